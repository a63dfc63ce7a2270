// FdStream — the poll()-based core shared by the file-descriptor transports (serial, TCP):
// deadline-bounded write and read on a non-blocking fd, and cancel() from any thread through
// an eventfd that every poll() also watches.
#pragma once

#include <atomic>
#include <string>

#include "gonio/drivers/transport/transport.hpp"

namespace gonio::drivers::detail {

class FdStream : public Transport {
 public:
  // Takes ownership of `fd` (non-blocking). `socket` selects send(MSG_NOSIGNAL) for writes.
  FdStream(int fd, bool socket, std::string description);
  ~FdStream() override;

  std::string describe() const override { return description_; }
  void write(std::string_view message, Deadline deadline) override;
  ReadResult read_some(std::span<char> buffer, Deadline deadline) override;
  void clear(Deadline deadline) override;
  void cancel() noexcept override;

 protected:
  int fd() const noexcept { return fd_; }

 private:
  // Waits until fd is ready for `events`; throws timeout / disconnected.
  void wait(short events, Deadline deadline, const char* what);

  int fd_ = -1;
  int cancel_fd_ = -1;
  bool socket_ = false;
  std::string description_;
};

// Throws Error(io_error) "<what> on <description>: <strerror>" for errno `err`, mapping
// EPIPE/ECONNRESET/EIO/ENXIO/ENODEV to disconnected.
[[noreturn]] void throw_errno(const std::string& what, const std::string& description, int err);

}  // namespace gonio::drivers::detail
