// Modbus RTU framing facts shared by the device simulator, the golden-replay tests and the
// fuzz targets: the CRC and the length of a request frame from its first bytes.
//
// Sources: MODBUS over Serial Line, Specification and Implementation Guide V1.02, §2.5.1
// (RTU frame: address, PDU, CRC low byte first) and §6.2.2 (CRC-16, polynomial 0xA001
// reflected, initial value 0xFFFF); MODBUS Application Protocol Specification V1.1b3, §6
// (request PDU layout of each function code).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

namespace gonio::drivers::modbus {

std::uint16_t crc16(std::span<const std::uint8_t> bytes) noexcept;

// True if the last two bytes are the CRC of the rest (low byte first).
bool crc_ok(std::span<const std::uint8_t> frame) noexcept;

// Total length of an RTU request frame (address .. CRC) given its first bytes:
//   > 0  the length, once enough header bytes are present to know it
//   0    more bytes are needed to tell
//   < 0  a function code whose request layout this table does not know
int rtu_request_length(std::span<const std::uint8_t> head) noexcept;

}  // namespace gonio::drivers::modbus
