// gonio-probe scpi / list (scpi_probe.hpp): open one SCPI photometer with the chosen
// transport and preset, ask for its identity or one reading, and word every failure for a
// technician; list serial ports and USB devices.
#include "scpi_probe.hpp"

#include <algorithm>
#include <filesystem>
#include <ostream>

#include <fmt/format.h>
#include <fmt/ostream.h>

#include "gonio/drivers/scpi/scpi.hpp"
#include "gonio/drivers/transport/serial.hpp"
#include "gonio/drivers/transport/tcp.hpp"
#include "gonio/drivers/usbtmc/usbtmc.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::drivers::probe {
namespace {

const char* scpi_hint(Errc c) {
  switch (c) {
    case Errc::not_found: return "is the device connected and powered, and the address right?";
    case Errc::disconnected: return "the link dropped: check the cable and the device";
    case Errc::busy: return "another program holds the device (goniod? a terminal?)";
    case Errc::timeout: return "no answer: wrong port, baud rate or preset, or the device hangs";
    case Errc::protocol_error: return "the device answered nonsense: wrong preset or baud rate?";
    case Errc::device_alarm: return "the device reported an error";
    case Errc::saturated: return "shorten the integration time or attenuate the beam";
    case Errc::io_error: return "operating-system error (permissions? see the udev rules)";
    default: return "";
  }
}

}  // namespace

int exit_code_for(const std::exception& ex) noexcept {
  const auto* e = dynamic_cast<const Error*>(&ex);
  if (e == nullptr) return 1;
  switch (e->code()) {
    case Errc::invalid_argument:
    case Errc::out_of_range:
    case Errc::unsupported: return 2;
    case Errc::not_found:
    case Errc::disconnected:
    case Errc::io_error: return 3;
    case Errc::timeout: return 4;
    case Errc::protocol_error:
    case Errc::parse_error: return 5;
    case Errc::device_alarm:
    case Errc::saturated: return 6;
    case Errc::busy: return 7;
    default: return 1;
  }
}

int run_scpi(const ScpiOptions& o, std::ostream& out, std::ostream& err) {
  try {
    const int links = !o.serial.empty() + !o.tcp.empty() + !o.usbtmc.empty();
    if (links != 1) throw Error::invalid("link", "give exactly one of --serial, --tcp, --usbtmc");
    if (o.command != "idn" && o.command != "measure")
      throw Error::invalid("command", fmt::format("'{}' (allowed: idn, measure)", o.command));
    scpi::PhotometerConfig pc;
    pc.preset = parse_enum<scpi::Preset>(o.preset, "--preset");
    Channel ch = Channel::sample;
    if (o.channel == "reference") ch = Channel::reference;
    else if (o.channel == "dark") ch = Channel::dark;
    else if (o.channel != "sample")
      throw Error::invalid("--channel", fmt::format("'{}' (allowed: sample, reference, dark)", o.channel));
    if (pc.preset == scpi::Preset::pm100) {
      if (o.command == "measure" && !o.wavelength_nm)
        throw Error::invalid("--wavelength", "the pm100 preset measures at one wavelength: give --wavelength NM");
      pc.wavelengths = WavelengthGrid({o.wavelength_nm.value_or(550)}, "--wavelength");
      pc.repeats = 3;
    }
    TransportPtr t;
    if (!o.serial.empty()) t = open_serial(SerialConfig::parse(o.serial));
    if (!o.tcp.empty()) t = open_tcp(TcpConfig::parse(o.tcp));
    if (!o.usbtmc.empty())
      t = std::make_unique<usbtmc::UsbtmcTransport>(usbtmc::open_libusb(usbtmc::DeviceSelector::parse(o.usbtmc)));
    auto pm = scpi::make_photometer(std::move(t), pc);
    const auto id = pm->identify(o.timeout);
    if (o.command == "idn") {
      fmt::print(out, "{}\n", id.to_string());
      return 0;
    }
    const auto r = pm->measure(ch, o.timeout, SaturationPolicy::flag);
    fmt::print(out, "# {} — {} channel, integration {:g} ms{}\n", id.to_string(), to_text(ch),
               r.integration_ms, r.saturated ? ", SATURATED" : "");
    fmt::print(out, "# wavelength_nm value_{0} std_uncertainty_{0}\n", r.unit);
    const auto& w = r.spectrum.wavelengths;
    for (std::size_t i = 0; i < r.spectrum.size(); ++i) {
      if (o.wavelength_nm && pc.preset == scpi::Preset::gonio) {
        // Only the channel nearest the requested wavelength.
        std::size_t best = 0;
        for (std::size_t k = 1; k < w.size(); ++k)
          if (std::fabs(w[k] - *o.wavelength_nm) < std::fabs(w[best] - *o.wavelength_nm)) best = k;
        if (i != best) continue;
      }
      fmt::print(out, "{:g} {:.6g} {:.3g}\n", w[i], r.spectrum.values[i], r.spectrum.std_uncertainty[i]);
    }
    if (r.saturated) {
      fmt::print(err, "error: the detector is saturated: {}\n", scpi_hint(Errc::saturated));
      return 6;
    }
    return 0;
  } catch (const Error& e) {
    const auto h = scpi_hint(e.code());
    fmt::print(err, "error: {}{}{}\n", e.what(), *h ? "\n  hint: " : "", h);
    return exit_code_for(e);
  } catch (const std::exception& e) {
    fmt::print(err, "error: {}\n", e.what());
    return 1;
  }
}

int run_list(std::ostream& out, std::ostream& err) {
  namespace fs = std::filesystem;
  fmt::print(out, "serial ports:\n");
  std::vector<std::string> ports;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator("/dev", ec)) {
    const auto name = e.path().filename().string();
    if (name.rfind("ttyUSB", 0) == 0 || name.rfind("ttyACM", 0) == 0 || name.rfind("ttyS", 0) == 0 ||
        name.rfind("ttyAMA", 0) == 0)
      ports.push_back(e.path().string());
  }
  std::sort(ports.begin(), ports.end());
  for (const auto& p : ports) fmt::print(out, "  {}\n", p);
  if (fs::is_directory("/dev/serial/by-id", ec))
    for (const auto& e : fs::directory_iterator("/dev/serial/by-id", ec))
      fmt::print(out, "  {} -> {}\n", e.path().string(), fs::canonical(e.path(), ec).string());
  if (ports.empty()) fmt::print(out, "  (none)\n");
  fmt::print(out, "usb devices:\n");
  try {
    const auto devs = usbtmc::list_usb_devices();
    for (const auto& d : devs)
      fmt::print(out, "  {:04x}:{:04x} bus {:03d} device {:03d}{}{}{}\n", d.vid, d.pid, d.bus, d.address,
                 d.usbtmc ? " USBTMC" : "",
                 d.product.empty() ? "" : fmt::format(" {} {}", d.manufacturer, d.product),
                 d.serial.empty() ? "" : fmt::format(" serial {}", d.serial));
    if (devs.empty()) fmt::print(out, "  (none)\n");
  } catch (const Error& e) {
    fmt::print(err, "warning: cannot list USB devices: {}\n", e.what());
  }
  return 0;
}

}  // namespace gonio::drivers::probe
