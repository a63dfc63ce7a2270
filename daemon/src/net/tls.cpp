// The TLS listeners' context and checks (tls.hpp, net.hpp), with Debian's OpenSSL.
#include "net/tls.hpp"

#include <sys/stat.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>

#include <fmt/format.h>
#include <openssl/err.h>
#include <openssl/pem.h>
#include <openssl/ssl.h>
#include <openssl/x509.h>
#include <spdlog/spdlog.h>

#include "gonio/daemon/net/net.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::daemon::net {

namespace {

// TLS 1.2: ECDHE key exchange (forward secrecy) and AEAD ciphers only, as Mozilla's
// "intermediate" profile without its DHE suites (RFC 7919 groups are not worth the
// handshake's cost here). TLS 1.3 suites are all AEAD and forward secret (RFC 8446 §9.1).
constexpr const char* kCiphers12 =
    "ECDHE-ECDSA-AES128-GCM-SHA256:ECDHE-RSA-AES128-GCM-SHA256:"
    "ECDHE-ECDSA-AES256-GCM-SHA384:ECDHE-RSA-AES256-GCM-SHA384:"
    "ECDHE-ECDSA-CHACHA20-POLY1305:ECDHE-RSA-CHACHA20-POLY1305";
constexpr const char* kSuites13 = "TLS_AES_128_GCM_SHA256:TLS_AES_256_GCM_SHA384:TLS_CHACHA20_POLY1305_SHA256";
constexpr const char* kGroups = "X25519:P-256:P-384";

// The last OpenSSL error of this thread, and the queue cleared.
std::string openssl_error() {
  unsigned long last = 0;
  while (const unsigned long e = ERR_get_error()) last = e;
  if (last == 0) return "unknown OpenSSL error";
  char text[256];
  ERR_error_string_n(last, text, sizeof text);
  return text;
}

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};
using File = std::unique_ptr<std::FILE, FileCloser>;
struct X509Free {
  void operator()(X509* x) const { X509_free(x); }
};
struct KeyFree {
  void operator()(EVP_PKEY* k) const { EVP_PKEY_free(k); }
};

std::string key_name(std::string_view name) { return fmt::format("server.tls.{}", name); }

File open_pem(const std::string& path, std::string_view name) {
  File f(std::fopen(path.c_str(), "rbe"));
  if (!f) throw Error::invalid(key_name(name), fmt::format("cannot read '{}': {}", path, std::strerror(errno)));
  return f;
}

std::string time_text(const ASN1_TIME* t) {
  std::unique_ptr<BIO, decltype(&BIO_free)> bio(BIO_new(BIO_s_mem()), &BIO_free);
  ASN1_TIME_print(bio.get(), t);
  char* data = nullptr;
  const long n = BIO_get_mem_data(bio.get(), &data);
  return std::string(data, static_cast<std::size_t>(n));
}

}  // namespace

void check_tls_files(const Config::Tls& t) {
  if (t.cert.empty() && t.key.empty()) return;
  // The key first: a key others can read is refused whatever else is wrong.
  struct stat st {};
  if (::stat(t.key.c_str(), &st) != 0)
    throw Error::invalid(key_name("key"), fmt::format("cannot read '{}': {}", t.key, std::strerror(errno)));
  if ((st.st_mode & 077) != 0)
    throw Error::invalid(key_name("key"),
                         fmt::format("'{}' has mode {:04o}: a private key must be accessible to its "
                                     "owner only (chmod 600)",
                                     t.key, st.st_mode & 07777));
  std::unique_ptr<X509, X509Free> cert;
  {
    const auto f = open_pem(t.cert, "cert");
    cert.reset(PEM_read_X509(f.get(), nullptr, nullptr, nullptr));
  }
  if (!cert)
    throw Error::invalid(key_name("cert"), fmt::format("'{}' holds no PEM certificate: {}", t.cert, openssl_error()));
  std::unique_ptr<EVP_PKEY, KeyFree> key;
  {
    const auto f = open_pem(t.key, "key");
    key.reset(PEM_read_PrivateKey(f.get(), nullptr, nullptr, nullptr));
  }
  if (!key)
    throw Error::invalid(key_name("key"),
                         fmt::format("'{}' holds no PEM private key (or it is encrypted): {}", t.key, openssl_error()));
  if (X509_check_private_key(cert.get(), key.get()) != 1) {
    ERR_clear_error();
    throw Error::invalid(key_name("key"),
                         fmt::format("'{}' is not the key of the certificate '{}'", t.key, t.cert));
  }
  if (X509_cmp_current_time(X509_get0_notAfter(cert.get())) <= 0)
    throw Error::invalid(key_name("cert"), fmt::format("'{}' expired on {}", t.cert,
                                                       time_text(X509_get0_notAfter(cert.get()))));
  if (X509_cmp_current_time(X509_get0_notBefore(cert.get())) >= 0)
    throw Error::invalid(key_name("cert"), fmt::format("'{}' is not valid before {}", t.cert,
                                                       time_text(X509_get0_notBefore(cert.get()))));
  if (!t.client_ca.empty()) {
    const auto f = open_pem(t.client_ca, "client_ca");
    std::unique_ptr<X509, X509Free> ca(PEM_read_X509(f.get(), nullptr, nullptr, nullptr));
    if (!ca)
      throw Error::invalid(key_name("client_ca"),
                           fmt::format("'{}' holds no PEM certificate: {}", t.client_ca, openssl_error()));
  }
}

namespace {

std::shared_ptr<TlsServer::Context> make_context(const Config::Tls& t) {
  check_tls_files(t);
  auto ctx = std::make_shared<TlsServer::Context>(TlsServer::Context::tls_server);
  SSL_CTX* h = ctx->native_handle();
  const auto fail = [](std::string_view name, const std::string& path) {
    return Error::invalid(key_name(name), fmt::format("'{}': {}", path, openssl_error()));
  };
  if (SSL_CTX_set_min_proto_version(h, TLS1_2_VERSION) != 1 || SSL_CTX_set_cipher_list(h, kCiphers12) != 1 ||
      SSL_CTX_set_ciphersuites(h, kSuites13) != 1 || SSL_CTX_set1_groups_list(h, kGroups) != 1)
    throw Error(Errc::internal, fmt::format("OpenSSL refuses goniod's TLS settings: {}", openssl_error()));
  // No compression (CRIME), no renegotiation (a client could make the server redo the
  // handshake's work at will).
  SSL_CTX_set_options(h, SSL_OP_NO_COMPRESSION | SSL_OP_NO_RENEGOTIATION);
  if (SSL_CTX_use_certificate_chain_file(h, t.cert.c_str()) != 1) throw fail("cert", t.cert);
  if (SSL_CTX_use_PrivateKey_file(h, t.key.c_str(), SSL_FILETYPE_PEM) != 1) throw fail("key", t.key);
  if (SSL_CTX_check_private_key(h) != 1) throw fail("key", t.key);
  static constexpr unsigned char kSessionContext[] = "goniod";
  SSL_CTX_set_session_id_context(h, kSessionContext, sizeof kSessionContext - 1);
  if (!t.client_ca.empty()) {
    if (SSL_CTX_load_verify_locations(h, t.client_ca.c_str(), nullptr) != 1) throw fail("client_ca", t.client_ca);
    STACK_OF(X509_NAME)* names = SSL_load_client_CA_file(t.client_ca.c_str());
    if (!names) throw fail("client_ca", t.client_ca);
    SSL_CTX_set_client_CA_list(h, names);
    // Asked for, not required: a peer without a certificate may still log in with a token.
    // One that presents a certificate the CA did not sign fails the handshake.
    SSL_CTX_set_verify(h, SSL_VERIFY_PEER, nullptr);
  }
  return ctx;
}

}  // namespace

TlsServer::TlsServer(Config::Tls files) : files_(std::move(files)), ctx_(make_context(files_)) {}

void TlsServer::reload() {
  auto next = make_context(files_);
  std::lock_guard lock(mu_);
  ctx_ = std::move(next);
}

std::optional<Principal> certificate_principal(SSL* ssl, const Auth& auth, std::string_view transport) {
  std::unique_ptr<X509, X509Free> cert(SSL_get1_peer_certificate(ssl));
  if (!cert || SSL_get_verify_result(ssl) != X509_V_OK) return std::nullopt;
  char cn[256] = {};
  const int n = X509_NAME_get_text_by_NID(X509_get_subject_name(cert.get()), NID_commonName, cn, sizeof cn);
  if (n <= 0 || static_cast<std::size_t>(n) >= sizeof cn) return std::nullopt;
  auto p = auth.named(std::string_view(cn, static_cast<std::size_t>(n)), transport);
  if (!p) spdlog::info("{}: a client certificate for '{}' names no token: the peer must log in", transport, cn);
  return p;
}

std::shared_ptr<TlsServer> make_tls_server(const Config& config) {
  if (config.tls.cert.empty()) return nullptr;
  return std::make_shared<TlsServer>(config.tls);
}

void reload_tls(TlsServer& tls) { tls.reload(); }

}  // namespace gonio::daemon::net
