// BulkEndpoints on real hardware through libusb-1.0: device lookup by VID:PID[:serial],
// the USBTMC interface (class 0xFE, subclass 0x03; USBTMC 1.0 §4.2.1, Table 14 area), its
// bulk endpoints, claim with kernel-driver auto-detach, and libusb errors mapped to gonio
// error codes.
#include <charconv>
#include <mutex>

#include <libusb.h>

#include <fmt/format.h>

#include "gonio/drivers/usbtmc/usbtmc.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::drivers::usbtmc {
namespace {

constexpr std::uint8_t kClassApplication = 0xFE;  // USBTMC 1.0 §4.2.1: bInterfaceClass
constexpr std::uint8_t kSubclassTmc = 0x03;       // bInterfaceSubClass

[[noreturn]] void throw_usb(int rc, const std::string& what) {
  const auto msg = fmt::format("{}: {}", what, libusb_strerror(rc));
  switch (rc) {
    case LIBUSB_ERROR_TIMEOUT: throw Error(Errc::timeout, msg);
    case LIBUSB_ERROR_NO_DEVICE: throw Error(Errc::disconnected, msg);
    case LIBUSB_ERROR_NOT_FOUND: throw Error(Errc::not_found, msg);
    case LIBUSB_ERROR_BUSY: throw Error(Errc::busy, msg + " (claimed by another program)");
    case LIBUSB_ERROR_ACCESS: throw Error(Errc::io_error, msg + " (check the udev rules)");
    case LIBUSB_ERROR_PIPE:
    case LIBUSB_ERROR_OVERFLOW: throw Error(Errc::protocol_error, msg);
    default: throw Error(Errc::io_error, msg);
  }
}

unsigned to_ms(milliseconds t) { return static_cast<unsigned>(std::max<long long>(1, t.count())); }

struct Context {
  libusb_context* ctx = nullptr;
  Context() {
    if (const int rc = libusb_init(&ctx); rc != 0) throw_usb(rc, "libusb_init");
  }
  ~Context() { libusb_exit(ctx); }
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;
};

std::string string_descriptor(libusb_device_handle* h, std::uint8_t index) {
  if (index == 0) return {};
  unsigned char buf[256];
  const int n = libusb_get_string_descriptor_ascii(h, index, buf, sizeof buf);
  return n > 0 ? std::string(reinterpret_cast<const char*>(buf), static_cast<std::size_t>(n)) : std::string();
}

struct TmcInterface {
  int number = -1;
  std::uint8_t out = 0, in = 0;
  std::size_t in_mps = 64;
};

TmcInterface find_tmc_interface(libusb_device* dev) {
  TmcInterface found;
  libusb_config_descriptor* cfg = nullptr;
  if (libusb_get_active_config_descriptor(dev, &cfg) != 0 || cfg == nullptr) return found;
  for (int i = 0; i < cfg->bNumInterfaces && found.number < 0; ++i) {
    const auto& itf = cfg->interface[i];
    for (int a = 0; a < itf.num_altsetting; ++a) {
      const auto& alt = itf.altsetting[a];
      if (alt.bInterfaceClass != kClassApplication || alt.bInterfaceSubClass != kSubclassTmc) continue;
      TmcInterface t;
      t.number = alt.bInterfaceNumber;
      for (int e = 0; e < alt.bNumEndpoints; ++e) {
        const auto& ep = alt.endpoint[e];
        if ((ep.bmAttributes & LIBUSB_TRANSFER_TYPE_MASK) != LIBUSB_TRANSFER_TYPE_BULK) continue;
        if (ep.bEndpointAddress & LIBUSB_ENDPOINT_IN) {
          t.in = ep.bEndpointAddress;
          t.in_mps = ep.wMaxPacketSize;
        } else {
          t.out = ep.bEndpointAddress;
        }
      }
      if (t.in != 0 && t.out != 0) {
        found = t;
        break;
      }
    }
  }
  libusb_free_config_descriptor(cfg);
  return found;
}

class LibusbEndpoints final : public BulkEndpoints {
 public:
  LibusbEndpoints(std::unique_ptr<Context> ctx, libusb_device_handle* h, TmcInterface itf,
                  std::string description)
      : ctx_(std::move(ctx)), h_(h), itf_(itf), description_(std::move(description)) {}
  ~LibusbEndpoints() override {
    libusb_release_interface(h_, itf_.number);
    libusb_close(h_);
  }

  std::string describe() const override { return description_; }

  void bulk_out(std::span<const std::uint8_t> data, milliseconds timeout) override {
    int done = 0;
    const int rc = libusb_bulk_transfer(h_, itf_.out, const_cast<unsigned char*>(data.data()),
                                        static_cast<int>(data.size()), &done, to_ms(timeout));
    if (rc != 0) throw_usb(rc, description_ + ": bulk-OUT");
    if (static_cast<std::size_t>(done) != data.size())
      throw Error(Errc::timeout, fmt::format("{}: bulk-OUT sent {} of {} bytes", description_,
                                             done, data.size()));
  }

  std::size_t bulk_in(std::span<std::uint8_t> buffer, milliseconds timeout) override {
    int done = 0;
    const int rc = libusb_bulk_transfer(h_, itf_.in, buffer.data(), static_cast<int>(buffer.size()),
                                        &done, to_ms(timeout));
    if (rc == LIBUSB_ERROR_TIMEOUT && done > 0) return static_cast<std::size_t>(done);
    if (rc != 0) throw_usb(rc, description_ + ": bulk-IN");
    return static_cast<std::size_t>(done);
  }

  std::vector<std::uint8_t> control_in(std::uint8_t request_type, Request request,
                                       std::uint16_t value, std::uint16_t index,
                                       std::uint16_t length, milliseconds timeout) override {
    std::vector<std::uint8_t> buf(length);
    const int rc = libusb_control_transfer(h_, request_type, static_cast<std::uint8_t>(request),
                                           value, index, buf.data(), length, to_ms(timeout));
    if (rc < 0) throw_usb(rc, fmt::format("{}: control request {}", description_,
                                          static_cast<int>(request)));
    buf.resize(static_cast<std::size_t>(rc));
    return buf;
  }

  void clear_halt(bool in_endpoint, milliseconds) override {
    const int rc = libusb_clear_halt(h_, in_endpoint ? itf_.in : itf_.out);
    if (rc != 0) throw_usb(rc, description_ + ": clear halt");
  }

  std::uint8_t bulk_out_address() const override { return itf_.out; }
  std::uint8_t bulk_in_address() const override { return itf_.in; }
  std::uint8_t interface_number() const override { return static_cast<std::uint8_t>(itf_.number); }
  std::size_t max_packet_size() const override { return itf_.in_mps; }

 private:
  std::unique_ptr<Context> ctx_;
  libusb_device_handle* h_;
  TmcInterface itf_;
  std::string description_;
};

std::uint16_t parse_hex16(std::string_view s, const char* field) {
  unsigned v = 0;
  const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v, 16);
  if (s.empty() || s.size() > 4 || ec != std::errc() || p != s.data() + s.size())
    throw Error::invalid(field, fmt::format("'{}' is not a 16-bit hex id like 1313", s));
  return static_cast<std::uint16_t>(v);
}

}  // namespace

DeviceSelector DeviceSelector::parse(std::string_view text) {
  DeviceSelector d;
  const auto c1 = text.find(':');
  if (c1 == std::string_view::npos)
    throw Error::invalid("usbtmc", fmt::format("'{}' is not VID:PID[:SERIAL]", text));
  const auto rest = text.substr(c1 + 1);
  const auto c2 = rest.find(':');
  d.vid = parse_hex16(text.substr(0, c1), "usbtmc.vid");
  d.pid = parse_hex16(rest.substr(0, c2), "usbtmc.pid");
  if (c2 != std::string_view::npos) d.serial = std::string(rest.substr(c2 + 1));
  return d;
}

std::string DeviceSelector::describe() const {
  return serial.empty() ? fmt::format("{:04x}:{:04x}", vid, pid)
                        : fmt::format("{:04x}:{:04x}:{}", vid, pid, serial);
}

std::vector<UsbDeviceInfo> list_usb_devices() {
  Context ctx;
  libusb_device** list = nullptr;
  const ssize_t n = libusb_get_device_list(ctx.ctx, &list);
  if (n < 0) throw_usb(static_cast<int>(n), "libusb_get_device_list");
  std::vector<UsbDeviceInfo> out;
  for (ssize_t i = 0; i < n; ++i) {
    libusb_device_descriptor d{};
    if (libusb_get_device_descriptor(list[i], &d) != 0) continue;
    UsbDeviceInfo info;
    info.vid = d.idVendor;
    info.pid = d.idProduct;
    info.bus = libusb_get_bus_number(list[i]);
    info.address = libusb_get_device_address(list[i]);
    info.usbtmc = find_tmc_interface(list[i]).number >= 0;
    libusb_device_handle* h = nullptr;
    if (libusb_open(list[i], &h) == 0) {
      info.manufacturer = string_descriptor(h, d.iManufacturer);
      info.product = string_descriptor(h, d.iProduct);
      info.serial = string_descriptor(h, d.iSerialNumber);
      libusb_close(h);
    }
    out.push_back(std::move(info));
  }
  libusb_free_device_list(list, 1);
  return out;
}

std::unique_ptr<BulkEndpoints> open_libusb(const DeviceSelector& sel) {
  auto ctx = std::make_unique<Context>();
  libusb_device** list = nullptr;
  const ssize_t n = libusb_get_device_list(ctx->ctx, &list);
  if (n < 0) throw_usb(static_cast<int>(n), "libusb_get_device_list");
  libusb_device_handle* handle = nullptr;
  TmcInterface itf;
  int last_rc = LIBUSB_ERROR_NOT_FOUND;
  bool matched_ids = false;
  for (ssize_t i = 0; i < n && handle == nullptr; ++i) {
    libusb_device_descriptor d{};
    if (libusb_get_device_descriptor(list[i], &d) != 0) continue;
    if (d.idVendor != sel.vid || d.idProduct != sel.pid) continue;
    matched_ids = true;
    libusb_device_handle* h = nullptr;
    if (const int rc = libusb_open(list[i], &h); rc != 0) {
      last_rc = rc;
      continue;
    }
    if (!sel.serial.empty() && string_descriptor(h, d.iSerialNumber) != sel.serial) {
      libusb_close(h);
      continue;
    }
    itf = find_tmc_interface(list[i]);
    if (itf.number < 0) {
      libusb_close(h);
      libusb_free_device_list(list, 1);
      throw Error(Errc::not_found,
                  fmt::format("usb {}: the device has no USBTMC interface", sel.describe()));
    }
    handle = h;
  }
  libusb_free_device_list(list, 1);
  const auto what = "usb " + sel.describe();
  if (handle == nullptr) {
    if (matched_ids && last_rc != LIBUSB_ERROR_NOT_FOUND) throw_usb(last_rc, what + ": open");
    throw Error(Errc::not_found, fmt::format("{}: no such device", what));
  }
  libusb_set_auto_detach_kernel_driver(handle, 1);
  if (const int rc = libusb_claim_interface(handle, itf.number); rc != 0) {
    libusb_close(handle);
    throw_usb(rc, what + ": claim interface");
  }
  return std::make_unique<LibusbEndpoints>(std::move(ctx), handle, itf, what);
}

}  // namespace gonio::drivers::usbtmc
