// What long gonio-twin commands tell a person while they work and when they are done.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <string>
#include <thread>

namespace gonio::twin::cli {

// "12.3 kB", "55.2 MB": the size of a written file ("?" when it cannot be read back).
std::string file_size_text(const std::string& path);

// On a terminal, a line on stderr with the step and the seconds spent once a command has run
// for two seconds, redrawn each second and erased when the ticker is destroyed. The twin's
// estimators do not report how far they are, so it counts time, not a fraction. Nothing is
// drawn when stderr is not a terminal (logs and pipes keep their lines).
class Ticker {
 public:
  explicit Ticker(std::string command);
  ~Ticker();
  Ticker(const Ticker&) = delete;
  Ticker& operator=(const Ticker&) = delete;

  void step(std::string what);  // "measuring 4 212 geometries", "rendering the spheres"

 private:
  void run();

  std::string command_, step_;
  std::chrono::steady_clock::time_point t0_ = std::chrono::steady_clock::now();
  bool drawn_ = false, stop_ = false;
  std::mutex m_;
  std::condition_variable cv_;
  std::thread thread_;
};

}  // namespace gonio::twin::cli
