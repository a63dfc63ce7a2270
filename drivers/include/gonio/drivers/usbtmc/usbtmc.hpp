// USBTMC — USB Test & Measurement Class transport (USBTMC 1.0, USB-IF, 2003).
//
// Messages travel in bulk transfers that start with a 12-byte header (§3.2, Table 1):
//   byte 0 MsgID, 1 bTag, 2 bTagInverse (~bTag), 3 reserved 0x00,
//   bytes 4..11 MsgID-specific: for DEV_DEP_MSG_OUT (Table 3) and DEV_DEP_MSG_IN (Table 9)
//   TransferSize (uint32, little endian), bmTransferAttributes (bit 0 EOM), 3 reserved;
//   for REQUEST_DEV_DEP_MSG_IN (Table 4) TransferSize (most bytes the host accepts),
//   bmTransferAttributes (bit 1 TermCharEnabled), TermChar, 2 reserved.
// A Bulk-OUT transfer is padded with 0–3 alignment bytes to a multiple of 4 (§3.2.1.1).
// bTag runs 1..255 and never 0 (§3.2, Table 1): every new transfer takes the next one.
// The reply to REQUEST_DEV_DEP_MSG_IN echoes its bTag (§3.3.1).
//
// When a transfer times out the host aborts it (§4.2.1.2–4.2.1.5: INITIATE_ABORT_BULK_OUT/IN,
// then CHECK_ABORT_BULK_OUT/IN_STATUS until not STATUS_PENDING, reading the Bulk-IN FIFO
// dry while the device says it holds data); clear() runs INITIATE_CLEAR / CHECK_CLEAR_STATUS
// (§4.2.1.6–4.2.1.7) and then clears the Bulk-OUT halt (§4.2.1.6: CLEAR_FEATURE).
//
// The endpoints sit behind BulkEndpoints so that the protocol is tested without hardware
// (an in-memory device in the tests) and run on hardware through libusb.
#pragma once

#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "gonio/drivers/transport/transport.hpp"

namespace gonio::drivers::usbtmc {

using std::chrono::milliseconds;

constexpr std::size_t kHeaderSize = 12;

enum class MsgId : std::uint8_t {
  dev_dep_msg_out = 1,         // Bulk-OUT: a device-dependent message (Table 2)
  request_dev_dep_msg_in = 2,  // Bulk-OUT: ask for a reply; also the Bulk-IN reply's id
  vendor_specific_out = 126,
  request_vendor_specific_in = 127,
};

// bRequest values of the class-specific control requests (§4.2.1, Table 15).
enum class Request : std::uint8_t {
  initiate_abort_bulk_out = 1,
  check_abort_bulk_out_status = 2,
  initiate_abort_bulk_in = 3,
  check_abort_bulk_in_status = 4,
  initiate_clear = 5,
  check_clear_status = 6,
  get_capabilities = 7,
};

// USBTMC_status values (§4.2.1, Table 16).
enum class Status : std::uint8_t {
  success = 0x01,
  pending = 0x02,
  failed = 0x80,
  transfer_not_in_progress = 0x81,
  split_not_in_progress = 0x82,
  split_in_progress = 0x83,
};

// bmRequestType of class requests: device-to-host, class, recipient interface or endpoint.
constexpr std::uint8_t kRequestTypeInterface = 0xA1;
constexpr std::uint8_t kRequestTypeEndpoint = 0xA2;

using Header = std::array<std::uint8_t, kHeaderSize>;

// 1..255 wrapping to 1 (bTag 0 is not allowed).
constexpr std::uint8_t next_tag(std::uint8_t tag) noexcept {
  return tag >= 255 ? std::uint8_t{1} : static_cast<std::uint8_t>(tag + 1);
}

Header encode_dev_dep_msg_out(std::uint8_t tag, std::uint32_t transfer_size, bool eom);
Header encode_request_dev_dep_msg_in(std::uint8_t tag, std::uint32_t max_size,
                                     std::optional<char> term_char);

struct InHeader {
  std::uint8_t tag = 0;
  std::uint32_t transfer_size = 0;
  bool eom = false;
  bool term_char_matched = false;
};

// Parses a Bulk-IN DEV_DEP_MSG_IN header. Throws Error(protocol_error) naming what is wrong
// (too short, wrong MsgID, bTagInverse mismatch, reserved byte not 0).
InHeader decode_dev_dep_msg_in(std::span<const std::uint8_t> bytes);

// The device side of the link: one bulk-OUT and one bulk-IN endpoint plus the default
// control pipe. Errors: Error(timeout) (the transfer may be partly done), Error(disconnected).
class BulkEndpoints {
 public:
  virtual ~BulkEndpoints() = default;
  BulkEndpoints() = default;
  BulkEndpoints(const BulkEndpoints&) = delete;
  BulkEndpoints& operator=(const BulkEndpoints&) = delete;

  virtual std::string describe() const = 0;
  // One whole bulk-OUT transfer.
  virtual void bulk_out(std::span<const std::uint8_t> data, milliseconds timeout) = 0;
  // One bulk-IN read: the bytes the device sent, up to buffer.size() (a transfer may arrive
  // in several reads). Returns 0 for a zero-length packet.
  virtual std::size_t bulk_in(std::span<std::uint8_t> buffer, milliseconds timeout) = 0;
  // A class-specific control-IN request; returns the data stage.
  virtual std::vector<std::uint8_t> control_in(std::uint8_t request_type, Request request,
                                               std::uint16_t value, std::uint16_t index,
                                               std::uint16_t length, milliseconds timeout) = 0;
  // CLEAR_FEATURE(ENDPOINT_HALT) on the bulk-OUT (false) or bulk-IN (true) endpoint.
  virtual void clear_halt(bool in_endpoint, milliseconds timeout) = 0;

  virtual std::uint8_t bulk_out_address() const = 0;
  virtual std::uint8_t bulk_in_address() const = 0;
  virtual std::uint8_t interface_number() const = 0;
  virtual std::size_t max_packet_size() const = 0;  // of the bulk-IN endpoint
};

struct Options {
  std::uint32_t max_transfer = 4096;    // payload bytes per transfer (both directions)
  std::optional<char> term_char;        // ask the device to end a reply at this byte
  milliseconds abort_timeout{1000};     // for each step of abort / clear
};

class UsbtmcTransport final : public Transport {
 public:
  UsbtmcTransport(std::unique_ptr<BulkEndpoints> endpoints, Options options = {});

  std::string describe() const override;
  void write(std::string_view message, Deadline deadline) override;
  ReadResult read_some(std::span<char> buffer, Deadline deadline) override;
  void clear(Deadline deadline) override;
  void cancel() noexcept override;

  std::uint8_t last_tag() const noexcept { return tag_; }
  BulkEndpoints& endpoints() noexcept { return *ep_; }

 private:
  std::uint8_t take_tag() noexcept { return tag_ = next_tag(tag_); }
  void fetch_transfer(Deadline deadline);  // fills pending_ with one DEV_DEP_MSG_IN payload
  void abort_bulk_out(std::uint8_t tag);
  void abort_bulk_in(std::uint8_t tag);
  void drain_bulk_in();

  std::unique_ptr<BulkEndpoints> ep_;
  Options opt_;
  std::uint8_t tag_ = 0;  // last bTag used; the first transfer takes 1
  std::vector<char> pending_;
  std::size_t pending_pos_ = 0;
  bool pending_eom_ = false;
  std::atomic<bool> cancelled_{false};
};

// ---- libusb -------------------------------------------------------------------------

struct DeviceSelector {
  std::uint16_t vid = 0;
  std::uint16_t pid = 0;
  std::string serial;  // empty: the first match

  static DeviceSelector parse(std::string_view text);  // "1313:8078[:P0001234]" (hex ids)
  std::string describe() const;
};

struct UsbDeviceInfo {
  std::uint16_t vid = 0, pid = 0;
  int bus = 0, address = 0;
  bool usbtmc = false;        // has an interface of class 0xFE subclass 0x03
  std::string manufacturer, product, serial;  // empty when the device cannot be opened
};

// Every USB device that libusb sees. Throws Error(io_error) if libusb cannot start.
std::vector<UsbDeviceInfo> list_usb_devices();

// Finds the device, claims its USBTMC interface (detaching a kernel driver for the time
// it is held). not_found: no such device or no USBTMC interface; busy: claimed by another
// program; io_error: e.g. permission denied (see the udev rules).
std::unique_ptr<BulkEndpoints> open_libusb(const DeviceSelector& selector);

}  // namespace gonio::drivers::usbtmc
