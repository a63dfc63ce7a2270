// Modbus RTU framing (drivers/src/modbus/rtu_frame.cpp): the CRC against published frames,
// and the length of a request from its first bytes.
#include <array>
#include <cstdint>
#include <span>

#include <gtest/gtest.h>

#include "gonio/drivers/modbus/rtu_frame.hpp"

namespace mb = gonio::drivers::modbus;

TEST(MotionRtuFrame, CrcMatchesPublishedFrames) {
  // Oriental Motor FAQ: writing −1000 to 1802h of unit 1 ends with CRC 99h 58h.
  const std::array<std::uint8_t, 13> write{0x01, 0x10, 0x18, 0x02, 0x00, 0x02, 0x04,
                                           0xFF, 0xFF, 0xFC, 0x18, 0x99, 0x58};
  EXPECT_TRUE(mb::crc_ok(write));
  EXPECT_EQ(mb::crc16(std::span(write).first(11)), 0x5899);
  auto bad = write;
  bad[7] ^= 1;
  EXPECT_FALSE(mb::crc_ok(bad));
  // Read one holding register at 0 from unit 1: the textbook 84 0A.
  const std::array<std::uint8_t, 8> read{0x01, 0x03, 0x00, 0x00, 0x00, 0x01, 0x84, 0x0A};
  EXPECT_TRUE(mb::crc_ok(read));
}

TEST(MotionRtuFrame, RequestLengths) {
  const std::array<std::uint8_t, 2> read{0x01, 0x03};
  EXPECT_EQ(mb::rtu_request_length(read), 8);
  const std::array<std::uint8_t, 1> one{0x01};
  EXPECT_EQ(mb::rtu_request_length(one), 0);
  const std::array<std::uint8_t, 6> partial{0x01, 0x10, 0x00, 0x58, 0x00, 0x10};
  EXPECT_EQ(mb::rtu_request_length(partial), 0);
  const std::array<std::uint8_t, 7> block{0x01, 0x10, 0x00, 0x58, 0x00, 0x10, 0x20};
  EXPECT_EQ(mb::rtu_request_length(block), 9 + 32);
  const std::array<std::uint8_t, 11> rw{0x01, 0x17, 0, 0, 0, 1, 0, 2, 0, 1, 2};
  EXPECT_EQ(mb::rtu_request_length(rw), 15);
  const std::array<std::uint8_t, 2> unknown{0x01, 0x2B};
  EXPECT_LT(mb::rtu_request_length(unknown), 0);
}
