// `gonio-probe modbus-axis` (run_modbus_axis) against the simulator over TCP and RTU, its
// messages and documented exit codes; and the gonio-devsim Modbus entry (run_modbus_sim).
#include <atomic>
#include <mutex>
#include <sstream>
#include <thread>

#include <gtest/gtest.h>

#include "gonio/sim/devsim/modbus_sim.hpp"
#include "gonio/drivers/modbus/link.hpp"
#include "gonio/drivers/probe/modbus_probe.hpp"
#include "motion_test_util.hpp"

using namespace motion_test;
namespace devsim = gonio::drivers::devsim;
namespace probe = gonio::drivers::probe;

namespace {

// An output stream another thread may write while this one reads.
class SharedText : public std::streambuf {
 public:
  std::string snapshot() {
    std::lock_guard lock(mu_);
    return text_;
  }

 protected:
  int_type overflow(int_type c) override {
    if (c != traits_type::eof()) {
      std::lock_guard lock(mu_);
      text_ += static_cast<char>(c);
    }
    return c;
  }
  std::streamsize xsputn(const char* s, std::streamsize n) override {
    std::lock_guard lock(mu_);
    text_.append(s, static_cast<std::size_t>(n));
    return n;
  }

 private:
  std::mutex mu_;
  std::string text_;
};

struct ProbeRun {
  int code = -1;
  std::string out, err;
};

class MotionProbe : public ::testing::Test {
 protected:
  void SetUp() override {
    sim_ = std::make_unique<devsim::ModbusSim>(devsim::ModbusSimConfig::from_json(sim_config(true, true)));
    sim_->start();
  }
  probe::ModbusAxisOptions tcp(std::string command, double target = 0) const {
    probe::ModbusAxisOptions o;
    o.tcp = "127.0.0.1:" + std::to_string(sim_->tcp_port());
    o.unit = 1;
    o.steps_per_degree = 100;
    o.command = std::move(command);
    o.target_deg = target;
    o.speed_deg_s = 100;
    o.timeout = 5s;
    return o;
  }
  static ProbeRun run(const probe::ModbusAxisOptions& o) {
    std::ostringstream out, err;
    ProbeRun r;
    r.code = probe::run_modbus_axis(o, out, err);
    r.out = out.str();
    r.err = err.str();
    return r;
  }

  std::unique_ptr<devsim::ModbusSim> sim_;
};

}  // namespace

TEST_F(MotionProbe, StatusMoveHomeOverTcp) {
  auto r = run(tcp("status"));
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("position  0.0000° (0 steps)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("ready"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("alarm     none"), std::string::npos) << r.out;

  r = run(tcp("move", -12.5));
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("-12.5000°"), std::string::npos) << r.out;
  EXPECT_EQ(sim_->axis(1).command, -1250);

  r = run(tcp("home"));
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(sim_->axis(1).command, 0);
  EXPECT_TRUE(sim_->axis(1).home_end);
}

TEST_F(MotionProbe, MoveOverRtuWithFormat) {
  auto o = tcp("move", 7.25);
  o.tcp.clear();
  o.rtu = sim_->rtu_path() + ",115200,8E1";
  o.unit = 2;
  const auto r = run(o);
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(sim_->axis(2).command, 725);
}

TEST_F(MotionProbe, UsageErrorsSendNothing) {
  const auto before = sim_->requests();
  auto both = tcp("status");
  both.rtu = "/dev/ttyUSB0";
  EXPECT_EQ(run(both).code, 2);
  auto bad_unit = tcp("status");
  bad_unit.unit = 0;
  EXPECT_EQ(run(bad_unit).code, 2);
  auto bad_steps = tcp("status");
  bad_steps.steps_per_degree = 0;
  EXPECT_EQ(run(bad_steps).code, 2);
  auto bad_format = tcp("status");
  bad_format.tcp.clear();
  bad_format.rtu = sim_->rtu_path() + ",115200,8X1";
  const auto f = run(bad_format);
  EXPECT_EQ(f.code, 2);
  EXPECT_NE(f.err.find("8X1"), std::string::npos) << f.err;
  auto bad_preset = tcp("status");
  bad_preset.preset = "ezs";
  EXPECT_EQ(run(bad_preset).code, 2);
  auto bad_cmd = tcp("jog");
  EXPECT_EQ(run(bad_cmd).code, 2);
  auto bad_host = tcp("status");
  bad_host.tcp = "localhost";
  EXPECT_EQ(run(bad_host).code, 2);
  EXPECT_EQ(sim_->requests(), before);
}

TEST_F(MotionProbe, ExitCodesForDeviceTrouble) {
  // Absent: nothing listens on the port any more.
  auto absent = tcp("status");
  absent.timeout = 300ms;
  sim_->set_offline(true);
  auto r = run(absent);
  EXPECT_EQ(r.code, 3) << r.err;
  EXPECT_NE(r.err.find("unit 1 on tcp 127.0.0.1"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("hint:"), std::string::npos) << r.err;
  sim_->set_offline(false);

  // Absent serial device.
  auto no_tty = tcp("status");
  no_tty.tcp.clear();
  no_tty.rtu = "/dev/gonio-no-such-tty";
  no_tty.timeout = 300ms;
  EXPECT_EQ(run(no_tty).code, 3);

  // Silent unit: timeout.
  auto silent = tcp("status");
  silent.unit = 7;
  silent.timeout = 1s;
  EXPECT_EQ(run(silent).code, 4);

  // Nonsense replies.
  sim_->corrupt_next_replies(100);
  EXPECT_EQ(run(tcp("status")).code, 5);
  sim_->corrupt_next_replies(0);

  // Alarm: status reports it (exit 6), a move is refused with it.
  sim_->raise_alarm(1, 0x30);
  r = run(tcp("status"));
  EXPECT_EQ(r.code, 6);
  EXPECT_NE(r.out.find("0x30"), std::string::npos) << r.out;
  r = run(tcp("move", 5));
  EXPECT_EQ(r.code, 6);
  EXPECT_NE(r.err.find("0x30"), std::string::npos) << r.err;

  // Busy: STOP held on by someone else.
  gonio::drivers::modbus::LinkConfig lc;
  lc.name = "t";
  lc.port = sim_->tcp_port();
  gonio::drivers::modbus::ModbusLink link(lc, {});
  link.write(2, 0x7D, std::array<std::uint16_t, 1>{0x0020}, gonio::drivers::modbus::Clock::now() + 1s);
  auto busy = tcp("move", 1);
  busy.unit = 2;
  EXPECT_EQ(run(busy).code, 7);
}

TEST(MotionDevsim, RunModbusSimPrintsEndpointsAndServes) {
  std::atomic<bool> stop{false};
  SharedText buf;
  std::ostream out(&buf);
  std::atomic<int> code{-1};
  const json cfg = sim_config(true, true);
  std::thread t([&] { code = devsim::run_modbus_sim(cfg, out, stop); });
  // The two endpoint lines appear once the simulator is up.
  std::string text;
  ASSERT_TRUE(wait_until([&] {
    text = buf.snapshot();
    return text.find("modbus-rtu /dev/pts/") != std::string::npos;
  }));
  const auto at = text.find("modbus-tcp 127.0.0.1:");
  ASSERT_NE(at, std::string::npos) << text;
  const int port = std::stoi(text.substr(at + 21));
  probe::ModbusAxisOptions o;
  o.tcp = "127.0.0.1:" + std::to_string(port);
  o.steps_per_degree = 100;
  o.command = "status";
  o.timeout = 2s;
  std::ostringstream pout, perr;
  EXPECT_EQ(probe::run_modbus_axis(o, pout, perr), 0) << perr.str();
  stop = true;
  t.join();
  EXPECT_EQ(code, 0);
}
