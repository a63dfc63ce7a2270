// The USBTMC photometer link through real libusb, without hardware: umockdev builds a sysfs
// and udev tree for one USB device and routes the usbfs ioctls on its node
// /dev/bus/usb/001/005 to a handler here that plays the instrument. So everything below
// the transport is the production code path: enumeration by VID:PID[:serial], string
// descriptors over control transfers, interface claim, URB submit / reap / discard for bulk
// transfers with their timeouts, class requests and CLEAR_HALT.
//
// umockdev/pm100d.umockdev describes the device as the kernel shows it in sysfs; its
// `descriptors` attribute (USB 2.0 §9.6) holds the device descriptor (1313:8078, full speed,
// EP0 64 bytes, strings 1-3), one configuration, interface 0 of class 0xFE subclass 0x03
// protocol 0x01 (USBTMC USB488, USBTMC 1.0 §4.2.1) with bulk OUT 0x02 and bulk IN 0x81
// (64 bytes) and an interrupt IN 0x83 that the driver must pass over.
//
// umockdev's preload library has to be in the process from the start; ctest runs this
// executable through umockdev-wrapper. Run directly, the tests skip.
#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstddef>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <linux/usbdevice_fs.h>
#include <sys/ioctl.h>  // _IOR and friends in the USBDEVFS_* request numbers

#include <gtest/gtest.h>
#include <umockdev.h>

#include "gonio/drivers/scpi/scpi.hpp"
#include "gonio/drivers/usbtmc/usbtmc.hpp"
#include "gonio/proto/error.hpp"

namespace tmc = gonio::drivers::usbtmc;
using gonio::Errc;
using gonio::Error;
using gonio::drivers::deadline_after;
using namespace std::chrono_literals;

namespace {

using Bytes = std::vector<std::uint8_t>;

constexpr const char* kDevNode = "/dev/bus/usb/001/005";
constexpr std::uint8_t kBulkOut = 0x02, kBulkIn = 0x81;
constexpr std::uint8_t kStatusSuccess = 0x01;  // USBTMC 1.0 §4.2.1, Table 16

std::uint32_t le32(const std::uint8_t* p) {
  return p[0] | (p[1] << 8) | (p[2] << 16) | (static_cast<std::uint32_t>(p[3]) << 24);
}

struct ControlSetup {  // USB 2.0 §9.3, Table 9-2
  std::uint8_t request_type, request;
  std::uint16_t value, index, length;
};

// The instrument: a USB488 device (USBTMC 1.0) that answers *IDN? and MEAS:POW?. It keeps
// what the host sent so that the tests can check the bytes on the wire.
class Instrument {
 public:
  enum class Fault { none, bad_tag_inverse, silent };

  std::string identity = "Thorlabs,PM100D,P0012345,2.8.0";
  std::string long_reply;  // the reply to LONG? (to span several transfers)
  Fault fault = Fault::none;

  std::vector<Bytes> bulk_out;        // every Bulk-OUT transfer, verbatim
  std::vector<ControlSetup> control;  // every control request
  std::vector<unsigned> cleared_halts;
  std::vector<unsigned> claimed, released;
  std::vector<unsigned long> unexpected_ioctls;
  int discarded_urbs = 0;

  void on_bulk_out(std::span<const std::uint8_t> t) {
    bulk_out.emplace_back(t.begin(), t.end());
    if (t.size() < tmc::kHeaderSize) return;
    const std::uint8_t id = t[0], tag = t[1];
    const std::uint32_t size = le32(&t[4]);
    if (id == 1) {  // DEV_DEP_MSG_OUT (§3.2.1.1, Table 3): payload after the header
      message_.append(reinterpret_cast<const char*>(t.data()) + tmc::kHeaderSize,
                      std::min<std::size_t>(size, t.size() - tmc::kHeaderSize));
      if (t[8] & 0x01) answer(std::exchange(message_, {}));
    } else if (id == 2 && fault != Fault::silent) {  // REQUEST_DEV_DEP_MSG_IN (Table 4)
      queue_reply(tag, size);
    }
  }

  // The next Bulk-IN bytes, at most `room`; nullopt while the device has nothing to send.
  std::optional<Bytes> on_bulk_in(std::size_t room) {
    if (in_.empty()) return std::nullopt;
    Bytes& front = in_.front();
    const std::size_t n = std::min(room, front.size());
    Bytes out(front.begin(), front.begin() + static_cast<std::ptrdiff_t>(n));
    front.erase(front.begin(), front.begin() + static_cast<std::ptrdiff_t>(n));
    if (front.empty()) in_.pop_front();
    return out;
  }

  // Data stage of a control-IN request; nullopt stalls.
  std::optional<Bytes> on_control(const ControlSetup& s) {
    control.push_back(s);
    if (s.request_type == 0x80 && s.request == 6 && (s.value >> 8) == 3)  // GET_DESCRIPTOR string
      return string_descriptor(s.value & 0xFF);
    if ((s.request_type == 0xA1 || s.request_type == 0xA2) && s.request >= 1 && s.request <= 6)
      return class_request(s);
    return std::nullopt;
  }

 private:
  void answer(const std::string& message) {
    if (message == "*IDN?\n") reply_ += identity + "\n";
    else if (message == "MEAS:POW?\n") reply_ += "1.234E-03\n";
    else if (message == "LONG?\n") reply_ += long_reply;
  }

  void queue_reply(std::uint8_t tag, std::uint32_t max) {
    // DEV_DEP_MSG_IN (§3.3.1.1, Table 9): bTag echoes the request, EOM on the last part.
    const std::size_t n = std::min<std::size_t>(max, reply_.size());
    const bool eom = n == reply_.size();
    const auto inverse = static_cast<std::uint8_t>(fault == Fault::bad_tag_inverse ? tag : ~tag);
    Bytes t{2, tag, inverse, 0};
    for (int i = 0; i < 4; ++i) t.push_back(static_cast<std::uint8_t>(n >> (8 * i)));
    t.insert(t.end(), {static_cast<std::uint8_t>(eom ? 0x01 : 0x00), 0, 0, 0});
    t.insert(t.end(), reply_.begin(), reply_.begin() + static_cast<std::ptrdiff_t>(n));
    t.resize((t.size() + 3) / 4 * 4, 0);  // alignment bytes (Table 9), ignored by the host
    reply_.erase(0, n);
    in_.push_back(std::move(t));
  }

  std::optional<Bytes> string_descriptor(unsigned index) {  // USB 2.0 §9.6.7
    if (index == 0) return Bytes{4, 3, 0x09, 0x04};          // LANGID en-US
    static const char* const strings[] = {"Thorlabs", "PM100D", "P0012345"};
    if (index > 3) return std::nullopt;
    const std::string s = strings[index - 1];
    Bytes d{static_cast<std::uint8_t>(2 + 2 * s.size()), 3};
    for (char c : s) d.insert(d.end(), {static_cast<std::uint8_t>(c), 0});
    return d;
  }

  Bytes class_request(const ControlSetup& s) {
    // USBTMC 1.0 §4.2.1.2–4.2.1.7. An aborted or cleared device drops what it holds; after
    // INITIATE_ABORT_BULK_IN it ends the transfer with a short packet (§4.2.1.4).
    const auto tag = static_cast<std::uint8_t>(s.value);
    switch (s.request) {
      case 1: return {kStatusSuccess, tag};                  // INITIATE_ABORT_BULK_OUT
      case 2: return {kStatusSuccess, 0, 0, 0, 0, 0, 0, 0};  // CHECK_ABORT_BULK_OUT_STATUS
      case 3:                                                // INITIATE_ABORT_BULK_IN
        in_.clear();
        reply_.clear();
        in_.push_back({});
        return {kStatusSuccess, tag};
      case 4: return {kStatusSuccess, 0, 0, 0, 0, 0, 0, 0};  // CHECK_ABORT_BULK_IN_STATUS
      case 5:                                                // INITIATE_CLEAR
        in_.clear();
        reply_.clear();
        message_.clear();
        return {kStatusSuccess};
      default: return {kStatusSuccess, 0};  // CHECK_CLEAR_STATUS: done, FIFO empty
    }
  }

  std::string message_;   // DEV_DEP_MSG_OUT payload until EOM
  std::string reply_;     // reply bytes not yet requested
  std::deque<Bytes> in_;  // Bulk-IN transfers queued for the host
};

struct GObjectUnref {
  void operator()(gpointer p) const { g_object_unref(p); }
};
template <class T>
using GRef = std::unique_ptr<T, GObjectUnref>;

// usbfs on the instrument's node, the way the kernel's devio.c answers libusb: URBs are
// queued on submit and handed back by REAPURBNDELAY when done (Bulk-OUT and control at once,
// Bulk-IN when the instrument has data); a discarded URB is reaped with -ENOENT. Runs on
// umockdev's worker thread.
class UsbfsHandler {
 public:
  UsbfsHandler() : base_(umockdev_ioctl_base_new()) {
    g_signal_connect(base_.get(), "handle-ioctl", G_CALLBACK(&UsbfsHandler::on_ioctl), this);
  }
  UMockdevIoctlBase* base() const { return base_.get(); }

  template <class F>
  auto with_instrument(F&& f) {
    std::lock_guard lock(mutex_);
    return f(instrument_);
  }

 private:
  struct Urb {
    GRef<UMockdevIoctlData> data;
    GRef<UMockdevIoctlData> buffer;  // null for an empty transfer
    usbdevfs_urb* get() const { return reinterpret_cast<usbdevfs_urb*>(data->data); }
  };

  static gboolean on_ioctl(UMockdevIoctlBase*, UMockdevIoctlClient* client, gpointer self) {
    auto& h = *static_cast<UsbfsHandler*>(self);
    std::lock_guard lock(h.mutex_);
    const auto [rc, err] = h.handle(umockdev_ioctl_client_get_request(client),
                                    umockdev_ioctl_client_get_arg(client));
    umockdev_ioctl_client_complete(client, rc, err);
    return TRUE;
  }

  static GRef<UMockdevIoctlData> resolve(UMockdevIoctlData* d, std::size_t offset,
                                         std::size_t len) {
    return GRef<UMockdevIoctlData>(umockdev_ioctl_data_resolve(d, offset, len, nullptr));
  }
  static unsigned scalar(UMockdevIoctlData* arg) {
    const auto d = resolve(arg, 0, sizeof(unsigned));
    return d ? *reinterpret_cast<unsigned*>(d->data) : ~0u;
  }

  std::pair<long, int> handle(unsigned long request, UMockdevIoctlData* arg) {
    switch (request) {
      case USBDEVFS_GET_CAPABILITIES: {
        const auto d = resolve(arg, 0, sizeof(std::uint32_t));
        *reinterpret_cast<std::uint32_t*>(d->data) =
            USBDEVFS_CAP_BULK_SCATTER_GATHER | USBDEVFS_CAP_BULK_CONTINUATION |
            USBDEVFS_CAP_NO_PACKET_SIZE_LIM | USBDEVFS_CAP_REAP_AFTER_DISCONNECT |
            USBDEVFS_CAP_ZERO_PACKET;
        return {0, 0};
      }
      case USBDEVFS_CLAIMINTERFACE:
        instrument_.claimed.push_back(scalar(arg));
        return {0, 0};
      case USBDEVFS_DISCONNECT_CLAIM: {  // claim, detaching a kernel driver (there is none)
        const auto d = resolve(arg, 0, sizeof(usbdevfs_disconnect_claim));
        const auto* claim = reinterpret_cast<usbdevfs_disconnect_claim*>(d->data);
        instrument_.claimed.push_back(claim->interface);
        return {0, 0};
      }
      case USBDEVFS_RELEASEINTERFACE:
        instrument_.released.push_back(scalar(arg));
        return {0, 0};
      case USBDEVFS_IOCTL:  // reattaching a kernel driver: none is bound
        return {-1, ENODATA};
      case USBDEVFS_CLEAR_HALT:
        instrument_.cleared_halts.push_back(scalar(arg));
        return {0, 0};
      case USBDEVFS_SUBMITURB: return submit(arg);
      case USBDEVFS_REAPURB:
      case USBDEVFS_REAPURBNDELAY: return reap(arg);
      case USBDEVFS_DISCARDURB: {
        // The argument is the URB's address in the client.
        const auto addr = *reinterpret_cast<gulong*>(arg->data);
        const auto it = std::find_if(waiting_in_.begin(), waiting_in_.end(),
                                     [&](const Urb& u) { return u.data->client_addr == addr; });
        if (it == waiting_in_.end()) return {-1, EINVAL};
        it->get()->status = -ENOENT;
        it->get()->actual_length = 0;
        done_.push_back(std::move(*it));
        waiting_in_.erase(it);
        ++instrument_.discarded_urbs;
        return {0, 0};
      }
      default:
        instrument_.unexpected_ioctls.push_back(request);
        return {-1, ENOTTY};
    }
  }

  std::pair<long, int> submit(UMockdevIoctlData* arg) {
    Urb u;
    u.data = resolve(arg, 0, sizeof(usbdevfs_urb));
    auto* urb = u.get();
    if (urb->buffer_length > 0)
      u.buffer = resolve(u.data.get(), offsetof(usbdevfs_urb, buffer),
                         static_cast<std::size_t>(urb->buffer_length));
    std::span<std::uint8_t> buf;
    if (u.buffer) buf = {u.buffer->data, static_cast<std::size_t>(u.buffer->data_len)};
    urb->status = 0;
    urb->actual_length = 0;
    if (urb->type == USBDEVFS_URB_TYPE_CONTROL && urb->endpoint == 0 && buf.size() >= 8) {
      // The buffer holds the 8-byte setup packet, then the data stage.
      const ControlSetup s{buf[0], buf[1], static_cast<std::uint16_t>(buf[2] | buf[3] << 8),
                           static_cast<std::uint16_t>(buf[4] | buf[5] << 8),
                           static_cast<std::uint16_t>(buf[6] | buf[7] << 8)};
      if (const auto data = instrument_.on_control(s)) {
        const std::size_t n = std::min<std::size_t>({data->size(), s.length, buf.size() - 8});
        std::copy_n(data->begin(), n, buf.begin() + 8);
        urb->actual_length = static_cast<int>(n);
      } else {
        urb->status = -EPIPE;  // stall
      }
      done_.push_back(std::move(u));
    } else if (urb->type == USBDEVFS_URB_TYPE_BULK && urb->endpoint == kBulkOut) {
      instrument_.on_bulk_out(buf);
      urb->actual_length = urb->buffer_length;
      done_.push_back(std::move(u));
    } else if (urb->type == USBDEVFS_URB_TYPE_BULK && urb->endpoint == kBulkIn) {
      waiting_in_.push_back(std::move(u));
    } else {
      return {-1, EINVAL};
    }
    return {0, 0};
  }

  std::pair<long, int> reap(UMockdevIoctlData* arg) {
    if (done_.empty() && !waiting_in_.empty()) {
      Urb& u = waiting_in_.front();
      const std::size_t room = u.buffer ? static_cast<std::size_t>(u.buffer->data_len) : 0;
      if (const auto data = instrument_.on_bulk_in(room)) {
        std::copy(data->begin(), data->end(), u.buffer->data);
        u.get()->actual_length = static_cast<int>(data->size());
        done_.push_back(std::move(u));
        waiting_in_.pop_front();
      }
    }
    if (done_.empty()) return {-1, EAGAIN};
    // The argument points at the client's URB pointer: make it point at the reaped URB.
    const auto ptr = resolve(arg, 0, sizeof(void*));
    umockdev_ioctl_data_set_ptr(ptr.get(), 0, done_.front().data.get());
    done_.pop_front();
    return {0, 0};
  }

  GRef<UMockdevIoctlBase> base_;
  std::mutex mutex_;
  Instrument instrument_;
  std::deque<Urb> done_;        // ready to reap, in completion order
  std::deque<Urb> waiting_in_;  // Bulk-IN URBs waiting for the instrument
};

class UsbtmcUmockdev : public ::testing::Test {
 protected:
  void SetUp() override {
    testbed_.reset(umockdev_testbed_new());
    if (!umockdev_in_mock_environment()) {  // true only with a testbed and the preload
      testbed_.reset();
      GTEST_SKIP() << "needs umockdev's preload library: run under umockdev-wrapper "
                      "(packages umockdev, libumockdev-dev; ctest does this)";
    }
    // The handler goes first so that the node answers as soon as the device exists.
    GError* err = nullptr;
    ASSERT_TRUE(umockdev_testbed_attach_ioctl(testbed_.get(), kDevNode, usbfs_.base(), &err))
        << (err ? err->message : "");
    ASSERT_TRUE(umockdev_testbed_add_from_file(
        testbed_.get(), GONIO_SOURCE_DIR "/tests/integration/drivers/umockdev/pm100d.umockdev",
        &err))
        << (err ? err->message : "");
  }

  void TearDown() override {
    if (testbed_) {
      umockdev_testbed_detach_ioctl(testbed_.get(), kDevNode, nullptr);
      // Whatever the test did, nothing asked usbfs for something it does not emulate.
      usbfs_.with_instrument([](Instrument& i) {
        EXPECT_TRUE(i.unexpected_ioctls.empty())
            << "unexpected usbfs ioctl 0x" << std::hex << i.unexpected_ioctls.front();
      });
    }
  }

  template <class F>
  auto instrument(F&& f) { return usbfs_.with_instrument(std::forward<F>(f)); }

  UsbfsHandler usbfs_;
  GRef<UMockdevTestbed> testbed_;
};

std::unique_ptr<tmc::UsbtmcTransport> open_device(std::string_view selector,
                                                  tmc::Options o = {}) {
  auto endpoints = tmc::open_libusb(tmc::DeviceSelector::parse(selector));
  return std::make_unique<tmc::UsbtmcTransport>(std::move(endpoints), o);
}

Errc open_error(std::string_view selector) {
  try {
    open_device(selector);
  } catch (const Error& e) {
    return e.code();
  }
  ADD_FAILURE() << selector << " opened";
  return Errc::internal;
}

// Reads one whole message (up to EOM).
std::string read_message(gonio::drivers::Transport& t, std::chrono::milliseconds timeout) {
  const auto deadline = deadline_after(timeout);
  std::string out;
  char buf[256];
  for (;;) {
    const auto r = t.read_some(buf, deadline);
    out.append(buf, r.size);
    if (r.end_of_message) return out;
  }
}

TEST_F(UsbtmcUmockdev, ListsTheDeviceAsUsbtmc) {
  const auto devices = tmc::list_usb_devices();
  const auto it = std::find_if(devices.begin(), devices.end(), [](const tmc::UsbDeviceInfo& d) {
    return d.vid == 0x1313 && d.pid == 0x8078;
  });
  ASSERT_NE(it, devices.end());
  EXPECT_TRUE(it->usbtmc);
  EXPECT_EQ(it->bus, 1);
  EXPECT_EQ(it->address, 5);
  EXPECT_EQ(it->manufacturer, "Thorlabs");
  EXPECT_EQ(it->product, "PM100D");
  EXPECT_EQ(it->serial, "P0012345");
}

TEST_F(UsbtmcUmockdev, QueryGoesThroughBulkTransfersWithHeaders) {
  {
    gonio::drivers::scpi::Session session(open_device("1313:8078"));
    EXPECT_EQ(session.query("*IDN?", deadline_after(5s)), "Thorlabs,PM100D,P0012345,2.8.0");
    EXPECT_EQ(session.query("MEAS:POW?", deadline_after(5s)), "1.234E-03");
  }
  instrument([](Instrument& i) {
    // USB488 interface 0 claimed, released when the transport is gone.
    EXPECT_EQ(i.claimed, std::vector<unsigned>{0});
    EXPECT_EQ(i.released, std::vector<unsigned>{0});
    ASSERT_EQ(i.bulk_out.size(), 4u);
    // DEV_DEP_MSG_OUT (§3.2.1.1, Table 3): MsgID 1, bTag 1, bTagInverse, reserved,
    // TransferSize 6, EOM, 3 reserved, "*IDN?\n", 2 alignment bytes (§3.2.1.1).
    EXPECT_EQ(i.bulk_out[0], (Bytes{1, 1, 0xFE, 0, 6, 0, 0, 0, 1, 0, 0, 0,
                                    '*', 'I', 'D', 'N', '?', '\n', 0, 0}));
    // REQUEST_DEV_DEP_MSG_IN (§3.2.1.2, Table 4): bTag 2, TransferSize 4096, no TermChar.
    EXPECT_EQ(i.bulk_out[1], (Bytes{2, 2, 0xFD, 0, 0x00, 0x10, 0, 0, 0, 0, 0, 0}));
    EXPECT_EQ(i.bulk_out[2][1], 3);
    EXPECT_EQ(i.bulk_out[3][1], 4);
    EXPECT_TRUE(i.control.empty());
  });
}

TEST_F(UsbtmcUmockdev, LongReplySpansSeveralTransfers) {
  std::string reply;
  for (int k = 0; k < 30; ++k) reply += std::to_string(k * 1.5) + ",";
  reply.back() = '\n';
  instrument([&](Instrument& i) { i.long_reply = reply; });
  tmc::Options o;
  o.max_transfer = 64;
  const auto t = open_device("1313:8078", o);
  t->write("LONG?\n", deadline_after(5s));
  EXPECT_EQ(read_message(*t, 5s), reply);
  instrument([&](Instrument& i) {
    const std::size_t requests = (reply.size() + 63) / 64;
    ASSERT_EQ(i.bulk_out.size(), 1 + requests);
    for (std::size_t k = 1; k < i.bulk_out.size(); ++k) {
      EXPECT_EQ(i.bulk_out[k][0], 2);
      EXPECT_EQ(i.bulk_out[k][1], k + 1) << "every transfer takes the next bTag";
    }
  });
}

TEST_F(UsbtmcUmockdev, SelectsTheDeviceBySerialNumber) {
  EXPECT_NO_THROW(open_device("1313:8078:P0012345"));
  instrument([](Instrument& i) {
    // The serial number was read from the device: GET_DESCRIPTOR(STRING) requests.
    EXPECT_TRUE(std::any_of(i.control.begin(), i.control.end(), [](const ControlSetup& s) {
      return s.request_type == 0x80 && s.request == 6 && s.value == 0x0303;
    }));
  });
  EXPECT_EQ(open_error("1313:8078:P0099999"), Errc::not_found);
  instrument([](Instrument& i) { EXPECT_EQ(i.claimed.size(), 1u) << "claimed another serial"; });
}

TEST_F(UsbtmcUmockdev, OtherIdsAreNotFound) {
  EXPECT_EQ(open_error("1313:8079"), Errc::not_found);
  EXPECT_EQ(open_error("1314:8078"), Errc::not_found);
  instrument([](Instrument& i) { EXPECT_TRUE(i.claimed.empty()); });
}

TEST_F(UsbtmcUmockdev, MalformedReplyHeaderIsAProtocolErrorAndClearsTheDevice) {
  instrument([](Instrument& i) { i.fault = Instrument::Fault::bad_tag_inverse; });
  const auto t = open_device("1313:8078");
  t->write("*IDN?\n", deadline_after(5s));
  try {
    read_message(*t, 5s);
    ADD_FAILURE() << "a reply with a wrong bTagInverse was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::protocol_error) << e.what();
    EXPECT_NE(std::string(e.what()).find("bTagInverse"), std::string::npos) << e.what();
  }
  instrument([](Instrument& i) {
    // §4.2.1.6 INITIATE_CLEAR, §4.2.1.7 CHECK_CLEAR_STATUS on interface 0, then
    // CLEAR_FEATURE(ENDPOINT_HALT) on Bulk-OUT.
    ASSERT_EQ(i.control.size(), 2u);
    EXPECT_EQ(i.control[0].request_type, 0xA1);
    EXPECT_EQ(i.control[0].request, 5);
    EXPECT_EQ(i.control[0].index, 0);
    EXPECT_EQ(i.control[1].request, 6);
    EXPECT_EQ(i.cleared_halts, std::vector<unsigned>{kBulkOut});
  });
}

TEST_F(UsbtmcUmockdev, SilentDeviceTimesOutAndTheTransferIsAborted) {
  instrument([](Instrument& i) { i.fault = Instrument::Fault::silent; });
  const auto t = open_device("1313:8078");
  t->write("*IDN?\n", deadline_after(5s));
  // The deadline acted on is shown by what the driver did at it (the error, the URB libusb
  // discarded, the abort), not by a stopwatch: a read that ignored it would never return.
  try {
    read_message(*t, 300ms);
    ADD_FAILURE() << "a silent device answered";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::timeout) << e.what();
  }
  instrument([](Instrument& i) {
    // libusb gave up on the Bulk-IN URB (DISCARDURB); the driver then ran §4.2.1.4
    // INITIATE_ABORT_BULK_IN for the request's bTag (2) on endpoint 0x81, read the short
    // packet that ends the aborted transfer, and §4.2.1.5 CHECK_ABORT_BULK_IN_STATUS.
    EXPECT_GE(i.discarded_urbs, 1);
    ASSERT_EQ(i.control.size(), 2u);
    EXPECT_EQ(i.control[0].request_type, 0xA2);
    EXPECT_EQ(i.control[0].request, 3);
    EXPECT_EQ(i.control[0].value, 2);
    EXPECT_EQ(i.control[0].index, kBulkIn);
    EXPECT_EQ(i.control[1].request, 4);
  });
}

}  // namespace
