// UsbtmcTransport — SCPI messages over USBTMC bulk transfers (USBTMC 1.0 §3) with the
// abort and clear sequences of §4.2.1 on timeouts. Independent of libusb: it talks to a
// BulkEndpoints (libusb on hardware, an in-memory device in tests).
#include <algorithm>
#include <cstring>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "gonio/drivers/usbtmc/usbtmc.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::drivers::usbtmc {
namespace {

// Steps of an abort or clear loop before giving up (each step is bounded by abort_timeout).
constexpr int kMaxStatusPolls = 50;

milliseconds left_or_fail(Deadline d, const std::string& what) {
  const auto ms = remaining(d);
  if (ms.count() <= 0) throw Error(Errc::timeout, fmt::format("{}: no answer in time", what));
  return ms;
}

}  // namespace

UsbtmcTransport::UsbtmcTransport(std::unique_ptr<BulkEndpoints> endpoints, Options options)
    : ep_(std::move(endpoints)), opt_(options) {
  if (opt_.max_transfer < 4 || opt_.max_transfer > (1u << 20))
    throw Error::out_of_range("usbtmc.max_transfer", opt_.max_transfer, 4, 1u << 20, " bytes");
}

std::string UsbtmcTransport::describe() const { return "usbtmc " + ep_->describe(); }

void UsbtmcTransport::cancel() noexcept { cancelled_ = true; }

void UsbtmcTransport::write(std::string_view message, Deadline deadline) {
  // A new command makes any unread reply stale (IEEE 488.2 message exchange).
  pending_.clear();
  pending_pos_ = 0;
  std::size_t done = 0;
  do {
    if (cancelled_.exchange(false))
      throw Error(Errc::timeout, describe() + ": write cancelled");
    const std::size_t n = std::min<std::size_t>(message.size() - done, opt_.max_transfer);
    const bool eom = done + n == message.size();
    const std::uint8_t tag = take_tag();
    const Header h = encode_dev_dep_msg_out(tag, static_cast<std::uint32_t>(n), eom);
    std::vector<std::uint8_t> transfer(h.begin(), h.end());
    transfer.insert(transfer.end(), message.begin() + static_cast<std::ptrdiff_t>(done),
                    message.begin() + static_cast<std::ptrdiff_t>(done + n));
    transfer.resize((transfer.size() + 3) / 4 * 4, 0);  // §3.2.1.1 alignment bytes
    try {
      ep_->bulk_out(transfer, left_or_fail(deadline, describe() + ": write"));
    } catch (const Error& e) {
      if (e.code() == Errc::timeout) abort_bulk_out(tag);
      throw;
    }
    done += n;
  } while (done < message.size());
}

ReadResult UsbtmcTransport::read_some(std::span<char> buffer, Deadline deadline) {
  if (buffer.empty()) throw Error(Errc::internal, "usbtmc read_some with an empty buffer");
  while (pending_pos_ >= pending_.size()) {
    if (cancelled_.exchange(false))
      throw Error(Errc::timeout, describe() + ": read cancelled");
    fetch_transfer(deadline);
    // An empty transfer without EOM just means "nothing yet": ask again.
    if (pending_.empty() && pending_eom_)
      throw Error(Errc::protocol_error, describe() + ": empty message with EOM");
  }
  const std::size_t n = std::min(buffer.size(), pending_.size() - pending_pos_);
  std::memcpy(buffer.data(), pending_.data() + pending_pos_, n);
  pending_pos_ += n;
  return {n, pending_eom_ && pending_pos_ == pending_.size()};
}

void UsbtmcTransport::fetch_transfer(Deadline deadline) {
  pending_.clear();
  pending_pos_ = 0;
  pending_eom_ = false;
  const std::uint8_t tag = take_tag();
  const Header req = encode_request_dev_dep_msg_in(tag, opt_.max_transfer, opt_.term_char);
  try {
    ep_->bulk_out(req, left_or_fail(deadline, describe() + ": read request"));
  } catch (const Error& e) {
    if (e.code() == Errc::timeout) abort_bulk_out(tag);
    throw;
  }
  // Room for header, payload, alignment, rounded up to whole packets so that the device
  // never overflows our buffer (USB 2.0 §5.8.3 babble).
  const std::size_t mps = std::max<std::size_t>(ep_->max_packet_size(), 1);
  const std::size_t want = kHeaderSize + opt_.max_transfer + 3;
  std::vector<std::uint8_t> buf((want + mps - 1) / mps * mps);
  std::size_t got = 0;
  std::optional<InHeader> h;
  try {
    for (;;) {
      const std::size_t n = ep_->bulk_in(std::span(buf).subspan(got),
                                         left_or_fail(deadline, describe() + ": read"));
      got += n;
      if (!h && got >= kHeaderSize) {
        h = decode_dev_dep_msg_in(std::span(buf).first(kHeaderSize));
        if (h->tag != tag)
          throw Error(Errc::protocol_error,
                      fmt::format("{}: reply has bTag {} but the request had {}", describe(),
                                  h->tag, tag));
        if (h->transfer_size > opt_.max_transfer)
          throw Error(Errc::protocol_error,
                      fmt::format("{}: reply of {} bytes exceeds the {} requested", describe(),
                                  h->transfer_size, opt_.max_transfer));
      }
      if (h && got >= kHeaderSize + h->transfer_size) break;
      // A short packet ends the transfer (USB 2.0 §5.8.3); short of the header or payload
      // it is a broken transfer.
      if (n % mps != 0 || n == 0)
        throw Error(Errc::protocol_error,
                    fmt::format("{}: transfer ended after {} bytes, {} expected", describe(), got,
                                h ? kHeaderSize + h->transfer_size : kHeaderSize));
    }
  } catch (const Error& e) {
    if (e.code() == Errc::timeout) abort_bulk_in(tag);
    if (e.code() == Errc::protocol_error) {
      spdlog::warn("{}", e.what());
      try {
        clear(deadline_after(opt_.abort_timeout));
      } catch (const Error&) {
      }
    }
    throw;
  }
  pending_.assign(buf.begin() + kHeaderSize,
                  buf.begin() + static_cast<std::ptrdiff_t>(kHeaderSize + h->transfer_size));
  pending_eom_ = h->eom;
}

void UsbtmcTransport::abort_bulk_out(std::uint8_t tag) {
  // §4.2.1.2 INITIATE_ABORT_BULK_OUT, §4.2.1.3 CHECK_ABORT_BULK_OUT_STATUS, then
  // CLEAR_FEATURE(ENDPOINT_HALT) on Bulk-OUT. Best effort: the timeout is what we report.
  try {
    const auto r = ep_->control_in(kRequestTypeEndpoint, Request::initiate_abort_bulk_out, tag,
                                   ep_->bulk_out_address(), 2, opt_.abort_timeout);
    if (r.empty() || r[0] != static_cast<std::uint8_t>(Status::success)) {
      spdlog::debug("{}: INITIATE_ABORT_BULK_OUT status 0x{:02x}", describe(), r.empty() ? 0 : r[0]);
      return;
    }
    for (int i = 0; i < kMaxStatusPolls; ++i) {
      const auto s = ep_->control_in(kRequestTypeEndpoint, Request::check_abort_bulk_out_status,
                                     0, ep_->bulk_out_address(), 8, opt_.abort_timeout);
      if (s.empty() || s[0] != static_cast<std::uint8_t>(Status::pending)) break;
    }
    ep_->clear_halt(false, opt_.abort_timeout);
  } catch (const Error& e) {
    spdlog::warn("{}: abort of Bulk-OUT transfer {} failed: {}", describe(), tag, e.what());
  }
}

void UsbtmcTransport::drain_bulk_in() {
  // Read until a short packet (the device ends the aborted transfer with one).
  const std::size_t mps = std::max<std::size_t>(ep_->max_packet_size(), 1);
  std::vector<std::uint8_t> buf(mps);
  for (int i = 0; i < kMaxStatusPolls; ++i) {
    std::size_t n = 0;
    try {
      n = ep_->bulk_in(buf, opt_.abort_timeout);
    } catch (const Error& e) {
      if (e.code() == Errc::timeout) return;
      throw;
    }
    if (n < mps) return;
  }
}

void UsbtmcTransport::abort_bulk_in(std::uint8_t tag) {
  // §4.2.1.4 INITIATE_ABORT_BULK_IN; on success read Bulk-IN until a short packet, then
  // §4.2.1.5 CHECK_ABORT_BULK_IN_STATUS until not pending, reading more while
  // bmAbortBulkIn.D0 says the FIFO still holds data.
  try {
    const auto r = ep_->control_in(kRequestTypeEndpoint, Request::initiate_abort_bulk_in, tag,
                                   ep_->bulk_in_address(), 2, opt_.abort_timeout);
    if (r.empty() || r[0] != static_cast<std::uint8_t>(Status::success)) {
      spdlog::debug("{}: INITIATE_ABORT_BULK_IN status 0x{:02x}", describe(), r.empty() ? 0 : r[0]);
      return;
    }
    drain_bulk_in();
    for (int i = 0; i < kMaxStatusPolls; ++i) {
      const auto s = ep_->control_in(kRequestTypeEndpoint, Request::check_abort_bulk_in_status,
                                     0, ep_->bulk_in_address(), 8, opt_.abort_timeout);
      if (s.empty() || s[0] != static_cast<std::uint8_t>(Status::pending)) break;
      if (s.size() > 1 && (s[1] & 0x01)) drain_bulk_in();
    }
  } catch (const Error& e) {
    spdlog::warn("{}: abort of Bulk-IN transfer {} failed: {}", describe(), tag, e.what());
  }
}

void UsbtmcTransport::clear(Deadline deadline) {
  // §4.2.1.6 INITIATE_CLEAR, §4.2.1.7 CHECK_CLEAR_STATUS (reading Bulk-IN while bmClear.D0),
  // then CLEAR_FEATURE(ENDPOINT_HALT) on Bulk-OUT.
  pending_.clear();
  pending_pos_ = 0;
  cancelled_ = false;
  const auto step = [&] { return std::min(opt_.abort_timeout, std::max(remaining(deadline), milliseconds(1))); };
  const auto r = ep_->control_in(kRequestTypeInterface, Request::initiate_clear, 0,
                                 ep_->interface_number(), 1, step());
  if (r.empty() || r[0] != static_cast<std::uint8_t>(Status::success))
    throw Error(Errc::protocol_error,
                fmt::format("{}: INITIATE_CLEAR answered status 0x{:02x}", describe(),
                            r.empty() ? 0 : r[0]));
  for (int i = 0;; ++i) {
    if (i == kMaxStatusPolls)
      throw Error(Errc::timeout, describe() + ": device clear still pending");
    const auto s = ep_->control_in(kRequestTypeInterface, Request::check_clear_status, 0,
                                   ep_->interface_number(), 2, step());
    if (s.empty() || s[0] != static_cast<std::uint8_t>(Status::pending)) break;
    if (s.size() > 1 && (s[1] & 0x01)) drain_bulk_in();
  }
  ep_->clear_halt(false, step());
}

}  // namespace gonio::drivers::usbtmc
