// Golden replay of a captured Modbus RTU exchange (golden/modbus_rtu_capture.txt).
//
// The capture holds every request the driver sent and every reply of the device, as hex
// lines. Two checks:
//   - replay: a pty answers with the recorded replies, and the driver must send exactly
//     the recorded requests, byte for byte (frame layout, CRC, register addresses, the
//     16-register direct-data block, the order of polls), and read the right values;
//   - capture: the same calls against the simulator (instant motion, so the traffic
//     does not depend on timing) reproduces the golden file.
// GONIO_UPDATE_GOLDEN=1 rewrites the golden file from the simulator.
#include <fcntl.h>
#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include <gtest/gtest.h>

#include "gonio/sim/devsim/modbus_sim.hpp"
#include "gonio/drivers/modbus/modbus_motion.hpp"
#include "gonio/drivers/modbus/rtu_frame.hpp"
#include "motion_test_util.hpp"

using namespace motion_test;
using gonio::drivers::Axis;
namespace devsim = gonio::drivers::devsim;

namespace {

const std::filesystem::path kGolden =
    std::filesystem::path(GONIO_SOURCE_DIR) / "tests/integration/drivers/golden/modbus_rtu_capture.txt";

struct Exchange {
  std::vector<std::uint8_t> request;
  std::vector<std::uint8_t> reply;  // empty: the device stayed silent
  friend bool operator==(const Exchange&, const Exchange&) = default;
};

std::vector<std::uint8_t> parse_hex(const std::string& s) {
  std::vector<std::uint8_t> out;
  std::istringstream in(s);
  std::string byte;
  while (in >> byte) out.push_back(static_cast<std::uint8_t>(std::stoul(byte, nullptr, 16)));
  return out;
}

std::string to_hex(const std::vector<std::uint8_t>& v) {
  std::string s;
  for (const auto b : v) {
    static const char* digits = "0123456789abcdef";
    if (!s.empty()) s += ' ';
    s += digits[b >> 4];
    s += digits[b & 15];
  }
  return s;
}

std::vector<Exchange> load(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::vector<Exchange> out;
  std::string line;
  while (std::getline(in, line)) {
    if (line.size() < 2 || line[0] == '#') continue;
    if (line[0] == '>') out.push_back({parse_hex(line.substr(1)), {}});
    else if (line[0] == '<' && !out.empty()) out.back().reply = parse_hex(line.substr(1));
  }
  return out;
}

// The driver configuration of the capture, pinned here: any change to it changes the
// traffic (speeds and rates are in the direct-data block).
json golden_config(const std::string& device) {
  const auto ax = [](int unit) {
    return json{{"unit", unit},          {"steps_per_degree", 100}, {"speed_deg_s", 50},
                {"accel_deg_s2", 500},   {"in_position_deg", 0.02}, {"following_error_deg", 2}};
  };
  return json{{"links", {{"main", rtu_link(device)}}},
              {"response_timeout_ms", 100},
              {"retries", 1},
              {"poll_interval_ms", 5},
              {"settle_timeout_ms", 300},
              {"axes", {{"incidence", ax(1)}, {"receive", ax(2)}}}};
}

// The calls: status, two guarded moves (the guard reads both arm positions back before
// each), a readback, homing, status.
void drive(const std::string& device) {
  auto m = guarded_motion(golden_config(device), 10);
  const auto s0 = m->status(Axis::incidence, 2s);
  EXPECT_TRUE(s0.ready);
  EXPECT_DOUBLE_EQ(s0.position_deg, 0);
  m->move(Axis::incidence, 30, 2s);
  m->move(Axis::receive, 20, 2s);
  EXPECT_DOUBLE_EQ(m->position(Axis::receive, 2s), 20);
  m->home(Axis::incidence, 2s);
  const auto s1 = m->status(Axis::incidence, 2s);
  EXPECT_TRUE(s1.home_end);
  EXPECT_TRUE(s1.in_position);
  EXPECT_DOUBLE_EQ(s1.position_deg, 0);
}

// A pty that plays the device from a capture: reads each request, compares it with the
// recorded one, answers with the recorded reply.
class Replayer {
 public:
  explicit Replayer(std::vector<Exchange> script) : script_(std::move(script)) {
    master_ = posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC);
    if (master_ < 0 || grantpt(master_) != 0 || unlockpt(master_) != 0) throw std::runtime_error("pty");
    std::array<char, 128> name{};
    ptsname_r(master_, name.data(), name.size());
    path_ = name.data();
    slave_ = ::open(path_.c_str(), O_RDWR | O_NOCTTY | O_CLOEXEC);  // raw, held open
    termios t{};
    tcgetattr(slave_, &t);
    cfmakeraw(&t);
    tcsetattr(slave_, TCSANOW, &t);
    thread_ = std::thread([this] { run(); });
  }
  ~Replayer() {
    join();
    ::close(slave_);
    ::close(master_);
  }
  // Ends the replay (a script not yet consumed stays unserved); results are final after.
  void join() {
    done_ = true;
    if (thread_.joinable()) thread_.join();
  }
  const std::string& path() const { return path_; }
  std::size_t served() const { return served_; }
  const std::string& mismatch() const { return mismatch_; }

 private:
  void run() {
    std::vector<std::uint8_t> got;
    for (const auto& ex : script_) {
      got.clear();
      const auto until = std::chrono::steady_clock::now() + 3s;
      while (got.size() < ex.request.size() && std::chrono::steady_clock::now() < until && !done_) {
        pollfd p{master_, POLLIN, 0};
        if (::poll(&p, 1, 20) <= 0) continue;
        std::array<std::uint8_t, 256> buf{};
        const ssize_t n = ::read(master_, buf.data(), std::min(buf.size(), ex.request.size() - got.size()));
        if (n > 0) got.insert(got.end(), buf.begin(), buf.begin() + n);
      }
      if (got != ex.request) {
        mismatch_ = "request " + std::to_string(served_ + 1) + ": expected [" + to_hex(ex.request) +
                    "], got [" + to_hex(got) + "]";
        return;
      }
      if (!ex.reply.empty() && ::write(master_, ex.reply.data(), ex.reply.size()) < 0) return;
      ++served_;
    }
  }

  std::vector<Exchange> script_;
  int master_ = -1, slave_ = -1;
  std::string path_;
  std::thread thread_;
  std::atomic<bool> done_{false};
  std::atomic<std::size_t> served_{0};
  std::string mismatch_;
};

std::vector<Exchange> capture_from_simulator(const std::filesystem::path& out) {
  json cfg = sim_config(false, true);
  cfg["motion"] = "instant";
  cfg["record"] = out.string();
  devsim::ModbusSim sim(devsim::ModbusSimConfig::from_json(cfg));
  sim.start();
  drive(sim.rtu_path());
  sim.stop();
  return load(out);
}

}  // namespace

TEST(MotionGolden, CaptureIsWellFormed) {
  const auto golden = load(kGolden);
  ASSERT_GE(golden.size(), 10u) << "missing or short " << kGolden;
  bool block_write = false;
  for (const auto& ex : golden) {
    EXPECT_TRUE(gonio::drivers::modbus::crc_ok(ex.request)) << to_hex(ex.request);
    EXPECT_EQ(gonio::drivers::modbus::rtu_request_length(ex.request), static_cast<int>(ex.request.size()));
    ASSERT_FALSE(ex.reply.empty());
    EXPECT_TRUE(gonio::drivers::modbus::crc_ok(ex.reply)) << to_hex(ex.reply);
    EXPECT_EQ(ex.reply[0], ex.request[0]);  // the addressed unit answers
    EXPECT_EQ(ex.reply[1], ex.request[1]);  // no exception replies in this capture
    // The direct data operation: 16 registers from 0x0058, trigger = 1 last.
    if (ex.request[1] == 0x10 && ex.request[2] == 0x00 && ex.request[3] == 0x58) {
      block_write = true;
      ASSERT_EQ(ex.request.size(), 9u + 32u);
      EXPECT_EQ(ex.request[5], 16);
      const std::size_t trig = 7 + 28;  // 15th and 16th registers
      EXPECT_EQ((std::vector<std::uint8_t>(ex.request.begin() + trig, ex.request.begin() + trig + 4)),
                (std::vector<std::uint8_t>{0, 0, 0, 1}));
    }
  }
  EXPECT_TRUE(block_write);
}

TEST(MotionGolden, DriverSendsExactlyTheRecordedRequests) {
  const auto golden = load(kGolden);
  ASSERT_FALSE(golden.empty()) << "missing " << kGolden;
  Replayer replay(golden);
  drive(replay.path());
  replay.join();
  EXPECT_EQ(replay.mismatch(), "");
  EXPECT_EQ(replay.served(), golden.size());
}

TEST(MotionGolden, SimulatorReproducesTheCapture) {
  const auto tmp = std::filesystem::temp_directory_path() /
                   ("gonio-modbus-capture-" + std::to_string(::getpid()) + ".txt");
  const auto captured = capture_from_simulator(tmp);
  if (const char* update = std::getenv("GONIO_UPDATE_GOLDEN"); update && std::string(update) == "1") {
    std::filesystem::create_directories(kGolden.parent_path());
    std::filesystem::copy_file(tmp, kGolden, std::filesystem::copy_options::overwrite_existing);
  }
  std::filesystem::remove(tmp);
  const auto golden = load(kGolden);
  ASSERT_EQ(captured.size(), golden.size());
  for (std::size_t i = 0; i < golden.size(); ++i) {
    EXPECT_EQ(to_hex(captured[i].request), to_hex(golden[i].request)) << "exchange " << i + 1;
    EXPECT_EQ(to_hex(captured[i].reply), to_hex(golden[i].reply)) << "exchange " << i + 1;
  }
}
