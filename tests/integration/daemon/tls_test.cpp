// TLS on goniod's listeners, against a real goniod and real tools: a CA and certificates
// made by the openssl CLI at test time, openssl s_client for the protocol versions, curl
// --cacert on https://, gonioctl --ca on tls://, sslscan for what a scanner sees; a handshake
// that never finishes, a certificate renewed under SIGHUP while a session stays up, client
// certificates mapped to tokens, and --check-config refusing bad files by their key.
#include <sys/stat.h>
#include <sys/wait.h>

#include <openssl/err.h>
#include <openssl/ssl.h>
#include <openssl/x509v3.h>

#include <gtest/gtest.h>

#include "gonio/test/daemon_harness.hpp"

namespace gonio::test {
namespace {

struct Run {
  int rc = -1;
  std::string out;  // stdout and stderr
};

Run run(const std::string& cmd) {
  Run r;
  FILE* p = ::popen(("(" + cmd + ") 2>&1").c_str(), "r");
  if (!p) return r;
  char buf[4096];
  std::size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) r.out.append(buf, n);
  const int st = ::pclose(p);
  r.rc = WIFEXITED(st) ? WEXITSTATUS(st) : 128;
  return r;
}

std::string q(const fs::path& p) { return "'" + p.string() + "'"; }

// A test CA and what it signs, made with the openssl CLI (EC P-256: quick to generate).
struct Pki {
  TempDir dir;
  fs::path ca = dir.path / "ca.pem";

  Pki() {
    const auto r = run("cd " + q(dir.path) +
                       " && printf 'subjectAltName=IP:127.0.0.1\\n' > server.ext"
                       " && openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes -keyout ca.key"
                       " -out ca.pem -subj '/CN=gonio test CA' -days 2");
    if (r.rc != 0) throw std::runtime_error("openssl: " + r.out);
  }
  // NAME.pem and NAME.key (mode 0600) for subject CN `cn`, signed by `issuer` ("ca" or
  // another CA made by make_ca); `server`: a server certificate for 127.0.0.1 (not localhost).
  // `faketime`: the time it is made at (libfaketime), to make one that has expired.
  void issue(const std::string& name, const std::string& cn, bool server, const std::string& issuer = "ca",
             const std::string& faketime = {}) {
    const auto r = run("cd " + q(dir.path) + " && openssl req -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes -keyout " +
                       name + ".key -out " + name + ".csr -subj '/CN=" + cn + "' && " +
                       (faketime.empty() ? "" : "faketime '" + faketime + "' ") + "openssl x509 -req -in " + name +
                       ".csr -CA " + issuer + ".pem -CAkey " + issuer + ".key -CAcreateserial -days 1 -out " + name +
                       ".pem" + (server ? " -extfile server.ext" : "") + " && chmod 600 " + name + ".key");
    if (r.rc != 0) throw std::runtime_error("openssl: " + r.out);
  }
  void make_ca(const std::string& name) {
    const auto r = run("cd " + q(dir.path) + " && openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes -keyout " +
                       name + ".key -out " + name + ".pem -subj '/CN=" + name + "' -days 2");
    if (r.rc != 0) throw std::runtime_error("openssl: " + r.out);
  }
  fs::path pem(const std::string& name) const { return dir.path / (name + ".pem"); }
  fs::path key(const std::string& name) const { return dir.path / (name + ".key"); }
};

std::string tls_section(const Pki& pki, const std::string& name, const std::string& more = {}) {
  return "\n[server.tls]\ncert = \"" + pki.pem(name).string() + "\"\nkey = \"" + pki.key(name).string() + "\"\n" + more;
}

// goniod's mock lab listening on tls:// and https:// only.
std::string tls_config(const std::string& tls, const std::string& server_keys = {}) {
  MockOptions o;
  o.tcp = o.http = false;
  o.extra = tls;
  auto cfg = mock_config(o);
  cfg.replace(cfg.find("listen = []"), 11,
              "listen = [\"tls://127.0.0.1:0\", \"https://127.0.0.1:0\"]\n" + server_keys);
  return cfg;
}

std::string openssl_error() {
  const auto e = ERR_get_error();
  char text[256] = "unknown";
  if (e) ERR_error_string_n(e, text, sizeof text);
  ERR_clear_error();
  return text;
}

// An NDJSON connection over TLS (OpenSSL), verifying goniod against the test CA; optionally
// with a client certificate.
class TlsConn {
 public:
  TlsConn(int port, const fs::path& ca, const fs::path& cert = {}, const fs::path& key = {})
      : ctx_(SSL_CTX_new(TLS_client_method())) {
    SSL_CTX_load_verify_locations(ctx_, ca.c_str(), nullptr);
    SSL_CTX_set_verify(ctx_, SSL_VERIFY_PEER, nullptr);
    if (!cert.empty()) {
      SSL_CTX_use_certificate_file(ctx_, cert.c_str(), SSL_FILETYPE_PEM);
      SSL_CTX_use_PrivateKey_file(ctx_, key.c_str(), SSL_FILETYPE_PEM);
    }
    fd_ = connect_tcp("127.0.0.1", port);
    timeval tv{10, 0};
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    ssl_ = SSL_new(ctx_);
    SSL_set_fd(ssl_, fd_);
    X509_VERIFY_PARAM_set1_ip_asc(SSL_get0_param(ssl_), "127.0.0.1");
    if (SSL_connect(ssl_) != 1) {
      const auto why = openssl_error();
      this->~TlsConn();
      throw std::runtime_error("TLS handshake: " + why);
    }
  }
  ~TlsConn() {
    if (ssl_) SSL_free(ssl_);
    if (ctx_) SSL_CTX_free(ctx_);
    if (fd_ >= 0) ::close(fd_);
    ssl_ = nullptr, ctx_ = nullptr, fd_ = -1;
  }
  TlsConn(const TlsConn&) = delete;
  TlsConn& operator=(const TlsConn&) = delete;

  // The subject CN of the certificate goniod served.
  std::string server_cn() const {
    X509* cert = SSL_get1_peer_certificate(ssl_);
    char cn[256] = {};
    if (cert) X509_NAME_get_text_by_NID(X509_get_subject_name(cert), NID_commonName, cn, sizeof cn);
    X509_free(cert);
    return cn;
  }
  // The response object to a request; throws when the connection ends first.
  json request(const std::string& method, const json& params = json::object()) {
    const auto id = next_id_++;
    const auto text = json{{"jsonrpc", "2.0"}, {"id", id}, {"method", method}, {"params", params}}.dump() + "\n";
    if (SSL_write(ssl_, text.data(), static_cast<int>(text.size())) <= 0) throw std::runtime_error("TLS write: " + openssl_error());
    for (;;) {
      const auto nl = buf_.find('\n');
      if (nl != std::string::npos) {
        auto j = json::parse(buf_.substr(0, nl));
        buf_.erase(0, nl + 1);
        if (j.contains("id") && (j["id"] == id || j["id"].is_null())) return j;
        continue;
      }
      char b[16384];
      const int n = SSL_read(ssl_, b, sizeof b);
      if (n <= 0) throw std::runtime_error("TLS read: the connection ended (" + openssl_error() + ")");
      buf_.append(b, static_cast<std::size_t>(n));
    }
  }
  // Raw bytes out, and in until `until` has arrived (or the connection ends).
  void send_raw(const std::string& bytes) {
    if (SSL_write(ssl_, bytes.data(), static_cast<int>(bytes.size())) <= 0) throw std::runtime_error("TLS write: " + openssl_error());
  }
  std::string read_until(const std::string& until) {
    while (buf_.find(until) == std::string::npos) {
      char b[16384];
      const int n = SSL_read(ssl_, b, sizeof b);
      if (n <= 0) break;
      buf_.append(b, static_cast<std::size_t>(n));
    }
    const auto at = buf_.find(until);
    const auto end = at == std::string::npos ? buf_.size() : at + until.size();
    auto out = buf_.substr(0, end);
    buf_.erase(0, end);
    return out;
  }
  std::string read_exact(std::size_t n) {
    while (buf_.size() < n) {
      char b[16384];
      const int r = SSL_read(ssl_, b, sizeof b);
      if (r <= 0) throw std::runtime_error("TLS read: the connection ended");
      buf_.append(b, static_cast<std::size_t>(r));
    }
    auto out = buf_.substr(0, n);
    buf_.erase(0, n);
    return out;
  }
  // Writes `bytes` without reading; false once the connection has ended.
  bool write_all(const std::string& bytes) {
    int small = 4096;  // the kernel takes little of what goniod writes back
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &small, sizeof small);
    for (std::size_t off = 0; off < bytes.size();) {
      const int n = SSL_write(ssl_, bytes.data() + off, static_cast<int>(std::min<std::size_t>(bytes.size() - off, 16384)));
      if (n <= 0) return false;
      off += static_cast<std::size_t>(n);
    }
    return true;
  }
  json call(const std::string& method, const json& params = json::object()) {
    const auto r = request(method, params);
    if (r.contains("error")) throw std::runtime_error(method + ": " + r["error"].dump());
    return r["result"];
  }

 private:
  SSL_CTX* ctx_ = nullptr;
  SSL* ssl_ = nullptr;
  int fd_ = -1;
  std::string buf_;
  long long next_id_ = 1;
};

std::string bin(const std::string& exe) { return std::string(GONIO_BIN_DIR) + "/" + exe; }

TEST(Tls, OnlyTls12And13AreSpokenAndTheCertificateVerifies) {
  Pki pki;
  pki.issue("server", "goniod-test", true);
  TempDir dir;
  Goniod g(dir.path, tls_config(tls_section(pki, "server")));
  for (const char* scheme : {"tls://", "https://"}) {
    const auto connect = " -connect 127.0.0.1:" + std::to_string(port_of(g.uri(scheme)));
    for (const char* version : {"-tls1_2", "-tls1_3"}) {
      const auto r = run("openssl s_client -brief -verify_return_error -CAfile " + q(pki.ca) + connect + " " +
                         version + " < /dev/null");
      EXPECT_EQ(r.rc, 0) << scheme << " " << version << ": " << r.out;
      EXPECT_NE(r.out.find("Verification: OK"), std::string::npos) << r.out;
      EXPECT_NE(r.out.find(std::string("Protocol version: TLSv1.") + version[6]), std::string::npos) << r.out;
    }
    // The client offers TLS 1.1 (its own floor lowered): goniod answers with an alert.
    const auto old = run("openssl s_client -brief -tls1_1 -cipher 'DEFAULT:@SECLEVEL=0' -CAfile " + q(pki.ca) +
                         connect + " < /dev/null");
    EXPECT_NE(old.rc, 0) << old.out;
    EXPECT_NE(old.out.find("alert protocol version"), std::string::npos) << scheme << ": " << old.out;
  }
}

TEST(Tls, CurlPostsJsonRpcOverHttpsAndGonioctlCallsOverTlsAndHttps) {
  Pki pki;
  pki.issue("server", "goniod-test", true);
  TempDir dir;
  Goniod g(dir.path, tls_config(tls_section(pki, "server")));
  const auto token = g.admin_token();
  const auto https = "https://127.0.0.1:" + std::to_string(port_of(g.uri("https://")));
  const auto r = run("curl -sS --fail-with-body --cacert " + q(pki.ca) + " -H 'Content-Type: application/json' -H "
                     "'Authorization: Bearer " + token + "' -d '{\"jsonrpc\":\"2.0\",\"id\":1,\"method\":\"auth.whoami\"}' " +
                     https + "/rpc");
  ASSERT_EQ(r.rc, 0) << r.out;
  const auto who = json::parse(r.out);
  EXPECT_EQ(who["result"]["role"], "admin") << r.out;
  EXPECT_EQ(who["result"]["transport"], "https") << r.out;
  // Without the CA, curl refuses the server.
  const auto untrusted = run("curl -sS -d '{}' " + https + "/rpc");
  EXPECT_EQ(untrusted.rc, 60) << untrusted.out;  // curl: peer certificate cannot be authenticated

  const auto tls = g.uri("tls://");
  const auto ok = run(bin("gonioctl") + " --connect " + tls + " --ca " + q(pki.ca) + " --token " + token +
                      " --json call auth.whoami");
  ASSERT_EQ(ok.rc, 0) << ok.out;
  EXPECT_EQ(json::parse(ok.out)["transport"], "tls") << ok.out;
  const auto refused = run(bin("gonioctl") + " --connect " + tls + " --token " + token + " info");
  EXPECT_EQ(refused.rc, 3) << refused.out;  // cannot connect
  EXPECT_NE(refused.out.find("the server's certificate is not trusted"), std::string::npos) << refused.out;
  EXPECT_NE(refused.out.find("--ca"), std::string::npos) << refused.out;
  // gonioctl over https:// (POST /rpc, the token as a bearer header), verified the same way.
  const auto over_https = run(bin("gonioctl") + " --connect " + https + " --ca " + q(pki.ca) + " --token " + token +
                              " --json call auth.whoami");
  ASSERT_EQ(over_https.rc, 0) << over_https.out;
  EXPECT_EQ(json::parse(over_https.out)["transport"], "https") << over_https.out;
  const auto https_refused = run(bin("gonioctl") + " --connect " + https + " --token " + token + " info");
  EXPECT_EQ(https_refused.rc, 3) << https_refused.out;
  EXPECT_NE(https_refused.out.find("the server's certificate is not trusted"), std::string::npos) << https_refused.out;
  // The same server by a name its certificate does not carry: refused even with the CA.
  const auto wrong_host = run(bin("gonioctl") + " --connect tls://localhost:" + std::to_string(port_of(tls)) +
                              " --ca " + q(pki.ca) + " --token " + token + " info");
  EXPECT_EQ(wrong_host.rc, 3) << wrong_host.out;
  EXPECT_NE(wrong_host.out.find("hostname mismatch"), std::string::npos) << wrong_host.out;
}

// The dashboard's WebSocket over TLS: wss://HOST:PORT/ws, the bearer header at the upgrade.
TEST(Tls, AWebSocketOverHttpsIsWss) {
  Pki pki;
  pki.issue("server", "goniod-test", true);
  TempDir dir;
  Goniod g(dir.path, tls_config(tls_section(pki, "server")));
  TlsConn c(port_of(g.uri("https://")), pki.ca);
  c.send_raw("GET /ws HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
             "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n"
             "Authorization: Bearer " + g.admin_token() + "\r\n\r\n");
  const auto head = c.read_until("\r\n\r\n");
  ASSERT_TRUE(head.starts_with("HTTP/1.1 101")) << head;
  // One masked text frame (RFC 6455 §5.2), a payload under 126 bytes.
  const std::string call = json{{"jsonrpc", "2.0"}, {"id", 1}, {"method", "auth.whoami"}}.dump();
  std::string frame{static_cast<char>(0x81), static_cast<char>(0x80 | call.size()), 1, 2, 3, 4};
  for (std::size_t i = 0; i < call.size(); ++i) frame += static_cast<char>(call[i] ^ (1 + i % 4));
  c.send_raw(frame);
  const auto h = c.read_exact(2);
  ASSERT_EQ(static_cast<unsigned char>(h[0]), 0x81u);  // a final text frame, unmasked
  std::size_t n = static_cast<unsigned char>(h[1]);
  if (n == 126) {
    const auto ext = c.read_exact(2);
    n = (static_cast<std::size_t>(static_cast<unsigned char>(ext[0])) << 8) | static_cast<unsigned char>(ext[1]);
  }
  const auto answer = json::parse(c.read_exact(n));
  EXPECT_EQ(answer["result"]["transport"], "wss") << answer.dump();
  EXPECT_EQ(answer["result"]["role"], "admin") << answer.dump();
}

TEST(Tls, AHandshakeThatNeverFinishesIsCutAtTheDeadline) {
  Pki pki;
  pki.issue("server", "goniod-test", true);
  TempDir dir;
  Goniod g(dir.path, tls_config(tls_section(pki, "server")));  // read_timeout_s = 1
  for (const char* scheme : {"tls://", "https://"}) {
    Conn silent(connect_tcp("127.0.0.1", port_of(g.uri(scheme))));
    Conn partial(connect_tcp("127.0.0.1", port_of(g.uri(scheme))));
    partial.send_raw(std::string("\x16\x03\x01\x02\x00\x01", 6));  // a ClientHello's first bytes
    EXPECT_TRUE(silent.closed_by_peer(15s)) << scheme;
    EXPECT_TRUE(partial.closed_by_peer(15s)) << scheme;
  }
  const auto transports = g.unix_conn().call("system.info")["transports"];
  for (const auto& t : transports)
    if (t["endpoint"].get<std::string>().starts_with("tls://") || t["endpoint"].get<std::string>().starts_with("https://")) {
      EXPECT_EQ(t["connections"], 0) << t.dump();
      EXPECT_GE(t["dropped"].get<int>(), 2) << t.dump();
    }
  EXPECT_NE(g.log_text().find("TLS handshake did not complete within 1 s"), std::string::npos) << g.log_text();
}

// The plain listeners' limits hold over TLS: a peer that pipelines requests and never reads
// the answers is dropped as a slow reader, and the shared byte budget is given back.
TEST(Tls, APeerThatDoesNotReadIsDroppedAsOverPlainTcp) {
  Pki pki;
  pki.issue("server", "goniod-test", true);
  TempDir dir;
  Goniod g(dir.path, tls_config(tls_section(pki, "server"), "max_queue_bytes = 65536\nwrite_timeout_s = 1\n"));
  TlsConn c(port_of(g.uri("tls://")), pki.ca);
  c.call("auth.login", {{"token", g.admin_token()}});
  std::string lines;
  for (int i = 0; i < 400; ++i) lines += json{{"jsonrpc", "2.0"}, {"id", i}, {"method", "rpc.discover"}}.dump() + "\n";
  ::signal(SIGPIPE, SIG_IGN);  // OpenSSL writes with write(2): the drop must not end the test
  std::thread writer([&] { c.write_all(lines); });  // fails once goniod has dropped the peer
  const auto net = [&] { return g.unix_conn().call("system.info")["net"]; };
  const bool dropped = eventually([&] { return net()["slow_readers_dropped"].get<int>() >= 1; }, 20s);
  writer.join();
  EXPECT_TRUE(dropped) << net().dump();
  EXPECT_TRUE(eventually([&] { return net()["buffered_bytes"].get<std::size_t>() < 65536; })) << net().dump();
  // The server carries on (an answer within this test's 64 KiB queue: the OpenRPC document is larger).
  TlsConn next(port_of(g.uri("tls://")), pki.ca);
  next.call("auth.login", {{"token", g.admin_token()}});
  EXPECT_TRUE(next.call("system.info").contains("version")) << "a new peer is served";
}

TEST(Tls, SighupServesARenewedCertificateToNewConnectionsWhileOldSessionsGoOn) {
  Pki pki;
  pki.issue("a", "goniod-a", true);
  pki.issue("b", "goniod-b", true);
  // The configured files: a's now.
  fs::copy_file(pki.pem("a"), pki.pem("live"));
  fs::copy_file(pki.key("a"), pki.key("live"));
  TempDir dir;
  Goniod g(dir.path, tls_config(tls_section(pki, "live")));
  const int port = port_of(g.uri("tls://"));
  TlsConn old(port, pki.ca);
  EXPECT_EQ(old.server_cn(), "goniod-a");
  old.call("auth.login", {{"token", g.admin_token()}});

  // The renewed certificate is put in place, then goniod is told.
  fs::copy_file(pki.pem("b"), pki.pem("live"), fs::copy_options::overwrite_existing);
  fs::copy_file(pki.key("b"), pki.key("live"), fs::copy_options::overwrite_existing);
  ::kill(g.pid(), SIGHUP);
  EXPECT_TRUE(eventually([&] { return TlsConn(port, pki.ca).server_cn() == "goniod-b"; }));
  EXPECT_EQ(old.call("auth.whoami")["role"], "admin");  // the old session goes on
  EXPECT_EQ(old.server_cn(), "goniod-a");

  // A key that is not the certificate's: refused, logged, and b's stay in use.
  fs::copy_file(pki.key("a"), pki.key("live"), fs::copy_options::overwrite_existing);
  ::kill(g.pid(), SIGHUP);
  EXPECT_TRUE(eventually([&] { return g.log_text().find("SIGHUP: kept the TLS certificate in use") != std::string::npos; }))
      << g.log_text();
  EXPECT_NE(g.log_text().find("server.tls.key"), std::string::npos);
  EXPECT_EQ(TlsConn(port, pki.ca).server_cn(), "goniod-b");
  EXPECT_EQ(old.call("auth.whoami")["role"], "admin");
}

TEST(Tls, AClientCertificateLogsInAsTheTokenItsCnNames) {
  Pki pki;
  pki.issue("server", "goniod-test", true);
  pki.issue("tech", "lab-tech", false);
  pki.issue("stranger", "nobody-known", false);
  pki.make_ca("other-ca");
  pki.issue("forged", "lab-tech", false, "other-ca");
  const auto hash = run("printf %s tech-secret | sha256sum | cut -c1-64").out.substr(0, 64);
  TempDir dir;
  Goniod g(dir.path, tls_config(tls_section(pki, "server", "client_ca = \"" + pki.ca.string() + "\"\n") +
                                "\n[[auth.token]]\nname = \"lab-tech\"\nrole = \"technician\"\nsha256 = \"" + hash + "\"\n"));
  const int port = port_of(g.uri("tls://"));
  {
    TlsConn c(port, pki.ca, pki.pem("tech"), pki.key("tech"));
    const auto who = c.call("auth.whoami");
    EXPECT_EQ(who["name"], "lab-tech") << who.dump();
    EXPECT_EQ(who["role"], "technician") << who.dump();
  }
  {  // a CN that names no token: the peer must log in
    TlsConn c(port, pki.ca, pki.pem("stranger"), pki.key("stranger"));
    EXPECT_EQ(c.request("auth.whoami")["error"]["code"], -32000);
    EXPECT_EQ(c.call("auth.login", {{"token", "tech-secret"}})["role"], "technician");
  }
  {  // no certificate: as on plain TCP
    TlsConn c(port, pki.ca);
    EXPECT_EQ(c.call("auth.login", {{"token", "tech-secret"}})["role"], "technician");
  }
  // Signed by another CA: the handshake fails (TLS 1.3 tells the client on its first read).
  EXPECT_ANY_THROW({
    TlsConn c(port, pki.ca, pki.pem("forged"), pki.key("forged"));
    c.call("auth.whoami");
  });
  // https://: curl with the certificate, no bearer token.
  const auto r = run("curl -sS --cacert " + q(pki.ca) + " --cert " + q(pki.pem("tech")) + " --key " +
                     q(pki.key("tech")) + " -H 'Content-Type: application/json' -d "
                     "'{\"jsonrpc\":\"2.0\",\"id\":1,\"method\":\"auth.whoami\"}' https://127.0.0.1:" +
                     std::to_string(port_of(g.uri("https://"))) + "/rpc");
  ASSERT_EQ(r.rc, 0) << r.out;
  EXPECT_EQ(json::parse(r.out)["result"]["role"], "technician") << r.out;
}

TEST(Tls, CheckConfigRefusesBadFilesNamingTheKey) {
  Pki pki;
  pki.issue("server", "goniod-test", true);
  pki.issue("other", "goniod-other", true);
  pki.issue("expired", "goniod-old", true, "ca", "2020-01-01 00:00:00");
  TempDir dir;
  const auto check = [&](const std::string& tls) {
    std::ofstream(dir.path / "goniod.toml") << tls_config(tls);
    return run(bin("goniod") + " --check-config " + q(dir.path / "goniod.toml"));
  };
  const auto good = check(tls_section(pki, "server"));
  EXPECT_EQ(good.rc, 0) << good.out;

  fs::permissions(pki.key("server"), fs::perms::group_read | fs::perms::others_read, fs::perm_options::add);
  const auto readable = check(tls_section(pki, "server"));
  EXPECT_EQ(readable.rc, 2) << readable.out;
  EXPECT_NE(readable.out.find("server.tls.key"), std::string::npos) << readable.out;
  EXPECT_NE(readable.out.find("mode 0644"), std::string::npos) << readable.out;
  EXPECT_NE(readable.out.find(pki.key("server").string()), std::string::npos) << readable.out;
  // goniod itself refuses to start on it, before the state directory is made.
  const auto state = dir.path / "state";
  const auto start = run(bin("goniod") + " --state-dir " + q(state) + " --config " + q(dir.path / "goniod.toml"));
  EXPECT_EQ(start.rc, 2) << start.out;
  EXPECT_NE(start.out.find("server.tls.key"), std::string::npos) << start.out;
  EXPECT_FALSE(fs::exists(state));
  fs::permissions(pki.key("server"), fs::perms::owner_read | fs::perms::owner_write, fs::perm_options::replace);

  const auto mismatched = check("\n[server.tls]\ncert = \"" + pki.pem("server").string() + "\"\nkey = \"" +
                                pki.key("other").string() + "\"\n");
  EXPECT_EQ(mismatched.rc, 2) << mismatched.out;
  EXPECT_NE(mismatched.out.find("server.tls.key"), std::string::npos) << mismatched.out;
  EXPECT_NE(mismatched.out.find("is not the key of the certificate"), std::string::npos) << mismatched.out;

  const auto expired = check(tls_section(pki, "expired"));
  EXPECT_EQ(expired.rc, 2) << expired.out;
  EXPECT_NE(expired.out.find("server.tls.cert"), std::string::npos) << expired.out;
  // Made a day long at 2020-01-01 00:00 under libfaketime, whose clock runs on while openssl
  // works: the second is not fixed.
  EXPECT_NE(expired.out.find("expired on Jan  2 00:00:"), std::string::npos) << expired.out;
  EXPECT_NE(expired.out.find(" 2020 GMT"), std::string::npos) << expired.out;

  const auto missing = check("\n[server.tls]\ncert = \"" + (pki.dir.path / "none.pem").string() + "\"\nkey = \"" +
                             pki.key("server").string() + "\"\n");
  EXPECT_EQ(missing.rc, 2) << missing.out;
  EXPECT_NE(missing.out.find("server.tls.cert"), std::string::npos) << missing.out;
  EXPECT_NE(missing.out.find("No such file or directory"), std::string::npos) << missing.out;

  const auto no_cert = check("");
  EXPECT_EQ(no_cert.rc, 2) << no_cert.out;
  EXPECT_NE(no_cert.out.find("server.listen[0]"), std::string::npos) << no_cert.out;
  EXPECT_NE(no_cert.out.find("server.tls.cert"), std::string::npos) << no_cert.out;
}

// What Debian's sslscan finds: TLS 1.2 and 1.3 only, and every cipher accepted forward
// secret (ECDHE, or TLS 1.3) and AEAD (GCM, ChaCha20-Poly1305).
TEST(Tls, SslscanFindsNoOldProtocolAndNoWeakCipher) {
  Pki pki;
  pki.issue("server", "goniod-test", true);
  TempDir dir;
  Goniod g(dir.path, tls_config(tls_section(pki, "server")));
  const auto r = run("sslscan --no-colour --no-heartbleed 127.0.0.1:" + std::to_string(port_of(g.uri("tls://"))));
  ASSERT_EQ(r.rc, 0) << r.out;
  for (const char* off : {"SSLv2     disabled", "SSLv3     disabled", "TLSv1.0   disabled", "TLSv1.1   disabled",
                          "TLSv1.2   enabled", "TLSv1.3   enabled"})
    EXPECT_NE(r.out.find(off), std::string::npos) << off << "\n" << r.out;
  std::istringstream lines(r.out);
  std::string line;
  int accepted = 0;
  while (std::getline(lines, line)) {
    if (!line.starts_with("Accepted") && !line.starts_with("Preferred")) continue;
    ++accepted;
    std::istringstream f(line);
    std::string state, version, bits, unit, cipher;
    f >> state >> version >> bits >> unit >> cipher;
    EXPECT_TRUE(version == "TLSv1.2" || version == "TLSv1.3") << line;
    if (version == "TLSv1.2") {
      EXPECT_TRUE(cipher.starts_with("ECDHE-")) << line;
    }
    EXPECT_TRUE(cipher.find("GCM") != std::string::npos || cipher.find("CHACHA20") != std::string::npos) << line;
  }
  EXPECT_GE(accepted, 4) << r.out;
  EXPECT_EQ(r.out.find("Compression enabled"), std::string::npos) << r.out;
}

}  // namespace
}  // namespace gonio::test
