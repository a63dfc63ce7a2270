// USBTMC transport (drivers/src/usbtmc/transport.cpp) against an in-memory device behind
// BulkEndpoints: bTag sequencing and wrap-around, messages split across transfers (EOM only
// on the last), replies arriving in several packets, short transfers, and the abort / clear
// sequences on timeouts.
#include <deque>
#include <functional>

#include <gtest/gtest.h>

#include "gonio/drivers/scpi/scpi.hpp"
#include "gonio/drivers/usbtmc/usbtmc.hpp"
#include "gonio/proto/error.hpp"

namespace tmc = gonio::drivers::usbtmc;
using gonio::Errc;
using gonio::Error;
using gonio::drivers::deadline_after;
using namespace std::chrono_literals;

namespace {

struct ControlCall {
  std::uint8_t type;
  tmc::Request request;
  std::uint16_t value, index, length;
};

// A USBTMC device in memory: it collects DEV_DEP_MSG_OUT payloads until EOM, answers each
// complete message through `respond`, and serves REQUEST_DEV_DEP_MSG_IN from the queued
// reply, `packet` bytes per bulk_in call. Knobs make it misbehave.
class FakeDevice final : public tmc::BulkEndpoints {
 public:
  struct State {
    std::vector<std::vector<std::uint8_t>> out_transfers;  // every bulk-OUT, verbatim
    std::vector<std::string> messages;                     // complete messages received
    std::vector<ControlCall> control;
    std::vector<bool> clear_halts;
    std::string reply;             // bytes not yet sent to the host
    std::deque<std::uint8_t> in;   // the current Bulk-IN transfer, not yet read
    std::string partial;
    std::function<std::string(const std::string&)> respond = [](const std::string& m) {
      return "echo:" + m;
    };
    std::size_t packet = 64;       // bytes per bulk_in call (max packet size)
    bool stall_in = false;         // bulk_in times out
    bool wrong_tag = false;        // reply carries another bTag
    int pending_checks = 0;        // CHECK_* answers STATUS_PENDING this many times
    std::vector<std::uint8_t> forged;  // if set: the next Bulk-IN transfer, verbatim
  };

  explicit FakeDevice(std::shared_ptr<State> s) : s_(std::move(s)) {}

  std::string describe() const override { return "fake 0000:0000"; }

  void bulk_out(std::span<const std::uint8_t> data, std::chrono::milliseconds) override {
    s_->out_transfers.emplace_back(data.begin(), data.end());
    EXPECT_EQ(data.size() % 4, 0u) << "Bulk-OUT transfers are padded to 4 bytes";
    ASSERT_GE(data.size(), tmc::kHeaderSize);
    const std::uint8_t id = data[0], tag = data[1];
    std::uint32_t size = 0;
    for (int i = 0; i < 4; ++i) size |= static_cast<std::uint32_t>(data[4 + i]) << (8 * i);
    if (id == 1) {
      s_->partial.append(reinterpret_cast<const char*>(data.data()) + tmc::kHeaderSize, size);
      if (data[8] & 1) {
        s_->messages.push_back(s_->partial);
        s_->reply += s_->respond(s_->partial);
        s_->partial.clear();
      }
    } else if (id == 2 && !s_->forged.empty()) {
      s_->in.assign(s_->forged.begin(), s_->forged.end());
      s_->forged.clear();
    } else if (id == 2) {
      const std::size_t n = std::min<std::size_t>(size, s_->reply.size());
      const bool eom = n == s_->reply.size();
      const std::uint8_t t = s_->wrong_tag ? static_cast<std::uint8_t>(tag + 1) : tag;
      std::vector<std::uint8_t> h{2, t, static_cast<std::uint8_t>(~t), 0};
      for (int i = 0; i < 4; ++i) h.push_back(static_cast<std::uint8_t>(n >> (8 * i)));
      h.insert(h.end(), {static_cast<std::uint8_t>(eom ? 1 : 0), 0, 0, 0});
      h.insert(h.end(), s_->reply.begin(), s_->reply.begin() + static_cast<std::ptrdiff_t>(n));
      while (h.size() % 4) h.push_back(0);
      s_->reply.erase(0, n);
      s_->in.assign(h.begin(), h.end());
    }
  }

  std::size_t bulk_in(std::span<std::uint8_t> buf, std::chrono::milliseconds) override {
    if (s_->stall_in || s_->in.empty()) throw Error(Errc::timeout, "fake: bulk-IN timed out");
    const std::size_t n = std::min({buf.size(), s_->packet, s_->in.size()});
    for (std::size_t i = 0; i < n; ++i) {
      buf[i] = s_->in.front();
      s_->in.pop_front();
    }
    return n;
  }

  std::vector<std::uint8_t> control_in(std::uint8_t type, tmc::Request r, std::uint16_t value,
                                       std::uint16_t index, std::uint16_t length,
                                       std::chrono::milliseconds) override {
    s_->control.push_back({type, r, value, index, length});
    const auto status = [&]() -> std::uint8_t {
      if (r == tmc::Request::check_abort_bulk_in_status || r == tmc::Request::check_abort_bulk_out_status ||
          r == tmc::Request::check_clear_status)
        if (s_->pending_checks > 0) return --s_->pending_checks, 0x02;
      return 0x01;
    }();
    std::vector<std::uint8_t> out(length, 0);
    if (!out.empty()) out[0] = status;
    if (r == tmc::Request::initiate_abort_bulk_in || r == tmc::Request::initiate_abort_bulk_out)
      out[1] = static_cast<std::uint8_t>(value);
    if (r == tmc::Request::initiate_abort_bulk_in || r == tmc::Request::initiate_clear) {
      s_->in.clear();
      s_->reply.clear();
    }
    return out;
  }

  void clear_halt(bool in, std::chrono::milliseconds) override { s_->clear_halts.push_back(in); }
  std::uint8_t bulk_out_address() const override { return 0x02; }
  std::uint8_t bulk_in_address() const override { return 0x81; }
  std::uint8_t interface_number() const override { return 0; }
  std::size_t max_packet_size() const override { return s_->packet; }

 private:
  std::shared_ptr<State> s_;
};

struct Rig {
  std::shared_ptr<FakeDevice::State> state = std::make_shared<FakeDevice::State>();
  std::unique_ptr<tmc::UsbtmcTransport> t;
  explicit Rig(tmc::Options o = {}) {
    t = std::make_unique<tmc::UsbtmcTransport>(std::make_unique<FakeDevice>(state), o);
  }
  std::string read_message() {
    std::string out;
    char buf[7];  // deliberately small: many read_some calls per message
    for (int i = 0; i < 10000; ++i) {
      const auto r = t->read_some(buf, deadline_after(1s));
      out.append(buf, r.size);
      if (r.end_of_message) return out;
    }
    ADD_FAILURE() << "no EOM";
    return out;
  }
};

}  // namespace

TEST(Usbtmc, TagWrapsFrom255To1) {
  EXPECT_EQ(tmc::next_tag(1), 2);
  EXPECT_EQ(tmc::next_tag(254), 255);
  EXPECT_EQ(tmc::next_tag(255), 1);
  EXPECT_EQ(tmc::next_tag(0), 1);
}

TEST(Usbtmc, QueryRoundTripWithTagSequence) {
  Rig rig;
  rig.t->write("*IDN?\n", deadline_after(1s));
  EXPECT_EQ(rig.read_message(), "echo:*IDN?\n");
  ASSERT_EQ(rig.state->out_transfers.size(), 2u);
  EXPECT_EQ(rig.state->out_transfers[0][1], 1);  // DEV_DEP_MSG_OUT, bTag 1
  EXPECT_EQ(rig.state->out_transfers[1][0], 2);  // REQUEST_DEV_DEP_MSG_IN
  EXPECT_EQ(rig.state->out_transfers[1][1], 2);  // bTag 2
  EXPECT_EQ(rig.state->out_transfers[0].size(), 20u);  // 12 + 6 + 2 alignment bytes
}

TEST(Usbtmc, TagSequenceWrapsOverManyTransfers) {
  Rig rig;
  std::vector<int> tags;
  for (int i = 0; i < 200; ++i) {
    rig.t->write("Q", deadline_after(1s));
    EXPECT_EQ(rig.read_message(), "echo:Q");
  }
  for (const auto& tr : rig.state->out_transfers) tags.push_back(tr[1]);
  ASSERT_EQ(tags.size(), 400u);
  for (std::size_t i = 1; i < tags.size(); ++i) {
    EXPECT_NE(tags[i], 0);
    EXPECT_EQ(tags[i], tags[i - 1] == 255 ? 1 : tags[i - 1] + 1) << i;
  }
  EXPECT_EQ(tags[255], 1);  // the 256th transfer wrapped
}

TEST(Usbtmc, LongMessagesSplitWithEomOnlyOnLast) {
  tmc::Options o;
  o.max_transfer = 8;
  Rig rig(o);
  const std::string msg = "MEAS:SPEC? SAMPLE\n";  // 18 bytes → 8 + 8 + 2
  rig.t->write(msg, deadline_after(1s));
  ASSERT_EQ(rig.state->out_transfers.size(), 3u);
  EXPECT_EQ(rig.state->out_transfers[0][8], 0);
  EXPECT_EQ(rig.state->out_transfers[1][8], 0);
  EXPECT_EQ(rig.state->out_transfers[2][8], 1);
  EXPECT_EQ(rig.state->messages.at(0), msg);
  // The 23-byte reply comes back in three DEV_DEP_MSG_IN transfers, EOM on the last.
  EXPECT_EQ(rig.read_message(), "echo:" + msg);
  int requests = 0;
  for (const auto& tr : rig.state->out_transfers) requests += tr[0] == 2;
  EXPECT_EQ(requests, 3);
}

TEST(Usbtmc, ReplyArrivingInSmallPackets) {
  Rig rig;
  rig.state->packet = 4;  // header and payload spread over many bulk-IN reads
  rig.t->write("X?", deadline_after(1s));
  EXPECT_EQ(rig.read_message(), "echo:X?");
}

TEST(Usbtmc, ShortTransferIsAProtocolError) {
  Rig rig;
  rig.t->write("Y?", deadline_after(1s));
  // Forge the next Bulk-IN transfer: the header says 40 bytes, a short packet of 4 follows.
  const std::uint8_t tag = tmc::next_tag(rig.t->last_tag());
  rig.state->forged = {2, tag, static_cast<std::uint8_t>(~tag), 0, 40, 0, 0, 0, 1, 0, 0, 0, 'a', 'b', 'c', 'd'};
  try {
    char buf[16];
    rig.t->read_some(buf, deadline_after(1s));
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::protocol_error) << e.what();
  }
}

TEST(Usbtmc, WrongTagIsAProtocolErrorAndClearsTheDevice) {
  Rig rig;
  rig.state->wrong_tag = true;
  rig.t->write("X?", deadline_after(1s));
  try {
    rig.read_message();
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::protocol_error);
  }
  ASSERT_FALSE(rig.state->control.empty());
  EXPECT_EQ(rig.state->control.front().request, tmc::Request::initiate_clear);
}

TEST(Usbtmc, TimeoutAbortsTheBulkInTransfer) {
  Rig rig;
  rig.state->stall_in = true;
  rig.state->pending_checks = 2;
  rig.t->write("MEAS?", deadline_after(1s));
  try {
    char buf[16];
    rig.t->read_some(buf, deadline_after(50ms));
    FAIL() << "expected a timeout";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::timeout);
  }
  const auto request_tag = rig.t->last_tag();
  const auto& c = rig.state->control;
  ASSERT_GE(c.size(), 4u);  // initiate + 2 pending checks + final check
  EXPECT_EQ(c[0].type, tmc::kRequestTypeEndpoint);
  EXPECT_EQ(c[0].request, tmc::Request::initiate_abort_bulk_in);
  EXPECT_EQ(c[0].value, request_tag);
  EXPECT_EQ(c[0].index, 0x81);
  EXPECT_EQ(c[0].length, 2);
  for (std::size_t i = 1; i < c.size(); ++i) {
    EXPECT_EQ(c[i].request, tmc::Request::check_abort_bulk_in_status);
    EXPECT_EQ(c[i].length, 8);
  }
  EXPECT_EQ(c.size(), 4u);
  // The link works again afterwards.
  rig.state->stall_in = false;
  rig.t->write("OK?", deadline_after(1s));
  EXPECT_EQ(rig.read_message(), "echo:OK?");
}

TEST(Usbtmc, ClearRunsInitiateClearAndClearsTheOutHalt) {
  Rig rig;
  rig.state->pending_checks = 1;
  rig.t->clear(deadline_after(1s));
  const auto& c = rig.state->control;
  ASSERT_EQ(c.size(), 3u);
  EXPECT_EQ(c[0].request, tmc::Request::initiate_clear);
  EXPECT_EQ(c[0].type, tmc::kRequestTypeInterface);
  EXPECT_EQ(c[1].request, tmc::Request::check_clear_status);
  EXPECT_EQ(c[2].request, tmc::Request::check_clear_status);
  ASSERT_EQ(rig.state->clear_halts.size(), 1u);
  EXPECT_FALSE(rig.state->clear_halts[0]);
}

TEST(Usbtmc, ScpiSessionOverUsbtmcUsesEom) {
  // A reply without a trailing newline still ends at EOM.
  auto state = std::make_shared<FakeDevice::State>();
  state->respond = [](const std::string&) { return std::string("GONIO,SIM,1,1.0"); };
  gonio::drivers::scpi::Session s(
      std::make_unique<tmc::UsbtmcTransport>(std::make_unique<FakeDevice>(state)));
  EXPECT_EQ(s.query("*IDN?", deadline_after(1s)), "GONIO,SIM,1,1.0");
  EXPECT_EQ(state->messages.at(0), "*IDN?\n");
}

TEST(Usbtmc, SelectorParsing) {
  const auto d = tmc::DeviceSelector::parse("1313:8078:P0001234");
  EXPECT_EQ(d.vid, 0x1313);
  EXPECT_EQ(d.pid, 0x8078);
  EXPECT_EQ(d.serial, "P0001234");
  EXPECT_EQ(d.describe(), "1313:8078:P0001234");
  EXPECT_THROW(tmc::DeviceSelector::parse("1313"), Error);
  EXPECT_THROW(tmc::DeviceSelector::parse("xyz:8078"), Error);
  EXPECT_THROW(tmc::DeviceSelector::parse("12345:1"), Error);
}
