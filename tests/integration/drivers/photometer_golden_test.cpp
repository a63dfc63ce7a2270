// Golden replay of a captured SCPI session (golden/photometer_gonio_session.txt): the
// driver must send exactly the captured commands, in order, and read the captured replies
// into the same readings. The capture was recorded from gonio-devsim's photometer; set
// GONIO_RECORD_GOLDEN=1 to record it again from the in-process simulator.
#include <cstdlib>
#include <deque>
#include <fstream>

#include <gtest/gtest.h>

#include "gonio/drivers/scpi/scpi.hpp"
#include "gonio/sim/devsim/scpi_sim.hpp"
#include "gonio/drivers/transport/tcp.hpp"
#include "gonio/proto/error.hpp"

using gonio::Errc;
using gonio::Error;
using namespace gonio::drivers;
using namespace std::chrono_literals;

namespace {

const std::string kGolden = std::string(GONIO_SOURCE_DIR) +
                            "/tests/integration/drivers/golden/photometer_gonio_session.txt";

// Wraps a transport and writes "> command" / "< reply" lines.
class Recorder final : public Transport {
 public:
  Recorder(TransportPtr inner, std::ostream& out) : inner_(std::move(inner)), out_(out) {}
  std::string describe() const override { return inner_->describe(); }
  void write(std::string_view m, Deadline d) override {
    out_ << "> " << m.substr(0, m.find('\n')) << "\n";
    inner_->write(m, d);
  }
  ReadResult read_some(std::span<char> b, Deadline d) override {
    const auto r = inner_->read_some(b, d);
    for (std::size_t i = 0; i < r.size; ++i) {
      if (b[i] == '\n') {
        out_ << "< " << line_ << "\n";
        line_.clear();
        continue;
      }
      line_ += b[i];
    }
    return r;
  }
  void clear(Deadline d) override { inner_->clear(d); }
  void cancel() noexcept override { inner_->cancel(); }

 private:
  TransportPtr inner_;
  std::ostream& out_;
  std::string line_;
};

// Plays a capture back: checks every write against the next "> " line and answers with
// the "< " lines that follow it.
class Replayer final : public Transport {
 public:
  explicit Replayer(std::deque<std::string> lines) : lines_(std::move(lines)) {}
  std::string describe() const override { return "golden replay"; }
  void write(std::string_view m, Deadline) override {
    const std::string cmd(m.substr(0, m.find('\n')));
    if (lines_.empty() || lines_.front().rfind("> ", 0) != 0)
      throw Error(Errc::protocol_error, "replay: unexpected command '" + cmd + "'");
    EXPECT_EQ(lines_.front().substr(2), cmd);
    lines_.pop_front();
    while (!lines_.empty() && lines_.front().rfind("< ", 0) == 0) {
      pending_ += lines_.front().substr(2) + "\n";
      lines_.pop_front();
    }
  }
  ReadResult read_some(std::span<char> b, Deadline) override {
    if (pending_.empty()) throw Error(Errc::timeout, "replay: no captured reply");
    const std::size_t n = std::min(b.size(), pending_.size());
    std::copy_n(pending_.begin(), n, b.begin());
    pending_.erase(0, n);
    return {n, false};
  }
  void clear(Deadline) override { pending_.clear(); }
  void cancel() noexcept override {}
  bool done() const { return lines_.empty() && pending_.empty(); }

 private:
  std::deque<std::string> lines_;
  std::string pending_;
};

struct Session {
  Identity id;
  gonio::WavelengthGrid grid;
  Reading dark, reference, sample;
};

Session run(Photometer& p) {
  Session s;
  s.id = p.identify(2s);
  s.grid = p.wavelengths(2s);
  p.set_integration_ms(20, 2s);
  s.dark = p.measure(Channel::dark, 2s);
  s.reference = p.measure(Channel::reference, 2s);
  s.sample = p.measure(Channel::sample, 2s);
  return s;
}

}  // namespace

TEST(PhotometerGolden, ReplaysTheCapturedSession) {
  if (std::getenv("GONIO_RECORD_GOLDEN") != nullptr) {
    devsim::ScpiSimConfig cfg;
    cfg.wavelengths = gonio::WavelengthGrid::parse("450:650:50");
    cfg.seed = 42;
    devsim::ScpiSimDevice dev(cfg, [](const gonio::Geometry&) {
      return std::vector<double>{0.2, 0.3, 0.4, 0.5, 0.6};
    });
    devsim::ScpiSimServer server(dev);
    TcpConfig tc;
    tc.port = server.listen_tcp();
    server.start();
    std::ofstream out(kGolden);
    auto p = scpi::make_photometer(std::make_unique<Recorder>(open_tcp(tc), out), {});
    run(*p);
  }
  std::ifstream in(kGolden);
  ASSERT_TRUE(in) << kGolden;
  std::deque<std::string> lines;
  for (std::string l; std::getline(in, l);) lines.push_back(l);
  ASSERT_GT(lines.size(), 10u);
  // The sample reply as captured, to compare the driver's reading against.
  std::string sample_reply;
  for (std::size_t i = 0; i + 1 < lines.size(); ++i)
    if (lines[i] == "> MEAS:SPEC? SAMP") sample_reply = lines[i + 1].substr(2);
  ASSERT_FALSE(sample_reply.empty());

  auto replay = std::make_unique<Replayer>(lines);
  auto* r = replay.get();
  auto p = scpi::make_photometer(std::move(replay), {});
  const auto s = run(*p);
  EXPECT_TRUE(r->done()) << "the driver sent fewer commands than captured";
  EXPECT_EQ(s.id.model, "SIM-SPM1");
  EXPECT_EQ(s.grid.size(), 5u);
  const auto fields = scpi::parse_numbers(sample_reply);
  ASSERT_EQ(fields.size(), 3u + 2 * 5);
  EXPECT_EQ(s.sample.saturated, fields[0] == 1);
  EXPECT_DOUBLE_EQ(s.sample.integration_ms, 1000 * fields[1]);
  for (std::size_t i = 0; i < 5; ++i) {
    EXPECT_DOUBLE_EQ(s.sample.spectrum.values[i], fields[3 + i]);
    EXPECT_DOUBLE_EQ(s.sample.spectrum.std_uncertainty[i], fields[8 + i]);
  }
  EXPECT_LT(s.dark.spectrum.values[2], s.sample.spectrum.values[2]);
  EXPECT_LT(s.sample.spectrum.values[2], s.reference.spectrum.values[2]);
}
