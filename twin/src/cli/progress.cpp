// Tickers and size notes of gonio-twin's long commands (see progress.hpp).
#include "cli/progress.hpp"

#include <unistd.h>

#include <cstdio>
#include <filesystem>

#include <fmt/format.h>

namespace gonio::twin::cli {

std::string file_size_text(const std::string& path) {
  std::error_code ec;
  const auto bytes = std::filesystem::file_size(path, ec);
  if (ec) return "?";
  const double b = static_cast<double>(bytes);
  if (b < 1e3) return fmt::format("{} B", bytes);
  if (b < 1e6) return fmt::format("{:.1f} kB", b / 1e3);
  if (b < 1e9) return fmt::format("{:.1f} MB", b / 1e6);
  return fmt::format("{:.2f} GB", b / 1e9);
}

Ticker::Ticker(std::string command) : command_(std::move(command)) {
  if (::isatty(STDERR_FILENO)) thread_ = std::thread([this] { run(); });
}

Ticker::~Ticker() {
  {
    std::lock_guard lock(m_);
    stop_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void Ticker::step(std::string what) {
  std::lock_guard lock(m_);
  step_ = std::move(what);
}

void Ticker::run() {
  std::unique_lock lock(m_);
  // Quiet for the first two seconds: a quick command prints nothing extra.
  if (cv_.wait_for(lock, std::chrono::seconds(2), [this] { return stop_; })) return;
  while (!stop_) {
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
    std::fprintf(stderr, "\r%s: %s… %.0f s\033[K", command_.c_str(), step_.c_str(), s);
    std::fflush(stderr);
    drawn_ = true;
    cv_.wait_for(lock, std::chrono::seconds(1), [this] { return stop_; });
  }
  if (drawn_) {
    std::fputs("\r\033[K", stderr);
    std::fflush(stderr);
  }
}

}  // namespace gonio::twin::cli
