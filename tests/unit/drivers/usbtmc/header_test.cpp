// USBTMC bulk headers (drivers/src/usbtmc/header.cpp): the bytes of DEV_DEP_MSG_OUT and
// REQUEST_DEV_DEP_MSG_IN (USBTMC 1.0 §3.2.1), strict decoding of DEV_DEP_MSG_IN (§3.3.1.1).
#include <algorithm>
#include <array>
#include <cstdint>
#include <iterator>
#include <optional>
#include <span>

#include <gtest/gtest.h>

#include "gonio/drivers/usbtmc/usbtmc.hpp"
#include "gonio/proto/error.hpp"

namespace tmc = gonio::drivers::usbtmc;
using gonio::Errc;
using gonio::Error;

TEST(Usbtmc, HeaderEncoding) {
  const auto h = tmc::encode_dev_dep_msg_out(0x2A, 0x01020304, true);
  const tmc::Header want{1, 0x2A, 0xD5, 0, 0x04, 0x03, 0x02, 0x01, 0x01, 0, 0, 0};
  EXPECT_EQ(h, want);
  const auto r = tmc::encode_request_dev_dep_msg_in(7, 4096, '\n');
  const tmc::Header want_r{2, 7, 0xF8, 0, 0x00, 0x10, 0, 0, 0x02, '\n', 0, 0};
  EXPECT_EQ(r, want_r);
  EXPECT_EQ(tmc::encode_request_dev_dep_msg_in(7, 16, std::nullopt)[8], 0);
}

TEST(Usbtmc, HeaderDecodingIsStrict) {
  const std::uint8_t ok[12] = {2, 5, 0xFA, 0, 3, 0, 0, 0, 1, 0, 0, 0};
  const auto h = tmc::decode_dev_dep_msg_in(ok);
  EXPECT_EQ(h.tag, 5);
  EXPECT_EQ(h.transfer_size, 3u);
  EXPECT_TRUE(h.eom);
  auto broken = [&](int byte, std::uint8_t v) {
    std::array<std::uint8_t, 12> b;
    std::copy(std::begin(ok), std::end(ok), b.begin());
    b[static_cast<std::size_t>(byte)] = v;
    try {
      tmc::decode_dev_dep_msg_in(b);
    } catch (const Error& e) {
      return e.code();
    }
    return Errc::internal;
  };
  EXPECT_EQ(broken(0, 1), Errc::protocol_error);     // MsgID
  EXPECT_EQ(broken(2, 0xFB), Errc::protocol_error);  // bTagInverse
  EXPECT_EQ(broken(3, 1), Errc::protocol_error);     // reserved
  EXPECT_EQ(broken(8, 0x04), Errc::protocol_error);  // reserved attribute bit
  EXPECT_THROW(tmc::decode_dev_dep_msg_in(std::span(ok).first(11)), Error);
}
