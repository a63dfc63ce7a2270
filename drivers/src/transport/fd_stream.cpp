// Deadline-bounded I/O on a non-blocking file descriptor with poll(), cancellable from any
// thread through an eventfd (Linux). Used by the serial and TCP transports.
#include "fd_stream.hpp"

#include <cerrno>
#include <cstdint>
#include <cstring>

#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"

namespace gonio::drivers {

std::chrono::milliseconds remaining(Deadline d) {
  const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(d - Clock::now());
  return left.count() > 0 ? left : std::chrono::milliseconds(0);
}

namespace detail {

void throw_errno(const std::string& what, const std::string& description, int err) {
  const auto msg = fmt::format("{} on {}: {}", what, description, std::strerror(err));
  switch (err) {
    case EPIPE:
    case ECONNRESET:
    case EIO:
    case ENXIO:
    case ENODEV:
      throw Error(Errc::disconnected, msg);
    default:
      throw Error(Errc::io_error, msg);
  }
}

FdStream::FdStream(int fd, bool socket, std::string description)
    : fd_(fd), socket_(socket), description_(std::move(description)) {
  cancel_fd_ = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (cancel_fd_ < 0) {
    const int err = errno;
    ::close(fd_);
    throw_errno("eventfd", description_, err);
  }
}

FdStream::~FdStream() {
  ::close(fd_);
  ::close(cancel_fd_);
}

void FdStream::cancel() noexcept {
  const std::uint64_t one = 1;
  [[maybe_unused]] const auto n = ::write(cancel_fd_, &one, sizeof one);
}

void FdStream::wait(short events, Deadline deadline, const char* what) {
  for (;;) {
    pollfd fds[2] = {{fd_, events, 0}, {cancel_fd_, POLLIN, 0}};
    const auto left = remaining(deadline);
    const int rc = ::poll(fds, 2, static_cast<int>(left.count()));
    if (rc < 0) {
      if (errno == EINTR) continue;
      throw_errno("poll", description_, errno);
    }
    if (fds[1].revents & POLLIN) {
      std::uint64_t v = 0;
      [[maybe_unused]] const auto n = ::read(cancel_fd_, &v, sizeof v);  // re-arm
      throw Error(Errc::timeout, fmt::format("{} on {} cancelled", what, description_));
    }
    if (fds[0].revents & (events | POLLHUP | POLLERR)) {
      // POLLHUP with data still buffered: let read() drain it first, it reports the end.
      if ((fds[0].revents & (POLLHUP | POLLERR)) && !(fds[0].revents & events))
        throw Error(Errc::disconnected, fmt::format("{} on {}: the device closed the link",
                                                    what, description_));
      return;
    }
    if (rc == 0 || Clock::now() >= deadline)
      throw Error(Errc::timeout,
                  fmt::format("{} on {}: no answer in time", what, description_));
  }
}

void FdStream::write(std::string_view message, Deadline deadline) {
  std::size_t done = 0;
  while (done < message.size()) {
    wait(POLLOUT, deadline, "write");
    const ssize_t n = socket_ ? ::send(fd_, message.data() + done, message.size() - done,
                                       MSG_NOSIGNAL)
                              : ::write(fd_, message.data() + done, message.size() - done);
    if (n < 0) {
      if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) continue;
      throw_errno("write", description_, errno);
    }
    done += static_cast<std::size_t>(n);
  }
}

ReadResult FdStream::read_some(std::span<char> buffer, Deadline deadline) {
  for (;;) {
    wait(POLLIN, deadline, "read");
    const ssize_t n = ::read(fd_, buffer.data(), buffer.size());
    if (n > 0) return {static_cast<std::size_t>(n), false};
    if (n == 0)
      throw Error(Errc::disconnected,
                  fmt::format("read on {}: the device closed the link", description_));
    if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) continue;
    throw_errno("read", description_, errno);
  }
}

void FdStream::clear(Deadline deadline) {
  // Drain whatever arrives until the line has been quiet for a moment (late replies).
  char buf[512];
  for (;;) {
    pollfd pfd{fd_, POLLIN, 0};
    const auto quiet = std::min<std::chrono::milliseconds>(remaining(deadline),
                                                           std::chrono::milliseconds(20));
    const int rc = ::poll(&pfd, 1, static_cast<int>(quiet.count()));
    if (rc <= 0 || !(pfd.revents & POLLIN)) return;
    const ssize_t n = ::read(fd_, buf, sizeof buf);
    if (n <= 0) return;
  }
}

}  // namespace detail
}  // namespace gonio::drivers
