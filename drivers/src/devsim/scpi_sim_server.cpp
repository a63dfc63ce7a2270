// ScpiSimServer — offers a ScpiSimDevice on a pseudo-terminal (posix_openpt; the server keeps
// the slave open so that clients may come and go without a hang-up) and on a TCP port, one
// poll() loop on a background thread, one line buffer per client, NL-terminated replies.
#include <cerrno>
#include <cstring>
#include <algorithm>
#include <chrono>
#include <deque>
#include <map>

#include <fcntl.h>
#include <netinet/in.h>
#include <arpa/inet.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <termios.h>
#include <unistd.h>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "gonio/sim/devsim/scpi_sim.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::drivers::devsim {
namespace {

[[noreturn]] void fail(const char* what) {
  throw Error(Errc::io_error, fmt::format("scpi simulator: {}: {}", what, std::strerror(errno)));
}

constexpr std::size_t kMaxLine = 65536;

bool write_all(int fd, const std::string& s) {
  std::size_t done = 0;
  for (int spins = 0; done < s.size() && spins < 1000; ++spins) {
    const ssize_t n = ::write(fd, s.data() + done, s.size() - done);
    if (n > 0) {
      done += static_cast<std::size_t>(n);
    } else if (n < 0 && (errno == EAGAIN || errno == EINTR)) {
      pollfd p{fd, POLLOUT, 0};
      ::poll(&p, 1, 100);
    } else {
      return false;
    }
  }
  return done == s.size();
}

}  // namespace

ScpiSimServer::ScpiSimServer(ScpiSimDevice& device) : device_(device) {
  stop_fd_ = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (stop_fd_ < 0) fail("eventfd");
}

ScpiSimServer::~ScpiSimServer() {
  stop();
  for (const int fd : {pty_master_, pty_slave_, listen_fd_, stop_fd_})
    if (fd >= 0) ::close(fd);
}

std::string ScpiSimServer::open_pty() {
  pty_master_ = ::posix_openpt(O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (pty_master_ < 0) fail("posix_openpt");
  if (::grantpt(pty_master_) != 0 || ::unlockpt(pty_master_) != 0) fail("grantpt/unlockpt");
  char name[128];
  if (::ptsname_r(pty_master_, name, sizeof name) != 0) fail("ptsname_r");
  termios t{};
  ::tcgetattr(pty_master_, &t);
  ::cfmakeraw(&t);
  ::tcsetattr(pty_master_, TCSANOW, &t);
  pty_slave_ = ::open(name, O_RDWR | O_NOCTTY | O_CLOEXEC);  // held: no hang-up between clients
  if (pty_slave_ < 0) fail("open pty slave");
  return name;
}

std::uint16_t ScpiSimServer::listen_tcp(const std::string& host, std::uint16_t port) {
  listen_fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (listen_fd_ < 0) fail("socket");
  const int one = 1;
  ::setsockopt(listen_fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(port);
  if (::inet_pton(AF_INET, host.c_str(), &a.sin_addr) != 1)
    throw Error::invalid("listen", fmt::format("'{}' is not an IPv4 address", host));
  if (::bind(listen_fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) fail("bind");
  if (::listen(listen_fd_, 4) != 0) fail("listen");
  socklen_t len = sizeof a;
  ::getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&a), &len);
  return ntohs(a.sin_port);
}

void ScpiSimServer::start() {
  if (!thread_.joinable()) thread_ = std::thread([this] { run(); });
}

void ScpiSimServer::stop() {
  if (!thread_.joinable()) return;
  const std::uint64_t one = 1;
  [[maybe_unused]] const auto n = ::write(stop_fd_, &one, sizeof one);
  thread_.join();
}

void ScpiSimServer::run() {
  using Clock = std::chrono::steady_clock;
  std::map<int, std::string> clients;  // fd -> partial line; the pty master is a client too
  // Replies not yet due, per client, in order: a late reply holds back the ones after it.
  std::map<int, std::deque<std::pair<Clock::time_point, std::string>>> outbox;
  if (pty_master_ >= 0) clients[pty_master_];
  for (;;) {
    std::vector<int> closed;
    auto next_due = Clock::time_point::max();
    for (auto& [fd, q] : outbox) {
      while (!q.empty() && q.front().first <= Clock::now()) {
        if (!write_all(fd, q.front().second) && fd != pty_master_) closed.push_back(fd);
        q.pop_front();
      }
      if (!q.empty()) next_due = std::min(next_due, q.front().first);
    }
    int timeout_ms = -1;
    if (next_due != Clock::time_point::max())
      timeout_ms = static_cast<int>(std::max<long long>(
          1, std::chrono::duration_cast<std::chrono::milliseconds>(next_due - Clock::now()).count() + 1));
    std::vector<pollfd> fds{{stop_fd_, POLLIN, 0}};
    if (listen_fd_ >= 0) fds.push_back({listen_fd_, POLLIN, 0});
    for (const auto& [fd, buf] : clients) fds.push_back({fd, POLLIN, 0});
    if (::poll(fds.data(), fds.size(), timeout_ms) < 0) {
      if (errno == EINTR) continue;
      spdlog::error("scpi simulator: poll: {}", std::strerror(errno));
      return;
    }
    if (fds[0].revents) break;
    for (std::size_t i = 1; i < fds.size(); ++i) {
      if (!fds[i].revents) continue;
      const int fd = fds[i].fd;
      if (fd == listen_fd_) {
        const int c = ::accept4(listen_fd_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
        if (c >= 0) clients[c];
        continue;
      }
      char chunk[4096];
      const ssize_t n = ::read(fd, chunk, sizeof chunk);
      if (n <= 0) {
        if (n < 0 && (errno == EAGAIN || errno == EINTR)) continue;
        if (fd != pty_master_) closed.push_back(fd);
        continue;
      }
      auto& buf = clients[fd];
      buf.append(chunk, static_cast<std::size_t>(n));
      for (auto nl = buf.find('\n'); nl != std::string::npos; nl = buf.find('\n')) {
        auto line = buf.substr(0, nl);
        buf.erase(0, nl + 1);
        if (!line.empty() && line.back() == '\r') line.pop_back();
        const auto reply = device_.handle(line);
        const auto delay = device_.take_reply_delay();
        if (reply.empty()) continue;
        auto& q = outbox[fd];
        auto due = Clock::now() + delay;
        if (!q.empty()) due = std::max(due, q.back().first);
        if (delay.count() > 0) spdlog::debug("scpi simulator: answering '{}' {} ms late", line, delay.count());
        q.emplace_back(due, reply + "\n");
      }
      if (buf.size() > kMaxLine) buf.clear();  // a client that never ends its line
    }
    for (const int fd : closed) {
      if (!clients.contains(fd)) continue;
      ::close(fd);
      clients.erase(fd);
      outbox.erase(fd);
    }
  }
  for (const auto& [fd, buf] : clients)
    if (fd != pty_master_) ::close(fd);
}

}  // namespace gonio::drivers::devsim
