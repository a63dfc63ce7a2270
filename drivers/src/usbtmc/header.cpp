// USBTMC 1.0 bulk headers: encoding of DEV_DEP_MSG_OUT (§3.2.1.1, Table 3) and
// REQUEST_DEV_DEP_MSG_IN (§3.2.1.2, Table 4), strict decoding of DEV_DEP_MSG_IN (§3.3.1.1,
// Table 9). All multi-byte fields are little endian (§3, "USBTMC uses little endian").
#include <fmt/format.h>

#include "gonio/drivers/usbtmc/usbtmc.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::drivers::usbtmc {
namespace {

Header base(MsgId id, std::uint8_t tag, std::uint32_t size) {
  Header h{};
  h[0] = static_cast<std::uint8_t>(id);
  h[1] = tag;
  h[2] = static_cast<std::uint8_t>(~tag);
  h[3] = 0;
  for (int i = 0; i < 4; ++i) h[4 + i] = static_cast<std::uint8_t>(size >> (8 * i));
  return h;
}

}  // namespace

Header encode_dev_dep_msg_out(std::uint8_t tag, std::uint32_t transfer_size, bool eom) {
  Header h = base(MsgId::dev_dep_msg_out, tag, transfer_size);
  h[8] = eom ? 0x01 : 0x00;  // bmTransferAttributes D0 = EOM
  return h;
}

Header encode_request_dev_dep_msg_in(std::uint8_t tag, std::uint32_t max_size,
                                     std::optional<char> term_char) {
  Header h = base(MsgId::request_dev_dep_msg_in, tag, max_size);
  if (term_char) {
    h[8] = 0x02;  // D1 = TermCharEnabled
    h[9] = static_cast<std::uint8_t>(*term_char);
  }
  return h;
}

InHeader decode_dev_dep_msg_in(std::span<const std::uint8_t> b) {
  if (b.size() < kHeaderSize)
    throw Error(Errc::protocol_error,
                fmt::format("USBTMC: Bulk-IN transfer of {} bytes is shorter than its 12-byte header",
                            b.size()));
  if (b[0] != static_cast<std::uint8_t>(MsgId::request_dev_dep_msg_in))
    throw Error(Errc::protocol_error,
                fmt::format("USBTMC: Bulk-IN MsgID {} is not DEV_DEP_MSG_IN (2)", b[0]));
  if (static_cast<std::uint8_t>(~b[1]) != b[2])
    throw Error(Errc::protocol_error,
                fmt::format("USBTMC: bTagInverse 0x{:02x} does not match bTag 0x{:02x}", b[2], b[1]));
  if (b[1] == 0) throw Error(Errc::protocol_error, "USBTMC: bTag 0 is not allowed");
  if (b[3] != 0)
    throw Error(Errc::protocol_error, fmt::format("USBTMC: reserved header byte 3 is 0x{:02x}", b[3]));
  InHeader h;
  h.tag = b[1];
  for (int i = 0; i < 4; ++i) h.transfer_size |= static_cast<std::uint32_t>(b[4 + i]) << (8 * i);
  if (b[8] & 0xFC)
    throw Error(Errc::protocol_error,
                fmt::format("USBTMC: reserved bmTransferAttributes bits set (0x{:02x})", b[8]));
  h.eom = (b[8] & 0x01) != 0;
  h.term_char_matched = (b[8] & 0x02) != 0;
  return h;
}

}  // namespace gonio::drivers::usbtmc
