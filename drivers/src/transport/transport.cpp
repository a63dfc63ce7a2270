// read_transport: the transport factory used by the SCPI photometer registry entries.
#include <fmt/format.h>

#include "gonio/drivers/transport/serial.hpp"
#include "gonio/drivers/transport/tcp.hpp"
#include "gonio/drivers/usbtmc/usbtmc.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/proto/json_util.hpp"

namespace gonio::drivers {

TransportSpec read_transport(std::string_view type, json_util::ObjectReader& r) {
  if (type == "serial") {
    auto c = SerialConfig::read(r);
    return {{DeviceRef::Kind::path, r.path("device"), c.device}, [c] { return open_serial(c); }};
  }
  if (type == "tcp") {
    auto c = TcpConfig::read(r);
    return {{DeviceRef::Kind::tcp, r.path("host"), c.describe()}, [c] { return open_tcp(c); }};
  }
  if (type == "usbtmc") {
    usbtmc::DeviceSelector sel;
    sel = usbtmc::DeviceSelector::parse(r.required<std::string>("usb"));
    usbtmc::Options opt;
    const auto max = r.optional<long long>("max_transfer", opt.max_transfer);
    if (max < 4 || max > (1 << 20))
      throw Error::out_of_range(r.path("max_transfer"), static_cast<double>(max), 4, 1 << 20, " bytes");
    opt.max_transfer = static_cast<std::uint32_t>(max);
    return {{DeviceRef::Kind::usb, r.path("usb"), sel.describe()},
            [sel, opt]() -> TransportPtr {
              return std::make_unique<usbtmc::UsbtmcTransport>(usbtmc::open_libusb(sel), opt);
            }};
  }
  throw Error::invalid("transport", fmt::format("'{}' is not a transport (allowed: serial, tcp, usbtmc)", type));
}

}  // namespace gonio::drivers
