// The SCPI photometer driver end to end: against a gonio-devsim process over a real pty
// and over TCP loopback, against the in-process pm100 simulator, device errors and dead
// links as typed errors, and a golden replay of a captured SCPI session.
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <thread>

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "gonio/registry/registry.hpp"
#include "gonio/drivers/scpi/scpi.hpp"
#include "gonio/sim/devsim/scpi_sim.hpp"
#include "gonio/drivers/transport/serial.hpp"
#include "gonio/drivers/transport/tcp.hpp"
#include "gonio/proto/error.hpp"

extern char** environ;

using gonio::Errc;
using gonio::Error;
using namespace gonio::drivers;
using namespace std::chrono_literals;

namespace {

Errc code_of(auto&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.code();
  }
  return Errc::internal;
}

// gonio-devsim with a SCPI photometer on a pty and on TCP; reads the endpoints it prints.
class Devsim {
 public:
  explicit Devsim(const std::vector<std::string>& extra = {}) {
    int fds[2];
    if (::pipe(fds) != 0) throw std::runtime_error("pipe");
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_adddup2(&fa, fds[1], 1);
    posix_spawn_file_actions_addclose(&fa, fds[0]);
    const std::string exe = std::string(GONIO_BIN_DIR) + "/gonio-devsim";
    std::vector<std::string> args{exe, "--scpi-pty", "--scpi-tcp", "0", "--sample", "lambert:albedo=0.5"};
    args.insert(args.end(), extra.begin(), extra.end());
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    if (posix_spawn(&pid_, exe.c_str(), &fa, nullptr, argv.data(), environ) != 0)
      throw std::runtime_error("cannot start " + exe);
    posix_spawn_file_actions_destroy(&fa);
    ::close(fds[1]);
    FILE* f = ::fdopen(fds[0], "r");
    char line[256];
    for (int i = 0; i < 10 && std::fgets(line, sizeof line, f) != nullptr; ++i) {
      std::string s(line);
      if (!s.empty() && s.back() == '\n') s.pop_back();
      if (s.rfind("scpi-pty ", 0) == 0) pty = s.substr(9);
      if (s.rfind("scpi-tcp ", 0) == 0) tcp = s.substr(9);
      if (s == "ready") break;
    }
    std::fclose(f);
  }
  ~Devsim() { stop(); }
  void stop() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGTERM);
    int status = 0;
    ::waitpid(pid_, &status, 0);
    exit_status = status;
    pid_ = -1;
  }
  std::string pty, tcp;
  int exit_status = -1;

 private:
  pid_t pid_ = -1;
};

void exercise(Photometer& p) {
  const auto id = p.identify(2s);
  EXPECT_EQ(id.manufacturer, "GONIO");
  const auto grid = p.wavelengths(2s);
  ASSERT_EQ(grid.size(), 31u);
  EXPECT_DOUBLE_EQ(grid[0], 400);
  p.set_integration_ms(50, 2s);
  EXPECT_NEAR(p.integration_ms(2s), 50, 1e-9);
  EXPECT_EQ(code_of([&] { p.set_integration_ms(1e9, 2s); }), Errc::out_of_range);
  const auto d = p.measure(Channel::dark, 5s);
  const auto r = p.measure(Channel::reference, 5s);
  const auto s = p.measure(Channel::sample, 5s);
  EXPECT_NEAR(s.integration_ms, 50, 1e-9);
  EXPECT_FALSE(s.saturated);
  ASSERT_EQ(s.spectrum.size(), 31u);
  for (std::size_t i = 0; i < 31; ++i) {
    EXPECT_GT(s.spectrum.std_uncertainty[i], 0);
    // Lambertian albedo 0.5 through the twin: β ≈ 0.5 (noise ~1 % at these counts).
    const double beta = (s.spectrum.values[i] - d.spectrum.values[i]) /
                        (r.spectrum.values[i] - d.spectrum.values[i]);
    EXPECT_NEAR(beta, 0.5, 0.05) << grid[i];
  }
}

}  // namespace

TEST(PhotometerScpi, OverARealPtyAndTcpAgainstDevsim) {
  Devsim sim;
  ASSERT_FALSE(sim.pty.empty());
  ASSERT_FALSE(sim.tcp.empty());
  {
    auto p = make_photometer("scpi-serial", nlohmann::json{{"device", sim.pty}, {"baud", 115200}});
    exercise(*p);
    // Someone else holding the port is told so.
    EXPECT_EQ(code_of([&] { make_photometer("scpi-serial", nlohmann::json{{"device", sim.pty}}); }), Errc::busy);
  }
  const auto tcp = TcpConfig::parse(sim.tcp);
  auto p = make_photometer("scpi-tcp", nlohmann::json{{"host", tcp.host}, {"port", tcp.port}});
  exercise(*p);
  // pm100 commands against a gonio device: the device's own error, as device_alarm.
  nlohmann::json pm{{"host", tcp.host}, {"port", tcp.port}, {"preset", "pm100"}, {"wavelengths", "550"}};
  auto wrong = make_photometer("scpi-tcp", pm);
  EXPECT_EQ(code_of([&] { wrong->measure(Channel::sample, 2s); }), Errc::device_alarm);
  // The simulator goes away: the link is lost.
  sim.stop();
  EXPECT_TRUE(WIFEXITED(sim.exit_status) && WEXITSTATUS(sim.exit_status) == 0);
  EXPECT_EQ(code_of([&] { p->identify(1s); }), Errc::disconnected);
}

TEST(PhotometerScpi, AbsentDevices) {
  EXPECT_EQ(code_of([] { make_photometer("scpi-serial", nlohmann::json{{"device", "/dev/gonio-no-such-port"}}); }),
            Errc::not_found);
  EXPECT_EQ(code_of([] { make_photometer("scpi-tcp", nlohmann::json{{"host", "127.0.0.1"}, {"port", 1}}); }),
            Errc::not_found);
}

TEST(PhotometerScpi, Pm100PresetReadsOneWavelengthAtATime) {
  devsim::ScpiSimConfig cfg;
  cfg.preset = "pm100";
  cfg.identity = {"Thorlabs", "PM100D", "P0000001", "2.0"};
  devsim::ScpiSimDevice dev(cfg, [&](const gonio::Geometry&) {
    std::vector<double> b;
    for (const double nm : cfg.wavelengths) b.push_back(nm / 1000);  // β = λ/1000
    return b;
  });
  devsim::ScpiSimServer server(dev);
  const auto port = server.listen_tcp();
  server.start();
  auto p = make_photometer("scpi-tcp", nlohmann::json{{"host", "127.0.0.1"}, {"port", port},
                                                      {"preset", "pm100"}, {"wavelengths", "450,550,650"},
                                                      {"repeats", 4}, {"averages", 10}});
  EXPECT_EQ(p->identify(2s).model, "PM100D");
  EXPECT_FALSE(p->capabilities().dual_beam);
  EXPECT_EQ(code_of([&] { p->set_integration_ms(10, 1s); }), Errc::unsupported);
  const auto r = p->measure(Channel::sample, 5s);
  EXPECT_EQ(r.unit, "W");
  ASSERT_EQ(r.spectrum.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    const double want = 1e-3 * r.spectrum.wavelengths[i] / 1000;
    EXPECT_NEAR(r.spectrum.values[i], want, 5e-3 * want);
    EXPECT_GT(r.spectrum.std_uncertainty[i], 0);  // from 4 repeats
  }
  // A wavelength the meter does not accept is the device's error.
  auto out = make_photometer("scpi-tcp", nlohmann::json{{"host", "127.0.0.1"}, {"port", port},
                                                        {"preset", "pm100"}, {"wavelengths", "900"}});
  EXPECT_EQ(code_of([&] { out->measure(Channel::sample, 2s); }), Errc::device_alarm);
}

TEST(PhotometerScpi, SilentDeviceTimesOutAndGarbageIsAProtocolError) {
  devsim::ScpiSimConfig cfg;
  cfg.identity = {"GON\x01IO", "X", "1", "1"};  // a control byte in the reply
  devsim::ScpiSimDevice dev(cfg, [](const gonio::Geometry&) { return std::vector<double>(31, 0.5); });
  devsim::ScpiSimServer answering(dev);
  const auto port = answering.listen_tcp();
  answering.start();
  auto p = make_photometer("scpi-tcp", nlohmann::json{{"host", "127.0.0.1"}, {"port", port}});
  EXPECT_EQ(code_of([&] { p->identify(2s); }), Errc::protocol_error);

  // A listening socket nobody serves: the connection is queued, no reply ever comes.
  devsim::ScpiSimServer idle(dev);
  const auto idle_port = idle.listen_tcp();
  auto q = make_photometer("scpi-tcp", nlohmann::json{{"host", "127.0.0.1"}, {"port", idle_port}});
  EXPECT_EQ(code_of([&] { q->identify(200ms); }), Errc::timeout);
}

// A device that answers after the driver gave up: the late reply must never be taken for the
// reply to the next query (here: a reference spectrum read as the dark one). The session
// resynchronises (*OPC? marker) before the next query, whether the late reply has arrived
// by then (pty, after a pause) or is still on its way (TCP, at once).
TEST(PhotometerScpi, LateReplyIsNeverTakenForTheNextReading) {
  char path[] = "/tmp/gonio-late-XXXXXX";
  const int fd = ::mkstemp(path);
  ASSERT_GE(fd, 0);
  ::close(fd);
  // The 2nd measurement query is answered 700 ms late; dark ≈ 200 counts, reference ≈ 50 200.
  std::ofstream(path) << R"({"late_reply_at": 2, "late_reply_ms": 700})";
  for (const bool over_tcp : {false, true}) {
    SCOPED_TRACE(over_tcp ? "tcp" : "pty");
    Devsim sim({"--scpi-config", path});
    std::unique_ptr<Photometer> p;
    if (over_tcp) {
      const auto tcp = TcpConfig::parse(sim.tcp);
      p = make_photometer("scpi-tcp", nlohmann::json{{"host", tcp.host}, {"port", tcp.port}});
    } else {
      p = make_photometer("scpi-serial", nlohmann::json{{"device", sim.pty}, {"baud", 115200}});
    }
    p->measure(Channel::sample, 5s);
    EXPECT_EQ(code_of([&] { p->measure(Channel::reference, 250ms); }), Errc::timeout);
    if (!over_tcp) std::this_thread::sleep_for(1s);  // the late reply is waiting to be read
    const auto dark = p->measure(Channel::dark, 5s);
    const auto ref = p->measure(Channel::reference, 5s);
    ASSERT_EQ(dark.spectrum.size(), 31u);
    for (std::size_t i = 0; i < 31; ++i) {
      EXPECT_LT(dark.spectrum.values[i], 1000) << "a late reference reply read as dark, channel " << i;
      EXPECT_GT(ref.spectrum.values[i], 10000) << i;
    }
    EXPECT_EQ(p->identify(2s).manufacturer, "GONIO");  // and in step afterwards
  }
  std::remove(path);
}
