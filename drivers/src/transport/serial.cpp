// Serial line transport: termios raw mode (cfmakeraw), baud / data bits / parity / stop
// bits / RTS-CTS from config, CLOCAL so modem lines are ignored, exclusive flock().
// Works on USB-serial adapters and on pseudo-terminals (the simulators use those).
#include "gonio/drivers/transport/serial.hpp"

#include <array>
#include <cerrno>
#include <charconv>
#include <utility>

#include <fcntl.h>
#include <sys/file.h>
#include <termios.h>
#include <unistd.h>

#include <fmt/format.h>

#include "fd_stream.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/proto/json_util.hpp"

namespace gonio::drivers {
namespace {

constexpr std::array<std::pair<int, speed_t>, 26> kRates{{
    {50, B50},         {75, B75},         {110, B110},       {134, B134},
    {150, B150},       {200, B200},       {300, B300},       {600, B600},
    {1200, B1200},     {1800, B1800},     {2400, B2400},     {4800, B4800},
    {9600, B9600},     {19200, B19200},   {38400, B38400},   {57600, B57600},
    {115200, B115200}, {230400, B230400}, {460800, B460800}, {500000, B500000},
    {576000, B576000}, {921600, B921600}, {1000000, B1000000}, {1500000, B1500000},
    {2000000, B2000000}, {4000000, B4000000},
}};

speed_t speed_of(int baud, const std::string& field) {
  for (const auto& [b, s] : kRates)
    if (b == baud) return s;
  std::string allowed;
  for (const auto& [b, s] : kRates) allowed += (allowed.empty() ? "" : ", ") + std::to_string(b);
  throw Error::invalid(field, fmt::format("{} is not a serial rate (allowed: {})", baud, allowed));
}

char parity_of(std::string_view p, const std::string& field) {
  if (p == "none" || p == "N" || p == "n") return 'N';
  if (p == "even" || p == "E" || p == "e") return 'E';
  if (p == "odd" || p == "O" || p == "o") return 'O';
  throw Error::invalid(field, fmt::format("'{}' is not a parity (allowed: none, even, odd)", p));
}

void check_frame(const SerialConfig& c, const std::string& prefix) {
  (void)speed_of(c.baud, join_field(prefix, "baud"));
  if (c.data_bits != 7 && c.data_bits != 8)
    throw Error::out_of_range(join_field(prefix, "data_bits"), c.data_bits, 7, 8);
  if (c.stop_bits != 1 && c.stop_bits != 2)
    throw Error::out_of_range(join_field(prefix, "stop_bits"), c.stop_bits, 1, 2);
}

int parse_int(std::string_view s, const std::string& field) {
  int v = 0;
  const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || p != s.data() + s.size())
    throw Error::invalid(field, fmt::format("'{}' is not an integer", s));
  return v;
}

}  // namespace

SerialConfig SerialConfig::read(json_util::ObjectReader& r) {
  SerialConfig c;
  c.device = r.required<std::string>("device");
  if (c.device.empty()) throw Error::invalid(r.path("device"), "must not be empty");
  c.baud = r.optional<int>("baud", c.baud);
  c.data_bits = r.optional<int>("data_bits", c.data_bits);
  c.parity = parity_of(r.optional<std::string>("parity", "none"), r.path("parity"));
  c.stop_bits = r.optional<int>("stop_bits", c.stop_bits);
  const auto flow = r.optional<std::string>("flow", "none");
  if (flow != "none" && flow != "rtscts")
    throw Error::invalid(r.path("flow"), fmt::format("'{}' (allowed: none, rtscts)", flow));
  c.rtscts = flow == "rtscts";
  check_frame(c, r.path(""));
  return c;
}

SerialConfig SerialConfig::parse(std::string_view text) {
  SerialConfig c;
  const auto comma = text.find(',');
  c.device = std::string(text.substr(0, comma));
  if (c.device.empty()) throw Error::invalid("serial", "expected DEVICE[,BAUD[,8N1]]");
  if (comma != std::string_view::npos) {
    auto rest = text.substr(comma + 1);
    const auto comma2 = rest.find(',');
    c.baud = parse_int(rest.substr(0, comma2), "serial.baud");
    if (comma2 != std::string_view::npos) {
      const auto frame = rest.substr(comma2 + 1);
      if (frame.size() != 3)
        throw Error::invalid("serial.frame", fmt::format("'{}' is not like 8N1 or 8E1", frame));
      c.data_bits = frame[0] - '0';
      c.parity = parity_of(frame.substr(1, 1), "serial.parity");
      c.stop_bits = frame[2] - '0';
    }
  }
  check_frame(c, "serial");
  return c;
}

std::string SerialConfig::describe() const {
  return fmt::format("{} {} {}{}{}{}", device, baud, data_bits, parity, stop_bits,
                     rtscts ? " rtscts" : "");
}

TransportPtr open_serial(const SerialConfig& c) {
  const auto what = "serial " + c.describe();
  const int fd = ::open(c.device.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) {
    const int err = errno;
    if (err == ENOENT || err == ENODEV || err == ENXIO)
      throw Error(Errc::not_found, fmt::format("{}: no such device", what));
    if (err == EBUSY) throw Error(Errc::busy, fmt::format("{}: device is busy", what));
    detail::throw_errno("open", what, err);
  }
  auto stream = std::make_unique<detail::FdStream>(fd, false, what);  // owns fd from here
  if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    if (errno == EWOULDBLOCK)
      throw Error(Errc::busy, fmt::format("{}: in use by another program", what));
    detail::throw_errno("flock", what, errno);
  }
  termios t{};
  if (::tcgetattr(fd, &t) != 0) detail::throw_errno("tcgetattr (not a terminal?)", what, errno);
  ::cfmakeraw(&t);
  const speed_t speed = speed_of(c.baud, "baud");
  ::cfsetispeed(&t, speed);
  ::cfsetospeed(&t, speed);
  t.c_cflag &= ~static_cast<tcflag_t>(CSIZE | PARENB | PARODD | CSTOPB | CRTSCTS);
  t.c_cflag |= (c.data_bits == 7 ? CS7 : CS8) | CLOCAL | CREAD;
  if (c.parity != 'N') t.c_cflag |= PARENB;
  if (c.parity == 'O') t.c_cflag |= PARODD;
  if (c.stop_bits == 2) t.c_cflag |= CSTOPB;
  if (c.rtscts) t.c_cflag |= CRTSCTS;
  t.c_iflag &= ~static_cast<tcflag_t>(IXON | IXOFF | IXANY);
  t.c_cc[VMIN] = 0;
  t.c_cc[VTIME] = 0;
  if (::tcsetattr(fd, TCSANOW, &t) != 0) detail::throw_errno("tcsetattr", what, errno);
  ::tcflush(fd, TCIOFLUSH);  // bytes from before we opened are nobody's reply
  return stream;
}

}  // namespace gonio::drivers
