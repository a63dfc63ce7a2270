// Real servers for the MQTT and archive tests and benchmarks: a PostgreSQL cluster and a
// Mosquitto broker in temporary directories, on a Unix socket and a loopback port.
#pragma once

#include <pwd.h>
#include <sys/stat.h>

#include <array>
#include <cstdio>
#include <iterator>
#include <map>

#include "gonio/test/daemon_harness.hpp"

namespace gonio::test {

inline const std::string kPgBin = "/usr/lib/postgresql/15/bin";

inline int free_port() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a);
  socklen_t n = sizeof a;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &n);
  ::close(fd);
  return ntohs(a.sin_port);
}

// Output of a shell command (stdout), and its exit status.
inline std::pair<int, std::string> run(const std::string& cmd) {
  std::string out;
  FILE* p = ::popen(cmd.c_str(), "r");
  if (!p) return {-1, out};
  std::array<char, 4096> buf{};
  while (const auto n = std::fread(buf.data(), 1, buf.size(), p)) out.append(buf.data(), n);
  const int st = ::pclose(p);
  return {WIFEXITED(st) ? WEXITSTATUS(st) : -1, out};
}

// A PostgreSQL cluster in a temporary directory, listening on a Unix socket only. As root it
// runs as the 'postgres' account (the server refuses root).
class Postgres {
 public:
  explicit Postgres(const fs::path& dir) : dir_(dir), port_(free_port()) {
    const bool root = ::geteuid() == 0;
    if (root) {
      if (!::getpwnam("postgres")) throw std::runtime_error("no 'postgres' account");
      as_ = "runuser -u postgres -- ";
    }
    fs::create_directories(dir_ / "sock");
    ::chmod(dir_.parent_path().c_str(), 0755);
    ::chmod(dir_.c_str(), 0755);
    if (root) run("chown -R postgres: '" + dir_.string() + "'");
    const auto [rc, out] = run(as_ + kPgBin + "/initdb --no-sync -A trust -U postgres -D '" +
                               (dir_ / "data").string() + "' > '" + (dir_ / "initdb.log").string() + "' 2>&1");
    if (rc != 0) throw std::runtime_error("initdb failed: " + read(dir_ / "initdb.log"));
    start();
  }
  ~Postgres() { stop(); }
  void start() {
    const auto [rc, out] = run(as_ + kPgBin + "/pg_ctl -w -D '" + (dir_ / "data").string() + "' -l '" +
                               (dir_ / "server.log").string() + "' -o \"-p " + std::to_string(port_) +
                               " -k '" + (dir_ / "sock").string() +
                               "' -c listen_addresses='' -c fsync=off -c max_connections=30\" start 2>&1");
    if (rc != 0) throw std::runtime_error("pg_ctl start failed: " + out + read(dir_ / "server.log"));
    running_ = true;
  }
  void stop() {
    if (!running_) return;
    run(as_ + kPgBin + "/pg_ctl -w -m fast -D '" + (dir_ / "data").string() + "' stop > /dev/null 2>&1");
    running_ = false;
  }
  std::string conninfo() const {
    return "host=" + (dir_ / "sock").string() + " port=" + std::to_string(port_) +
           " user=postgres dbname=postgres";
  }
  // psql -At: rows as lines, columns by '|'.
  std::string query(const std::string& sql) const {
    const auto [rc, out] = run("psql \"" + conninfo() + "\" -v ON_ERROR_STOP=1 -At -c \"" + sql + "\" 2>&1");
    if (rc != 0) throw std::runtime_error("psql: " + out);
    return out;
  }

 private:
  static std::string read(const fs::path& p) {
    std::ifstream in(p);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
  }
  fs::path dir_;
  int port_;
  std::string as_;
  bool running_ = false;
};

// A Mosquitto broker on a loopback port, without persistence: a restart forgets every
// retained message, which goniod must publish again.
class Broker {
 public:
  // tls: a TLS listener with a CA made for the test (tls_files()), which requires clients to
  // present a certificate signed by it.
  explicit Broker(const fs::path& dir, bool tls = false) : dir_(dir), port_(free_port()), tls_(tls) {
    fs::create_directories(dir_);
    ::chmod(dir_.c_str(), 0755);
    std::ofstream conf(dir_ / "mosquitto.conf");
    conf << "listener " << port_ << " 127.0.0.1\nallow_anonymous true\npersistence false\n";
    if (tls_) {
      make_certificates();
      // As the test's own user: mosquitto started as root would read the files as its own
      // unprivileged account, which cannot enter the test's private temporary directory.
      conf << "user " << ::getpwuid(::geteuid())->pw_name << "\n";
      conf << "cafile " << (dir_ / "ca.crt").string() << "\ncertfile " << (dir_ / "server.crt").string()
           << "\nkeyfile " << (dir_ / "server.key").string() << "\nrequire_certificate true\n";
    }
    conf.close();
    start();
  }
  ~Broker() { kill(); }
  void start() {
    pid_ = ::fork();
    if (pid_ == 0) {
      const int fd = ::open((dir_ / "mosquitto.log").c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
      ::dup2(fd, 1), ::dup2(fd, 2);
      const auto conf = (dir_ / "mosquitto.conf").string();
      ::execlp("mosquitto", "mosquitto", "-c", conf.c_str(), static_cast<char*>(nullptr));
      ::_exit(127);
    }
    if (!eventually([&] {
          try {
            Conn c(connect_tcp("127.0.0.1", port_));
            return true;
          } catch (const std::exception&) {
            return false;
          }
        }, 10s))
      throw std::runtime_error("mosquitto did not come up");
  }
  void kill() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGKILL);
    ::waitpid(pid_, nullptr, 0);
    pid_ = -1;
  }
  int port() const { return port_; }
  // The CA, and a client certificate and key it signed (TLS brokers only).
  struct TlsFiles {
    fs::path ca, cert, key;
  };
  TlsFiles tls_files() const { return {dir_ / "ca.crt", dir_ / "client.crt", dir_ / "client.key"}; }
  std::string log() const {
    std::ifstream in(dir_ / "mosquitto.log");
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  }
  // Every retained message under `filter`: topic → payload.
  std::map<std::string, std::string> retained(const std::string& filter) const {
    std::string tls;
    if (tls_) {
      const auto f = tls_files();
      tls = " --cafile '" + f.ca.string() + "' --cert '" + f.cert.string() + "' --key '" + f.key.string() + "'";
    }
    const auto [rc, out] = run("mosquitto_sub -h 127.0.0.1 -p " + std::to_string(port_) + tls + " -t '" +
                               filter + "' --retained-only -v -W 2 2>/dev/null");
    std::map<std::string, std::string> m;
    std::istringstream in(out);
    for (std::string line; std::getline(in, line);) {
      const auto sp = line.find(' ');
      if (sp != std::string::npos) m[line.substr(0, sp)] = line.substr(sp + 1);
    }
    return m;
  }

 private:
  // A CA, and a server (for 127.0.0.1) and a client certificate signed by it: EC keys, valid
  // for a day.
  void make_certificates() const {
    const auto d = "'" + dir_.string() + "'";
    std::ofstream(dir_ / "server.ext") << "subjectAltName = IP:127.0.0.1, DNS:127.0.0.1, DNS:localhost\n";
    const std::string key = "-newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes";
    const std::string cmd =
        "cd " + d + " && openssl req -x509 " + key + " -keyout ca.key -out ca.crt -days 1 -subj '/CN=gonio test CA'"
        " && openssl req " + key + " -keyout server.key -out server.csr -subj '/CN=127.0.0.1'"
        " && openssl x509 -req -in server.csr -CA ca.crt -CAkey ca.key -CAcreateserial -out server.crt -days 1 -extfile server.ext"
        " && openssl req " + key + " -keyout client.key -out client.csr -subj '/CN=goniod'"
        " && openssl x509 -req -in client.csr -CA ca.crt -CAkey ca.key -CAcreateserial -out client.crt -days 1";
    const auto [rc, out] = run(cmd + " 2>&1");
    if (rc != 0) throw std::runtime_error("openssl: " + out);
  }

 private:
  fs::path dir_;
  int port_;
  bool tls_ = false;
  pid_t pid_ = -1;
};

inline bool servers_installed() {
  return fs::exists(kPgBin + "/initdb") &&
         run("command -v mosquitto mosquitto_sub psql openssl > /dev/null").first == 0;
}

}  // namespace gonio::test
