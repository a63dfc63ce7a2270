// sd_notify: READY, STATUS, WATCHDOG and STOPPING reach $NOTIFY_SOCKET (a datagram socket
// standing in for systemd, as in sd_notify(3)).
#include <gtest/gtest.h>

#include "gonio/test/daemon_harness.hpp"

namespace gonio::test {
namespace {

class NotifySocket {
 public:
  explicit NotifySocket(const fs::path& path) : path_(path) {
    fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_un a{};
    a.sun_family = AF_UNIX;
    std::strncpy(a.sun_path, path.c_str(), sizeof a.sun_path - 1);
    if (::bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) throw std::runtime_error("bind notify socket");
  }
  ~NotifySocket() { ::close(fd_); }
  // Every datagram received within `timeout`, joined by newlines.
  std::string drain(std::chrono::milliseconds timeout) {
    std::string all;
    const auto end = Clock::now() + timeout;
    for (;;) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(end - Clock::now()).count();
      if (left <= 0) return all;
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, static_cast<int>(left)) <= 0) continue;
      char b[4096];
      const auto n = ::recv(fd_, b, sizeof b, 0);
      if (n > 0) all += std::string(b, static_cast<std::size_t>(n)) + "\n";
    }
  }

 private:
  fs::path path_;
  int fd_ = -1;
};

TEST(Systemd, NotifiesReadyStatusWatchdogAndStopping) {
  TempDir dir;
  NotifySocket ns(dir.path / "notify");
  Goniod g(dir.path / "state", mock_config({}),
           {"NOTIFY_SOCKET=" + (dir.path / "notify").string(), "WATCHDOG_USEC=200000"});
  auto c = g.unix_conn();
  const auto id = submit(c, "s", kTrueSample, json{{"geometries", {"45as15"}}});
  wait_state(c, id, {"completed"});
  const auto got = ns.drain(600ms);
  EXPECT_NE(got.find("READY=1"), std::string::npos) << got;
  EXPECT_NE(got.find("WATCHDOG=1"), std::string::npos) << got;
  EXPECT_NE(got.find("STATUS=scan " + std::to_string(id) + " completed"), std::string::npos) << got;
  EXPECT_EQ(g.stop(), 0);
  EXPECT_NE(ns.drain(300ms).find("STOPPING=1"), std::string::npos);
}

}  // namespace
}  // namespace gonio::test
