// goniod start-up, run and shutdown (see daemon.hpp).
#include "gonio/daemon/startup/daemon.hpp"

#include <sys/resource.h>
#include <sys/stat.h>
#include <malloc.h>
#include <systemd/sd-daemon.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstring>
#include <fstream>
#include <ostream>
#include <thread>

#include <utility>  // before Asio: Boost 1.74's awaitable.hpp uses std::exchange without it

#include <boost/asio/io_context.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/signal_set.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/thread_pool.hpp>
#include <fmt/format.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/sinks/systemd_sink.h>
#include <spdlog/spdlog.h>

#include "gonio/daemon/config/config.hpp"
#include "gonio/daemon/fleet/archive.hpp"
#include "gonio/daemon/fleet/mqtt.hpp"
#include "gonio/daemon/instrument/alerts.hpp"
#include "gonio/daemon/instrument/diagnosis.hpp"
#include "gonio/daemon/instrument/instrument.hpp"
#include "gonio/daemon/instrument/twin_service.hpp"
#include "gonio/daemon/methods/methods.hpp"
#include "gonio/daemon/net/net.hpp"
#include "gonio/daemon/rpc/auth.hpp"
#include "gonio/daemon/rpc/fair_queue.hpp"
#include "gonio/daemon/rpc/governor.hpp"
#include "gonio/daemon/rpc/hub.hpp"
#include "gonio/daemon/rpc/rpc.hpp"
#include "gonio/daemon/store/retention.hpp"
#include "gonio/daemon/store/store.hpp"
#include "startup/instrument_tables.hpp"
#include "startup/signals.hpp"

#include "gonio/proto/json_util.hpp"
#include "gonio/proto/version.hpp"
#include "gonio/registry/registry.hpp"

namespace gonio::daemon {
namespace {

namespace asio = boost::asio;
namespace fs = std::filesystem;
using nlohmann::json;

void setup_logging(const std::string& level) {
  std::shared_ptr<spdlog::logger> logger;
  // Under systemd stderr goes to the journal anyway; the journal sink keeps the levels.
  if (std::getenv("JOURNAL_STREAM") || std::getenv("INVOCATION_ID"))
    logger = std::make_shared<spdlog::logger>(
        "goniod", std::make_shared<spdlog::sinks::systemd_sink_mt>("goniod"));
  else
    logger = std::make_shared<spdlog::logger>(
        "goniod", std::make_shared<spdlog::sinks::stderr_color_sink_mt>());
  logger->set_pattern("%Y-%m-%dT%H:%M:%S.%e %^%l%$ %v");
  logger->set_level(spdlog::level::from_str(level));
  spdlog::set_default_logger(logger);
}

void write_file_atomic(const fs::path& path, const std::string& text, fs::perms perms) {
  const auto tmp = path.string() + ".tmp";
  {
    std::ofstream out(tmp, std::ios::trunc);
    out << text;
    if (!out) throw Error(Errc::io_error, fmt::format("cannot write {}", tmp));
  }
  fs::permissions(tmp, perms);
  fs::rename(tmp, path);
}

// --check-config shows what goniod would log as warnings.
std::string warnings_text(const Config& c) {
  std::string out;
  for (const auto& w : c.warnings) out += fmt::format("# warning: {}\n", w);
  return out;
}

Config load_config(const DaemonOptions& o) {
  std::optional<Config> base;
  if (o.mock) base = Config::mock_defaults();
  Config c = o.config_file ? Config::load(*o.config_file, base) : base.value_or(Config{});
  settle_instrument_tables(c, o.mock);  // --mock wins over hardware tables, and says so
  if (!o.listen.empty()) {
    c.listen.clear();
    for (std::size_t i = 0; i < o.listen.size(); ++i)
      c.listen.push_back(ListenUri::parse(o.listen[i], fmt::format("--listen[{}]", i)));
  }
  if (o.log_level) c.log_level = *o.log_level;
  for (const auto& w : c.warnings) spdlog::warn("config: {}", w);
  if (c.motion.empty() || c.photometer.empty())
    throw Error::invalid("instrument", "no instrument configured: pass --mock, or a config file "
                                       "with [instrument.motion] and [instrument.photometer]");
  c.validate();
  return c;
}

// The latest calibrated profile replaces the configured one when it was made from it (same
// profile name); a calibration of another profile is kept in the store but not applied.
void use_calibrated_profile(const Store& store, TwinService& twin) {
  const auto stored = store.latest_profile();
  if (!stored) return;
  const auto configured = twin.profile();
  if (stored->name != configured.name) {
    spdlog::warn("the latest calibration (version {}) is of profile '{}', not the configured '{}': "
                 "predicting with the configured profile", stored->version, stored->name,
                 configured.name);
    return;
  }
  try {
    auto profile = stored->profile.get<twin::InstrumentProfile>();
    profile.validate();
    twin.set_profile(std::move(profile), stored->version, stored->created_at);
  } catch (const std::exception& e) {
    spdlog::error("cannot use calibrated profile version {}: {}; predicting with the configured "
                  "profile", stored->version, e.what());
    return;
  }
  spdlog::info("instrument profile {} version {} (calibrated {} by {})", stored->name,
               stored->version, stored->created_at, stored->created_by);
}

// What is at a device's address now; the instrument may be unplugged while its config is
// checked, so a missing device is reported, not refused.
std::string device_state(const drivers::DeviceRef& d) {
  using Kind = drivers::DeviceRef::Kind;
  if (d.kind == Kind::tcp) return "a TCP endpoint, not tried";
  if (d.kind == Kind::usb) return "a USB device by VID:PID, not looked up";
  struct stat st {};
  if (::stat(d.address.c_str(), &st) != 0)
    return fmt::format("missing ({}): goniod reports the instrument unavailable and retries "
                       "until it appears", std::strerror(errno));
  if (S_ISCHR(st.st_mode)) return "present, a character device";
  return "present, but not a character device";
}

std::string axes_text(const drivers::SideCheck& s) {
  std::string text;
  for (drivers::Axis a : s.axes) {
    text += fmt::format("{}{}", text.empty() ? "" : ", ", to_text(a));
    for (const auto& [axis, deg] : s.home)
      if (axis == a) text += fmt::format(" (homes to {}°)", deg);
  }
  return text;
}

// The keys the printed configuration leaves out: not set, so their values are decided at
// start (the admins' uids are goniod's own, ...). Named in comments so that every key shows.
std::string unset_keys(const Config& config) {
  std::string out;
  for (const auto& key : config_keys()) {
    if (!key.write(config).is_null()) continue;
    std::string shown(key.default_text);
    std::erase(shown, '`');
    out += fmt::format("# {}.{} is not set: {}\n", key.section, key.name, shown == "—" ? "none" : shown);
  }
  return out.empty() ? out : out + "\n";
}

// Client work yields to the measurement. The threads that serve clients (the network's
// I/O threads and the RPC workers) run kClientNice steps below the rest of goniod (the scan
// runner, the twin's workers, the control methods' threads, MQTT, the archive), so that
// under contention the kernel's fair scheduler gives them a weight of 110 against 1,024
// (sched(7), the nice-to-weight table): about a tenth of a core that the runner also
// wants, and all of any core it does not. Control methods keep the daemon's own priority.
constexpr int kClientNice = 10;

// Lowers the calling thread (Linux: setpriority on a thread id acts on that thread alone),
// once per thread. Raising it back would need CAP_SYS_NICE, so it is never undone.
void yield_to_measurement() {
  thread_local bool lowered = false;
  if (lowered) return;
  lowered = true;
  const auto tid = static_cast<id_t>(::gettid());
  errno = 0;
  const int now = ::getpriority(PRIO_PROCESS, tid);
  if (errno == 0 && ::setpriority(PRIO_PROCESS, tid, std::min(19, now + kClientNice)) != 0)
    spdlog::debug("cannot lower a client thread's priority: {}", std::strerror(errno));
}

constexpr const char* kRecoverReason =
    "goniod was stopped uncleanly during the scan; resumes at the next unmeasured point";

// The store in the state directory, the scans a crash left running marked to resume. On a
// full disk it opens read-only and the recovery waits until it can write (recover_later).
struct OpenedStore {
  std::unique_ptr<Store> store;
  bool recover_later = false;
};

OpenedStore open_store(const Config& config, const fs::path& state) {
  std::error_code ec;
  fs::create_directories(state, ec);
  if (ec) throw Error(Errc::io_error, fmt::format("cannot create {}: {}", state.string(), ec.message()));
  OpenedStore out;
  out.store = std::make_unique<Store>(state / "goniod.db", config.synchronous_full);
  out.store->set_min_free_mb(config.min_free_mb);
  // Before anything is written, so that the archive sees every change of this run.
  out.store->set_outbox(!config.archive.postgres.empty());
  try {
    for (auto id : out.store->recover_running(kRecoverReason))
      spdlog::warn("scan {} was running when goniod last stopped; it resumes first", id);
  } catch (const Error& e) {
    if (e.code() != Errc::storage_unavailable) throw;
    out.recover_later = true;
    spdlog::error("starting with a read-only store: {}", e.what());
  }
  return out;
}

void write_admin_token(Auth& auth, const fs::path& state) {
  try {
    if (auth.ensure_admin_token(state / "admin.token"))
      spdlog::info("wrote a new admin token to {} (mode 0600)", (state / "admin.token").string());
  } catch (const Error& e) {
    if (e.code() != Errc::storage_unavailable) throw;
    spdlog::error("no new admin token: {}", e.what());
  }
}

// The central archive and MQTT telemetry, each null unless configured.
struct Telemetry {
  std::unique_ptr<ArchiveShipper> archive;
  std::unique_ptr<MqttPublisher> mqtt;
};

Telemetry make_telemetry(const Config& config, Store& store, AlertService& alerts, Instrument& instrument) {
  Telemetry t;
  if (!config.archive.postgres.empty())
    t.archive = std::make_unique<ArchiveShipper>(
        config.archive,
        config.archive.instrument.empty() ? default_instrument_id() : config.archive.instrument,
        store, &alerts);
  if (!config.mqtt.url.empty())
    t.mqtt = std::make_unique<MqttPublisher>(
        config.mqtt, config.mqtt.instrument.empty() ? default_instrument_id() : config.mqtt.instrument,
        [&instrument] { return instrument.status().dump(); });
  return t;
}

void start_telemetry(Telemetry& t, const Config& config, Hub& hub) {
  if (t.mqtt) {
    hub.set_tap([p = t.mqtt.get()](std::string_view method, const std::string& params,
                                   std::optional<std::int64_t> scan) { p->publish(method, params, scan); });
    t.mqtt->start();
    spdlog::info("mqtt: publishing to {} under {}", config.mqtt.url, t.mqtt->topics().base());
  }
  if (t.archive) {
    t.archive->start();
    spdlog::info("archive: shipping to PostgreSQL as instrument '{}'", t.archive->instrument());
  }
}

rpc::DispatchLimits dispatch_limits(const Config& config) {
  rpc::DispatchLimits l;
  l.max_batch = config.max_batch;
  l.max_response_bytes = config.max_response_bytes;
  l.batch_window = config.max_in_flight;
  l.max_building_bytes = config.max_building_bytes;
  return l;
}

// The dashboard's files. Unless server.web_root is set, a build tree's goniod serves the
// tree's own (<build>/web/dist, beside bin/) before the installed one.
// Blocking methods run on `workers`, clients in turn (a FairQueue: one post per task, and
// each post runs whichever task is next in rotation), each after yielding to the
// measurement and waiting its turn at the governor; control methods on `control`.
rpc::Dispatcher make_dispatcher(const Config& config, asio::thread_pool& workers, asio::thread_pool& control,
                                rpc::ClientGovernor& governor) {
  auto queue = std::make_shared<rpc::FairQueue>();
  return rpc::Dispatcher(
      [&workers, &governor, queue](std::uint64_t client, std::function<void()> f) {
        queue->push(client, std::move(f));
        asio::post(workers, [&governor, queue] {
          yield_to_measurement();
          // The governor counts the requests' own CPU, on these threads: not the io threads'
          // reading, writing and notifications, which follow the measurement's pace.
          thread_local const bool counted = (rpc::mark_client_thread(), true);
          (void)counted;
          governor.wait_turn();
          if (auto task = queue->pop()) task();
        });
      },
      [&control](std::uint64_t, std::function<void()> f) { asio::post(control, std::move(f)); },
      dispatch_limits(config));
}

// system.info's "transports": an object of counters per listener.
std::function<void(JsonWriter&)> listener_stats(const std::vector<std::shared_ptr<net::Listener>>& listeners) {
  return [&listeners](JsonWriter& w) {
    for (const auto& l : listeners) {
      w.begin_object();
      l->write_stats(w);
      w.end_object();
    }
  };
}

std::shared_ptr<const WebRoot> load_dashboard(const Config& config) {
  std::error_code exe_ec;
  const auto web_root = config.served_web_root(fs::read_symlink("/proc/self/exe", exe_ec).string());
  auto web = std::make_shared<const WebRoot>(web_root.empty() ? WebRoot{} : WebRoot::load(web_root));
  const char* why = config.web_root_set ? "server.web_root" : web_root != config.web_root ? "beside goniod" : "the installed one";
  if (web->empty())
    spdlog::info("no dashboard: {} holds no files", web_root.empty() ? "server.web_root" : web_root);
  else
    spdlog::info("dashboard: {} files from {} ({})", web->size(), web_root, why);
  return web;
}

// The state dir's socket always, then the configured listeners; throws Error when one
// cannot be bound.
void open_listeners(asio::io_context& io, const Config& config, const fs::path& state,
                    const net::Context& ctx, std::vector<std::shared_ptr<net::Listener>>& listeners) {
  auto uris = config.listen;
  const auto default_sock = (state / "goniod.sock").string();
  if (std::none_of(uris.begin(), uris.end(), [&](const ListenUri& u) {
        return u.kind == ListenUri::Kind::unix_socket && u.path == default_sock;
      }))
    uris.insert(uris.begin(), ListenUri::parse("unix:" + default_sock));
  for (const auto& u : uris) {
    switch (u.kind) {
      case ListenUri::Kind::unix_socket: listeners.push_back(net::listen_unix(io, u.path, ctx)); break;
      case ListenUri::Kind::tcp: listeners.push_back(net::listen_tcp(io, u.host, u.port, ctx)); break;
      case ListenUri::Kind::http: listeners.push_back(net::listen_http(io, u.host, u.port, ctx)); break;
      case ListenUri::Kind::tls: listeners.push_back(net::listen_tls(io, u.host, u.port, ctx)); break;
      case ListenUri::Kind::https: listeners.push_back(net::listen_https(io, u.host, u.port, ctx)); break;
    }
    spdlog::info("listening on {}", listeners.back()->endpoint());
  }
}

// <state-dir>/endpoints.json: the bound URIs (real ports when 0 was asked) for clients.
json publish_endpoints(const fs::path& state, const std::vector<std::shared_ptr<net::Listener>>& listeners) {
  json endpoints = json::array();
  for (const auto& l : listeners) endpoints.push_back(l->endpoint());
  write_file_atomic(state / "endpoints.json", json{{"pid", ::getpid()}, {"listen", endpoints}}.dump() + "\n",
                    fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read);
  return endpoints;
}

// Audit rows of the daemon itself are not worth refusing to run for on a full disk.
void audit_self(Store& store, const std::string& action, const json& detail) {
  try {
    store.audit("goniod", action, "", detail);
  } catch (const Error& e) {
    if (e.code() != Errc::storage_unavailable) throw;
    spdlog::warn("{} not audited: {}", action, e.what());
  }
}

// The network threads: `main` (listeners, signals, timers, the webhook) and, with
// server.io_threads = N > 1, N - 1 io_contexts more, one thread each. Each connection is
// given to one of them in turn and stays there, so its handlers run one at a time on one
// thread with no strand, no lock shared with the other threads and no hand-off between them:
// one io_context run by two threads woke the other thread for each burst of completions,
// ~6 µs more of goniod's CPU per request than one thread (gonio-load, daemon/README.md).
class IoThreads {
 public:
  IoThreads(asio::io_context& main, int threads) : main_(main) {
    for (int i = 1; i < threads; ++i) more_.push_back(std::make_unique<asio::io_context>(1));
  }

  // The executor of the next connection.
  asio::any_io_executor next() {
    const auto i = next_.fetch_add(1, std::memory_order_relaxed) % (more_.size() + 1);
    if (i == 0) return main_.get_executor();
    return more_[i - 1]->get_executor();
  }

  // Runs every thread, this one on `main`, until `main` is stopped (at shutdown, once the
  // connections have ended); then stops the others. `main` is held to run until then: when
  // its listeners close it may have no work left while connections on the others still end.
  void run() {
    using Guard = asio::executor_work_guard<asio::io_context::executor_type>;
    std::vector<Guard> guards;
    guards.emplace_back(main_.get_executor());
    std::vector<std::thread> threads;
    for (auto& io : more_) {
      guards.emplace_back(io->get_executor());
      threads.emplace_back([&io = *io] {
        yield_to_measurement();
        rpc::mark_network_thread();
        io.run();
      });
    }
    // Everything that keeps the daemon's priority is started by now: this thread's lower
    // priority is inherited only by what it starts from here on (the stopper at shutdown).
    yield_to_measurement();
    rpc::mark_network_thread();
    main_.run();
    for (auto& io : more_) io->stop();
    for (auto& t : threads) t.join();
  }

 private:
  asio::io_context& main_;
  std::vector<std::unique_ptr<asio::io_context>> more_;
  std::atomic<std::size_t> next_{0};
};

// goniod serving from the opened store until a signal stops it: the services, the network,
// the instrument, then an orderly shutdown. Throws Error as run_daemon maps to exit codes.
int serve(const Config& config, const fs::path& state, OpenedStore& opened) {
  auto& store = opened.store;
  Auth auth(config.tokens, *store);
  write_admin_token(auth, state);
  TwinService twin(config, twin::InstrumentProfile::load(config.profile));
  use_calibrated_profile(*store, twin);
  Hub hub;
  AlertService alerts(*store, hub, parse_enum<Severity>(config.webhook_min_severity, "webhook.min_severity"));
  Instrument instrument(config, *store, twin, alerts, hub);

  auto telemetry = make_telemetry(config, *store, alerts, instrument);
  RetentionKeeper retention(*store, config.retention_days, telemetry.archive != nullptr);
  retention.start();
  // Unhooks the publisher from the hub before it goes, however this scope is left.
  struct Untap {
    Hub& hub;
    ~Untap() { hub.set_tap(nullptr); }
  } untap{hub};
  start_telemetry(telemetry, config, hub);

  asio::io_context io;
  IoThreads io_threads(io, config.io_threads);
  // Declared before the pools that wait on it, so that it outlives them.
  rpc::ClientGovernor governor({.busy_share = config.client_share_busy});
  asio::thread_pool workers(config.rpc_threads);
  // Control methods (pause, resume, cancel, reset) have threads of their own: a queue of
  // exports on the workers cannot delay them.
  asio::thread_pool control(2);
  rpc::Dispatcher dispatcher = make_dispatcher(config, workers, control, governor);
  dispatcher.set_principal_check([&auth](const Principal& p) { return auth.still_valid(p); });
  dispatcher.set_inline_gate([&governor] { return governor.holding(); });

  net::NetStats net_stats;
  std::vector<std::shared_ptr<net::Listener>> listeners;
  Services services{.config = config, .state_dir = state, .store = *store, .auth = auth, .hub = hub,
                    .twin = twin, .alerts = alerts, .instrument = instrument, .dispatcher = &dispatcher,
                    .started_at = utc::now(),
                    .transport_stats = listener_stats(listeners),
                    .net_stats = [&net_stats](JsonWriter& w) { net_stats.write(w); },
                    .end_sessions_of = [&listeners](const std::string& name) {
                      for (const auto& l : listeners) l->end_sessions_of(name);
                    },
                    .data_dir = config.twin_data_dir.empty() ? state / "data" : fs::path(config.twin_data_dir),
                    .archive = telemetry.archive.get(),
                    .mqtt = telemetry.mqtt.get(),
                    .governor_stats = [&governor](JsonWriter& w) { governor.write_stats(w); }};
  register_methods(dispatcher, services);

  const net::Context ctx{dispatcher, hub,
                         auth,       net::Limits::from(config),
                         net_stats,  load_dashboard(config),
                         [&io_threads] { return io_threads.next(); },
                         net::make_tls_server(config)};
  try {
    open_listeners(io, config, state, ctx, listeners);
  } catch (const Error& e) {
    spdlog::critical("{}", e.what());
    return exit_code::listen;
  }
  const auto endpoints = publish_endpoints(state, listeners);

  if (!config.webhook_url.empty()) {
    alerts.set_sink(net::make_webhook(io, config));
    spdlog::info("alerts at or above {} are POSTed to {}", config.webhook_min_severity, config.webhook_url);
  }

  // ---- instrument (a bad driver table is a usage error)
  std::optional<Diagnoser> diagnoser;
  if (config.diagnose) {
    diagnoser.emplace(*store, twin, alerts);
    instrument.set_sustained_listener(
        [&diagnoser](std::int64_t scan, std::int64_t alert) { diagnoser->request(scan, alert); });
  }
  if (opened.recover_later) instrument.recover_when_writable(kRecoverReason);
  instrument.set_status_listener([](const std::string& s) {
    sd_notifyf(0, "STATUS=%s", s.c_str());
  });
  try {
    instrument.start();
  } catch (const Error& e) {
    spdlog::critical("{}", e.what());
    for (auto& l : listeners) l->close();
    return exit_code::usage;
  }
  audit_self(*store, "daemon.start", json{{"version", GONIO_VERSION_STRING}, {"listen", endpoints}});

  // ---- signals, systemd
  StopOnSignal stop(io, listeners, instrument);
  ReloadOnSignal reload(io, ctx.tls);
  std::signal(SIGPIPE, SIG_IGN);
  Watchdog watchdog(io, config, instrument);
  watchdog.start();
  sd_notifyf(0, "READY=1\nSTATUS=ready, listening on %zu endpoint(s)\nMAINPID=%d", listeners.size(),
             static_cast<int>(::getpid()));
  spdlog::info("goniod {} ready (state dir {})", GONIO_VERSION_STRING, state.string());

  io_threads.run();

  // ---- shutdown
  stop.join();
  instrument.shutdown();
  control.join();
  governor.stop();  // client work it holds runs now, and the workers can finish
  workers.join();
  alerts.set_sink(nullptr);
  hub.set_tap(nullptr);
  if (telemetry.mqtt) telemetry.mqtt->stop();
  if (telemetry.archive) telemetry.archive->stop();
  audit_self(*store, "daemon.stop", json::object());
  spdlog::info("goniod stopped cleanly");
  return exit_code::ok;
}

}  // namespace

int check_config(const DaemonOptions& o, std::ostream& out, std::ostream& err) {
  const std::string source = o.config_file.value_or("<no file>");
  try {
    const Config config = load_config(o);
    try {
      (void)twin::InstrumentProfile::load(config.profile);
    } catch (const Error& e) {
      throw json_util::prefixed(e, "instrument.profile");
    }
    net::check_tls_files(config.tls);
    drivers::InstrumentCheck inst;
    try {
      inst = drivers::check_instrument(json{{"motion", config.motion}, {"photometer", config.photometer}},
                                       config.limits);
    } catch (const Error& e) {
      throw json_util::prefixed(e, "instrument");
    }
    out << fmt::format("# {}: valid. goniod {} would run with this configuration (every key,\n"
                       "# defaults filled in); it also listens on unix:<state-dir>/goniod.sock.\n\n",
                       source, GONIO_VERSION_STRING)
        << json_to_toml(config.to_json()) << "\n\n"
        << unset_keys(config)
        << warnings_text(config)
        << fmt::format("# instrument: motion driver '{}', axes {}; photometer driver '{}'\n",
                       inst.motion_driver, axes_text(inst.motion), inst.photometer_driver)
        << fmt::format("# the arms are kept {}° apart{}\n", inst.min_separation,
                       config.limits.min_separation ? "" : " (the motion driver's default)");
    std::vector<drivers::DeviceRef> devices = inst.motion.devices;
    devices.insert(devices.end(), inst.photometer.devices.begin(), inst.photometer.devices.end());
    if (devices.empty()) out << "# devices: none (no hardware)\n";
    for (const auto& d : devices)
      out << fmt::format("# device instrument.{} = {}: {}\n", d.field, d.address, device_state(d));
    if (!config.tls.cert.empty()) out << "# server.tls: the certificate and key are readable, match and are valid now\n";
    return exit_code::ok;
  } catch (const Error& e) {
    err << fmt::format("goniod: {}: {}\n", source, e.what());
    return exit_code::usage;
  } catch (const std::exception& e) {  // not a verdict on the file: a bug
    err << fmt::format("goniod: {}: internal error: {}\n", source, e.what());
    return exit_code::internal;
  }
}

int run_daemon(const DaemonOptions& o) {
  // Large buffers (message lines, answers, exports) come from mmap and go back to the system
  // when freed: glibc's adaptive threshold would otherwise move them into the heap after
  // the first one, where a burst of hostile requests leaves the memory resident.
  ::mallopt(M_MMAP_THRESHOLD, 256 << 10);
  ::umask(027);  // the store, its journal and endpoints.json: owner and group only
  Config config;
  try {
    config = load_config(o);
    setup_logging(config.log_level);
    net::check_tls_files(config.tls);  // before the state directory is touched
  } catch (const Error& e) {
    fmt::print(stderr, "goniod: {}\n", e.what());
    return exit_code::usage;
  }

  const fs::path state = o.state_dir;
  OpenedStore opened;
  try {
    opened = open_store(config, state);
  } catch (const Error& e) {
    spdlog::critical("{}", e.what());
    return exit_code::state;
  }

  try {
    return serve(config, state, opened);
  } catch (const Error& e) {
    spdlog::critical("{}", e.what());
    return e.code() == Errc::internal ? exit_code::internal
           : (e.code() == Errc::io_error ? exit_code::state : exit_code::usage);
  } catch (const std::exception& e) {
    spdlog::critical("internal error: {}", e.what());
    return exit_code::internal;
  }
}

}  // namespace gonio::daemon
