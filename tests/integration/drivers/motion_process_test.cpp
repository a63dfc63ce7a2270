// The Modbus motion pieces as real processes: gonio-devsim serving the AZ simulator on TCP
// and on a pty, gonio-probe modbus-axis and the driver talking to it, SIGTERM ending it.
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "gonio/drivers/modbus/modbus_motion.hpp"
#include "motion_test_util.hpp"

extern char** environ;

using namespace motion_test;
using gonio::drivers::Axis;

namespace {

struct Exit {
  int code = -1;
  std::string out;
};

// Starts `exe args...` with stdout on a pipe.
pid_t spawn(const std::string& exe, std::vector<std::string> args, int& out_fd) {
  std::array<int, 2> fds{};
  if (pipe2(fds.data(), O_CLOEXEC) != 0) return -1;
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_adddup2(&fa, fds[1], 1);
  args.insert(args.begin(), exe);
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = -1;
  if (posix_spawn(&pid, exe.c_str(), &fa, nullptr, argv.data(), environ) != 0) pid = -1;
  posix_spawn_file_actions_destroy(&fa);
  ::close(fds[1]);
  out_fd = fds[0];
  return pid;
}

// Reads from `fd` until `pred(text)` or EOF or `limit`.
std::string read_until(int fd, const std::function<bool(const std::string&)>& pred,
                       std::chrono::milliseconds limit) {
  std::string text;
  const auto end = std::chrono::steady_clock::now() + limit;
  while (!pred(text) && std::chrono::steady_clock::now() < end) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 50) <= 0) continue;
    std::array<char, 512> buf{};
    const ssize_t n = ::read(fd, buf.data(), buf.size());
    if (n <= 0) break;
    text.append(buf.data(), static_cast<std::size_t>(n));
  }
  return text;
}

int wait_exit(pid_t pid, std::chrono::milliseconds limit) {
  const auto end = std::chrono::steady_clock::now() + limit;
  int status = 0;
  while (std::chrono::steady_clock::now() < end) {
    if (::waitpid(pid, &status, WNOHANG) == pid) return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    std::this_thread::sleep_for(5ms);
  }
  ::kill(pid, SIGKILL);
  ::waitpid(pid, &status, 0);
  return -1;
}

Exit probe(std::vector<std::string> args) {
  int fd = -1;
  const pid_t pid = spawn(std::string(GONIO_BIN_DIR) + "/gonio-probe", std::move(args), fd);
  Exit e;
  if (pid < 0) return e;
  e.out = read_until(fd, [](const std::string&) { return false; }, 10s);  // until EOF
  ::close(fd);
  e.code = wait_exit(pid, 10s);
  return e;
}

class MotionProcess : public ::testing::Test {
 protected:
  void SetUp() override {
    pid_ = spawn(std::string(GONIO_BIN_DIR) + "/gonio-devsim",
                 {"--modbus-tcp", "0", "--modbus-rtu", "--units", "2"}, out_);
    ASSERT_GT(pid_, 0) << "cannot start " << GONIO_BIN_DIR << "/gonio-devsim";
    const auto text = read_until(out_, [](const std::string& t) { return t.find("ready\n") != std::string::npos; }, 10s);
    const auto tcp = text.find("modbus-tcp 127.0.0.1:");
    const auto rtu = text.find("modbus-rtu ");
    ASSERT_NE(tcp, std::string::npos) << text;
    ASSERT_NE(rtu, std::string::npos) << text;
    port_ = std::stoi(text.substr(tcp + 21));
    pty_ = text.substr(rtu + 11, text.find('\n', rtu) - rtu - 11);
  }
  void TearDown() override {
    if (pid_ > 0) {
      ::kill(pid_, SIGTERM);
      EXPECT_EQ(wait_exit(pid_, 5s), 0);
    }
    if (out_ >= 0) ::close(out_);
  }
  std::vector<std::string> axis_args(std::vector<std::string> link, int unit) const {
    std::vector<std::string> a{"modbus-axis"};
    a.insert(a.end(), link.begin(), link.end());
    for (const std::string& s : {std::string("--unit"), std::to_string(unit), std::string("--preset"),
                                 std::string("az"), std::string("--steps-per-degree"), std::string("100"),
                                 std::string("--speed"), std::string("100")})
      a.push_back(s);
    return a;
  }

  pid_t pid_ = -1;
  int out_ = -1;
  int port_ = 0;
  std::string pty_;
};

}  // namespace

TEST_F(MotionProcess, ProbeDrivesTheSimulatorOverTcpAndRtu) {
  const std::string tcp = "127.0.0.1:" + std::to_string(port_);
  auto args = axis_args({"--tcp", tcp}, 1);
  args.insert(args.end(), {"move", "12.5"});
  auto r = probe(args);
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("12.5000°"), std::string::npos) << r.out;

  args = axis_args({"--rtu", pty_ + ",115200,8E1"}, 1);
  args.push_back("status");
  r = probe(args);
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("position  12.5000° (1250 steps)"), std::string::npos) << r.out;

  args = axis_args({"--tcp", tcp}, 9);  // no such unit
  args.insert(args.end(), {"--timeout-ms", "1000", "status"});
  EXPECT_EQ(probe(args).code, 4);

  args = axis_args({"--tcp", tcp}, 1);
  args.insert(args.end(), {"jog"});
  EXPECT_EQ(probe(args).code, 2);
}

TEST_F(MotionProcess, DriverAgainstTheSimulatorProcess) {
  auto m = gonio::drivers::make_modbus_motion(driver_config(tcp_link(port_)));
  m->move(Axis::receive, -15, 5s);
  m->move(Axis::incidence, 60, 5s);
  EXPECT_DOUBLE_EQ(m->position(Axis::receive, 1s), -15);
  EXPECT_DOUBLE_EQ(m->position(Axis::incidence, 1s), 60);
  m->home(Axis::incidence, 5s);
  EXPECT_TRUE(m->status(Axis::incidence, 1s).home_end);
}
