// Divergence alerts end to end: a catalog BSDF that disagrees with the mock's true sample,
// alerts raised, deduplicated, pushed, and POSTed to a local HTTP receiver with retries.
#include <gtest/gtest.h>

#include <atomic>
#include <mutex>

#include "gonio/test/daemon_harness.hpp"

namespace gonio::test {
namespace {

// A tiny HTTP server on 127.0.0.1: the first `fail_first` requests get 500, the rest 200.
class Receiver {
 public:
  explicit Receiver(int fail_first) : fail_first_(fail_first) {
    fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ::bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a);
    ::listen(fd_, 16);
    socklen_t len = sizeof a;
    ::getsockname(fd_, reinterpret_cast<sockaddr*>(&a), &len);
    port = ntohs(a.sin_port);
    thread_ = std::thread([this] { run(); });
  }
  ~Receiver() {
    stop_ = true;
    ::shutdown(fd_, SHUT_RDWR);
    ::close(fd_);
    thread_.join();
  }
  int port = 0;
  std::vector<json> delivered() {
    std::lock_guard lock(mu_);
    return ok_;
  }
  int requests() const { return requests_.load(); }

 private:
  void run() {
    while (!stop_) {
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, 100) <= 0) continue;
      const int c = ::accept(fd_, nullptr, nullptr);
      if (c < 0) continue;
      std::string req;
      char b[8192];
      // Headers, then Content-Length bytes of body.
      std::size_t need = std::string::npos;
      while (true) {
        pollfd q{c, POLLIN, 0};
        if (::poll(&q, 1, 2000) <= 0) break;
        const auto n = ::recv(c, b, sizeof b, 0);
        if (n <= 0) break;
        req.append(b, static_cast<std::size_t>(n));
        const auto he = req.find("\r\n\r\n");
        if (he != std::string::npos && need == std::string::npos) {
          auto cl = req.find("Content-Length: ");
          if (cl == std::string::npos) cl = req.find("content-length: ");
          need = he + 4 + (cl == std::string::npos ? 0 : std::stoul(req.substr(cl + 16)));
        }
        if (need != std::string::npos && req.size() >= need) break;
      }
      const int n = ++requests_;
      const bool fail = n <= fail_first_;
      if (!fail && req.starts_with("POST /hook ")) {
        std::lock_guard lock(mu_);
        ok_.push_back(json::parse(req.substr(req.find("\r\n\r\n") + 4), nullptr, false));
      }
      const std::string res = fail ? "HTTP/1.1 500 Internal Server Error\r\nContent-Length: 0\r\nConnection: close\r\n\r\n"
                                   : "HTTP/1.1 200 OK\r\nContent-Length: 2\r\nConnection: close\r\n\r\nok";
      (void)!::send(c, res.data(), res.size(), MSG_NOSIGNAL);
      ::close(c);
    }
  }
  int fd_ = -1;
  int fail_first_;
  std::atomic<bool> stop_{false};
  std::atomic<int> requests_{0};
  std::mutex mu_;
  std::vector<json> ok_;
  std::thread thread_;
};

TEST(Alerts, DivergenceRaisesDedupedAlertsDeliveredByWebhookWithRetries) {
  Receiver rx(2);  // the first two POSTs fail
  TempDir dir;
  MockOptions o;
  o.extra = "[webhook]\nurl = \"http://127.0.0.1:" + std::to_string(rx.port) +
            "/hook\"\nretries = 4\nbackoff_s = 0.05\ntimeout_s = 2\n";
  Goniod g(dir.path, mock_config(o));
  auto c = g.unix_conn();
  auto sub = g.unix_conn();
  sub.call("subscribe", json{{"topics", {"alerts"}}});
  // The catalog says albedo 0.2, the sample on the stage is 0.6: every point diverges.
  const auto id = submit(c, "mislabelled", "lambert:albedo=0.2", json{{"grids", {"in=45;out=0:60:5"}}});
  const auto sc = wait_state(c, id, {"completed", "paused"});
  ASSERT_EQ(sc["state"], "completed") << sc.dump();
  EXPECT_EQ(sc["points_diverged"], 13);
  const auto alerts = c.call("alert.list", json{{"scan", id}});
  ASSERT_EQ(alerts.size(), 2u) << alerts.dump();  // one per cause, not one per point
  std::map<std::string, json> by_kind;
  for (const auto& a : alerts) by_kind[a["kind"].get<std::string>()] = a;
  EXPECT_EQ(by_kind["divergence"]["severity"], "warning");
  EXPECT_EQ(by_kind["divergence"]["count"], 13);
  EXPECT_EQ(by_kind["sustained_divergence"]["severity"], "critical");
  // Subscribers saw them.
  std::set<std::string> pushed;
  while (auto n = sub.notification(500ms)) pushed.insert((*n)["params"]["kind"].get<std::string>());
  EXPECT_TRUE(pushed.contains("divergence"));
  EXPECT_TRUE(pushed.contains("sustained_divergence"));
  // The receiver got both new alerts once each, after two refused attempts.
  ASSERT_TRUE(eventually([&] { return rx.delivered().size() >= 2; }, 10s)) << g.log_text();
  std::set<std::string> kinds;
  for (const auto& d : rx.delivered()) {
    EXPECT_EQ(d["event"], "alert.raised");
    kinds.insert(d["alert"]["kind"].get<std::string>());
  }
  EXPECT_EQ(kinds, (std::set<std::string>{"divergence", "sustained_divergence"}));
  EXPECT_EQ(rx.delivered().size(), 2u);
  EXPECT_EQ(rx.requests(), 4);
  const auto hook = c.call("system.info")["webhook"];
  EXPECT_EQ(hook["delivered"], 2);
  EXPECT_EQ(hook["failed"], 0);
}

TEST(Alerts, ReferenceWhiteDriftRaisesAHealthAlert) {
  TempDir dir;
  MockOptions o;
  o.lab = "lamp_drift_per_s = 0.02\n";  // 2 % per virtual second; a point takes about 0.4 s
  Goniod g(dir.path, mock_config(o));
  auto c = g.unix_conn();
  const auto id = submit(c, "tile", kTrueSample, json{{"grids", {"in=45;out=-20:40:5"}}});
  const auto sc = wait_state(c, id, {"completed", "paused"});
  ASSERT_EQ(sc["state"], "completed");
  // The reference is read with every point, so β itself stays right …
  EXPECT_EQ(sc["points_diverged"], 0);
  // … but the lamp's drift is reported.
  const auto alerts = c.call("alert.list", json{{"scan", id}});
  ASSERT_EQ(alerts.size(), 1u) << alerts.dump();
  EXPECT_EQ(alerts[0]["kind"], "reference_drift");
  EXPECT_EQ(alerts[0]["severity"], "warning");
  const auto last = c.call("scan.points", json{{"scan", id}, {"offset", 12}, {"limit", 1}})["points"][0];
  EXPECT_NE(std::find(last["flags"].begin(), last["flags"].end(), "reference_drift"), last["flags"].end());
}

}  // namespace
}  // namespace gonio::test
