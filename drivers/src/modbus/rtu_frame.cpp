// Modbus RTU CRC and request-frame lengths (sources in rtu_frame.hpp).
#include "gonio/drivers/modbus/rtu_frame.hpp"

namespace gonio::drivers::modbus {

std::uint16_t crc16(std::span<const std::uint8_t> bytes) noexcept {
  std::uint16_t crc = 0xFFFF;
  for (const std::uint8_t b : bytes) {
    crc ^= b;
    for (int i = 0; i < 8; ++i)
      crc = (crc & 1u) != 0 ? static_cast<std::uint16_t>((crc >> 1) ^ 0xA001u)
                            : static_cast<std::uint16_t>(crc >> 1);
  }
  return crc;
}

bool crc_ok(std::span<const std::uint8_t> frame) noexcept {
  if (frame.size() < 4) return false;
  const std::uint16_t crc = crc16(frame.first(frame.size() - 2));
  return frame[frame.size() - 2] == (crc & 0xFF) && frame[frame.size() - 1] == (crc >> 8);
}

int rtu_request_length(std::span<const std::uint8_t> head) noexcept {
  if (head.size() < 2) return 0;
  switch (head[1]) {
    case 0x01: case 0x02: case 0x03: case 0x04: case 0x05: case 0x06:
    case 0x08:
      return 8;  // address, function, 2 + 2 bytes, CRC
    case 0x07: case 0x0B: case 0x0C: case 0x11:
      return 4;  // address, function, CRC
    case 0x16:
      return 10;  // mask write: address, and-mask, or-mask
    case 0x0F: case 0x10:
      return head.size() < 7 ? 0 : 9 + head[6];  // ... byte count at offset 6
    case 0x17:
      return head.size() < 11 ? 0 : 13 + head[10];  // ... write byte count at offset 10
    default:
      return -1;
  }
}

}  // namespace gonio::drivers::modbus
