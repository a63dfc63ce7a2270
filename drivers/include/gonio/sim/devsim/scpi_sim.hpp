// The simulated SCPI photometer of gonio-devsim: a command interpreter that speaks the
// `gonio` command set (proto/scpi-gonio.md) or the `pm100` subset, and a server that offers
// it on a pseudo-terminal and/or a TCP port, so that the real SCPI driver and transports run
// end to end without hardware. Its readings come from a BetaSource (the twin, see mock.hpp).
//
// Signal model (per wavelength channel, counts): mean = dark_rate·t + gain·t·β for the
// sample channel (β = 1 for the reference white, 0 for dark); shot noise √mean plus read
// noise, drawn from a generator seeded by `seed`; readings at or above full scale are clipped
// and flagged as saturated.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "gonio/drivers/photometer/photometer.hpp"
#include "gonio/proto/geometry.hpp"
#include "gonio/proto/spectrum.hpp"

namespace gonio::drivers::devsim {

// β per wavelength channel of the sample at a geometry.
using BetaSource = std::function<std::vector<double>(const Geometry&)>;

struct ScpiSimConfig {
  std::string preset = "gonio";  // "gonio" or "pm100"
  Identity identity{"GONIO", "SIM-SPM1", "SIM0001", "1.0"};
  WavelengthGrid wavelengths = WavelengthGrid::visible();
  double integration_ms = 100;     // initial, within [min_integration_ms, max_integration_ms]
  double min_integration_ms = 1;
  double max_integration_ms = 10000;
  double gain_counts_per_ms = 500;  // signal of β = 1 per ms of integration
  double dark_counts_per_ms = 2;
  double read_noise_counts = 3;
  double full_scale_counts = 65535;
  double pm100_watts = 1e-3;        // pm100: power at β = 1
  std::uint64_t seed = 1;
  Geometry geometry = Geometry::in_plane(45, 0);
  // Scripted late answer: the reply to the Nth measurement query (MEAS:SPEC?, MEAS:POW?;
  // counted from 1, 0: never) is sent late_reply_ms after the query, and the replies to
  // anything after it wait behind it, as on a device busy with a long reading.
  int late_reply_at = 0;
  double late_reply_ms = 0;

  // Keys as above (identity as "manufacturer,model,serial,firmware"); unknown keys rejected.
  static ScpiSimConfig from_json(const nlohmann::json& j);
};

// The instrument's parser: one program message in, its response out.
class ScpiSimDevice {
 public:
  ScpiSimDevice(ScpiSimConfig config, BetaSource beta);

  // Handles one program message (without terminator; commands may be joined by ';').
  // Returns the response message without terminator, empty when there is none.
  std::string handle(std::string_view message);
  // How long the response of the last handle() is to be held back (then zero again).
  std::chrono::milliseconds take_reply_delay();

 private:
  std::string execute(std::string_view command);  // one command; may push errors
  void push_error(int code, std::string_view text);
  std::string measure_spectrum(std::string_view arg);
  std::string measure_power();
  void count_measurement();  // the scripted late reply

  mutable std::mutex mu_;
  ScpiSimConfig cfg_;
  BetaSource beta_;
  std::mt19937_64 rng_;
  std::deque<std::pair<int, std::string>> errors_;
  double pm_wavelength_ = 550;
  int pm_averages_ = 1;
  int measurements_ = 0;
  std::chrono::milliseconds reply_delay_{0};
};

// Serves a device to one client at a time per endpoint, on a background thread.
class ScpiSimServer {
 public:
  explicit ScpiSimServer(ScpiSimDevice& device);
  ~ScpiSimServer();
  ScpiSimServer(const ScpiSimServer&) = delete;
  ScpiSimServer& operator=(const ScpiSimServer&) = delete;

  // Creates a pseudo-terminal; returns the path a client opens (/dev/pts/N).
  std::string open_pty();
  // Listens on host:port (port 0: any free port); returns the port.
  std::uint16_t listen_tcp(const std::string& host = "127.0.0.1", std::uint16_t port = 0);
  void start();
  void stop();  // idempotent; also done by the destructor

 private:
  void run();

  ScpiSimDevice& device_;
  int pty_master_ = -1, pty_slave_ = -1, listen_fd_ = -1, stop_fd_ = -1;
  std::thread thread_;
};

}  // namespace gonio::drivers::devsim
