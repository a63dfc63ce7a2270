// Fuzz target: the USBTMC Bulk-IN header decoder and the transport's transfer assembly.
// The input is served as the device's Bulk-IN bytes (first byte: packet size) to a
// UsbtmcTransport reading one message; anything malformed must end in gonio::Error.
#include <algorithm>
#include <cstdint>
#include <span>
#include <vector>

#include "gonio/drivers/usbtmc/usbtmc.hpp"
#include "gonio/proto/error.hpp"

namespace {

namespace tmc = gonio::drivers::usbtmc;

class Replay final : public tmc::BulkEndpoints {
 public:
  Replay(std::span<const std::uint8_t> bytes, std::size_t packet) : in_(bytes), packet_(packet) {}
  std::string describe() const override { return "fuzz"; }
  void bulk_out(std::span<const std::uint8_t>, std::chrono::milliseconds) override {}
  std::size_t bulk_in(std::span<std::uint8_t> buf, std::chrono::milliseconds) override {
    if (in_.empty()) throw gonio::Error(gonio::Errc::timeout, "fuzz: no more bytes");
    const std::size_t n = std::min({buf.size(), packet_, in_.size()});
    std::copy_n(in_.begin(), n, buf.begin());
    in_ = in_.subspan(n);
    return n;
  }
  std::vector<std::uint8_t> control_in(std::uint8_t, tmc::Request, std::uint16_t, std::uint16_t,
                                       std::uint16_t length, std::chrono::milliseconds) override {
    std::vector<std::uint8_t> r(length, 0);
    if (!r.empty()) r[0] = 0x01;
    return r;
  }
  void clear_halt(bool, std::chrono::milliseconds) override {}
  std::uint8_t bulk_out_address() const override { return 0x02; }
  std::uint8_t bulk_in_address() const override { return 0x81; }
  std::uint8_t interface_number() const override { return 0; }
  std::size_t max_packet_size() const override { return packet_; }

 private:
  std::span<const std::uint8_t> in_;
  std::size_t packet_;
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::uint8_t> all(data, size);
  try {
    (void)tmc::decode_dev_dep_msg_in(all);
  } catch (const gonio::Error&) {
  }
  if (size < 1) return 0;
  const std::size_t packet = std::max<std::size_t>(1, data[0] % 65);
  tmc::Options opt;
  opt.max_transfer = 256;
  opt.abort_timeout = std::chrono::milliseconds(1);
  tmc::UsbtmcTransport t(std::make_unique<Replay>(all.subspan(1), packet), opt);
  char buf[64];
  try {
    // The first transfer's bTag is 1: inputs that start with a valid header get through.
    for (int i = 0; i < 64; ++i) {
      const auto r = t.read_some(buf, gonio::drivers::deadline_after(std::chrono::milliseconds(50)));
      if (r.end_of_message) break;
    }
  } catch (const gonio::Error&) {
  }
  return 0;
}
