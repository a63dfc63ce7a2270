// gonioctl demo — the README's main job, end to end on the mock instrument:
// start goniod --mock in a fresh state dir, create the glossy demo sample, submit the demo
// scan (θi = 45°, θr = −30…80° step 2°, 400–700 nm), watch it live, print measured vs
// predicted with the divergence summary, plot both curves to a PNG (twin plot API), and stop
// goniod with SIGTERM (or leave it serving).
#include <fcntl.h>
#include <sys/prctl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <thread>

#include <fmt/format.h>

#include "ctl/ctl_internal.hpp"
#include "gonio/daemon/config/config.hpp"
#include "gonio/daemon/ctl/ctl.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/twin/plot.hpp"

namespace gonio::daemon::ctl {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr const char* kSampleName = "glossy-demo";
// The receive arm stays 15° clear of the incidence arm (retro-reflection at θr = −45°).
constexpr const char* kGrid = "in=45;out=-30:80:2";
constexpr const char* kWavelengths = "400:700:10";

fs::path self_dir() {
  std::error_code ec;
  const auto exe = fs::read_symlink("/proc/self/exe", ec);
  return ec ? fs::current_path() : exe.parent_path();
}

pid_t spawn_goniod(const std::string& exe, const fs::path& dir, const fs::path& config, bool detach) {
  const auto log = (dir / "goniod.log").string();
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) throw Error(Errc::io_error, fmt::format("fork: {}", std::strerror(errno)));
  if (pid == 0) {
    // Unless it is to keep serving, goniod goes down with the demo, however the demo ends.
    if (!detach) {
      ::prctl(PR_SET_PDEATHSIG, SIGTERM);
      if (::getppid() != parent) ::_exit(1);
    }
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0640);
    if (fd >= 0) {
      ::dup2(fd, STDOUT_FILENO);
      ::dup2(fd, STDERR_FILENO);
    }
    const std::string state = dir.string(), cfg = config.string();
    ::execl(exe.c_str(), exe.c_str(), "--state-dir", state.c_str(), "--config", cfg.c_str(), "--mock",
            static_cast<char*>(nullptr));
    ::_exit(127);
  }
  return pid;
}

// Waits for goniod's socket; fails early if goniod exits.
void wait_ready(pid_t pid, const fs::path& dir) {
  const auto sock = "unix:" + (dir / "goniod.sock").string();
  for (int i = 0; i < 300; ++i) {
    int status = 0;
    if (::waitpid(pid, &status, WNOHANG) == pid)
      throw Error(Errc::io_error, fmt::format("goniod exited ({}) during start-up; see {}",
                                              WIFEXITED(status) ? WEXITSTATUS(status) : -1,
                                              (dir / "goniod.log").string()));
    try {
      Client c(sock, std::chrono::seconds(5));
      c.call("system.info");
      return;
    } catch (const std::exception&) {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  }
  throw Error(Errc::timeout, fmt::format("goniod did not answer on {} within 15 s", sock));
}

int stop_goniod(pid_t pid) {
  ::kill(pid, SIGTERM);
  for (int i = 0; i < 600; ++i) {
    int status = 0;
    if (::waitpid(pid, &status, WNOHANG) == pid) return WIFEXITED(status) ? WEXITSTATUS(status) : 128;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ::kill(pid, SIGKILL);
  ::waitpid(pid, nullptr, 0);
  return 137;
}

std::size_t channel_near(const json& wavelengths, double nm) {
  std::size_t c = 0;
  for (std::size_t i = 0; i < wavelengths.size(); ++i)
    if (std::abs(wavelengths[i].get<double>() - nm) < std::abs(wavelengths[c].get<double>() - nm)) c = i;
  return c;
}

// The state directory: the one asked for, else a fresh one under the temporary directory.
fs::path state_dir(const DemoOptions& d) {
  if (!d.state_dir.empty()) {
    fs::create_directories(d.state_dir);
    return d.state_dir;
  }
  std::string tmpl = (fs::temp_directory_path() / "gonio-demo-XXXXXX").string();
  if (!::mkdtemp(tmpl.data())) throw Error(Errc::io_error, fmt::format("mkdtemp: {}", std::strerror(errno)));
  return tmpl;
}

// The mock lab: the demo sample is its hidden true sample; motion takes (scaled) real time.
fs::path write_config(const fs::path& dir, double time_scale) {
  const auto config = dir / "demo.toml";
  std::ofstream out(config);
  out << "# goniod configuration of `gonioctl demo`: the mock instrument\n"
      << "[server]\nlog_level = \"info\"\n\n"
      << "[instrument.motion]\ndriver = \"mock\"\n"
      << fmt::format("sample = \"{}\"\n", kDemoSampleBsdf)
      << fmt::format("time_scale = {}\n\n", time_scale)
      << "[instrument.photometer]\ndriver = \"mock\"\n";
  return config;
}

// The demo sample, created unless an earlier demo in the same directory left it.
json demo_sample(Session& s) {
  try {
    return s.call("sample.get", json{{"sample", kSampleName}});
  } catch (const RpcError&) {
    return s.call("sample.create", json{{"name", kSampleName},
                                        {"notes", "glossy orange paint: diffuse base under a clear coat"},
                                        {"bsdf", kDemoSampleBsdf},
                                        {"tolerance", 0.02}});
  }
}

// Every point of scan `id`, page by page.
json all_points(Session& s, std::int64_t id) {
  json points = json::array();
  for (std::size_t offset = 0;;) {
    const auto page = s.call("scan.points", json{{"scan", id}, {"offset", offset}, {"limit", 1000}});
    for (const auto& p : page["points"]) points.push_back(p);
    if (page["next_offset"].is_null()) return points;
    offset = page["next_offset"].get<std::size_t>();
  }
}

// The scan's curve at one channel, measured beside predicted, and what the summary says of it.
struct Curve {
  double nm = 0;
  std::vector<double> x, ym, um, yp, up, z, de;  // NAN where a point has no prediction
  double z_worst = 0, de_worst = 0, de_sum = 0, tr_z = 0, tr_de = 0;
  std::size_t n_div = 0, n_de = 0, n_agree = 0, n_undecided = 0;
};

// The curve of `points` at the channel nearest 550 nm, printed as a table, a row a point.
Curve print_points(const json& points) {
  Curve k;
  const auto c = channel_near(points.front()["measured"]["wavelengths_nm"], 550);
  k.nm = points.front()["measured"]["wavelengths_nm"][c].get<double>();
  Table t({"θr", fmt::format("β meas {:g} nm", k.nm), "±u", "β twin", "±se", "max|z|", "ΔE00", ""});
  for (const auto& p : points) {
    const double tr = p["planned"]["theta_r"].get<double>();
    const auto& m = p["measured"];
    k.x.push_back(tr);
    k.ym.push_back(m["values"][c].get<double>());
    k.um.push_back(m["std_uncertainty"][c].get<double>());
    const bool has_pred = !p["predicted"].is_null();
    k.yp.push_back(has_pred ? p["predicted"]["values"][c].get<double>() : NAN);
    k.up.push_back(has_pred ? p["predicted"]["std_uncertainty"][c].get<double>() : NAN);
    k.z.push_back(p["z_max"].is_null() ? NAN : p["z_max"].get<double>());
    k.de.push_back(p["delta_e00"].is_null() ? NAN : p["delta_e00"].get<double>());
    if (std::isfinite(k.z.back()) && k.z.back() > k.z_worst) k.z_worst = k.z.back(), k.tr_z = tr;
    if (std::isfinite(k.de.back())) {
      k.de_sum += k.de.back(), ++k.n_de;
      if (k.de.back() > k.de_worst) k.de_worst = k.de.back(), k.tr_de = tr;
    }
    if (p["diverged"].get<bool>()) ++k.n_div;
    const auto decision = p.value("decision", std::string());
    k.n_agree += decision == "agrees";
    k.n_undecided += decision == "undecided";
    t.add({fmt::format("{:g}", tr), fmt::format("{:.4g}", k.ym.back()), fmt::format("{:.2g}", k.um.back()),
           has_pred ? fmt::format("{:.4g}", k.yp.back()) : "-", has_pred ? fmt::format("{:.2g}", k.up.back()) : "-",
           std::isfinite(k.z.back()) ? fmt::format("{:.2f}", k.z.back()) : "-",
           std::isfinite(k.de.back()) ? fmt::format("{:.2f}", k.de.back()) : "-",
           p["diverged"].get<bool>() ? "OUT OF TOLERANCE" : decision == "undecided" ? "undecided" : ""});
  }
  std::cout << "\nmeasured vs predicted (θi = 45°):\n" << t.render();
  return k;
}

void print_summary(const Curve& k, std::size_t points, double tolerance, double coverage_k, const json& alerts,
                   const json& verdict) {
  std::cout << fmt::format(
      "\ndivergence summary: {} of {} points out of tolerance (±{:g} %, k = {:g}), {} agree, {} "
      "undecided; worst |m − p|/u_c {:.2f} at θr = {:g}°; ΔE00 mean {:.2f}, worst {:.2f} at θr = {:g}°; "
      "{} alert(s)\n",
      k.n_div, points, 100 * tolerance, coverage_k, k.n_agree, k.n_undecided, k.z_worst, k.tr_z,
      k.n_de ? k.de_sum / static_cast<double>(k.n_de) : 0.0, k.de_worst, k.tr_de, alerts.size())
            << verdict_text(verdict);
  // Points undecided and a scan that agrees are not a contradiction: say why.
  const auto decision = verdict.is_object() ? verdict.value("decision", std::string()) : std::string();
  if (k.n_undecided > 0 && decision == "agrees") {
    std::vector<double> rel;
    for (std::size_t i = 0; i < k.ym.size(); ++i)
      if (std::isfinite(k.yp[i]) && k.yp[i] > 0) rel.push_back(std::hypot(k.um[i], k.up[i]) / k.yp[i]);
    std::sort(rel.begin(), rel.end());
    const double median = rel.empty() ? 0.0 : rel[rel.size() / 2];
    std::cout << fmt::format(
        "  why it agrees while {} points are undecided: a point agrees on its own only when its whole "
        "interval m − p ± {:g}·u_c lies within ±{:g} %, and one point's u_c is about {:.2g} % of β "
        "(median), so k·u_c alone nearly fills the tolerance; the verdict pools all {} points, whose mean "
        "difference is known far better than any one point's (docs/decision-rule.md)\n",
        k.n_undecided, coverage_k, 100 * tolerance, 100 * median, points);
  }
  for (const auto& a : alerts)
    std::cout << fmt::format("  alert {} [{}] {} (×{})\n", cell(a["id"]), cell(a["severity"]),
                             cell(a["message"]), cell(a["count"]));
}

// Both curves above, the divergence per point below with its thresholds.
void plot(const Curve& k, std::int64_t id, double z_threshold, double de_threshold, const fs::path& png) {
  twin::Figure fig;
  fig.title = fmt::format("gonio demo — scan {}: '{}' at θi = 45°, measured vs twin", id, kSampleName);
  fig.width = 1000;
  fig.height = 720;
  auto& top = fig.panels.emplace_back();
  top.title = fmt::format("radiance factor at {:g} nm", k.nm);
  top.x = twin::Axis("receiving angle θr", "°");
  top.y = twin::Axis("β").logarithmic();
  top.height_ratio = 2;
  auto& meas = top.series.emplace_back("measured (mock instrument) ±u", k.x, k.ym, k.um);
  meas.line = twin::LineStyle::none;
  meas.marker = twin::Marker::circle;
  meas.marker_size = 5;
  top.series.emplace_back("predicted (twin) ", k.x, k.yp);
  auto& bottom = fig.panels.emplace_back();
  bottom.x = twin::Axis("receiving angle θr", "°");
  bottom.y = twin::Axis("max |z|, ΔE00");
  auto& zs = bottom.series.emplace_back("max |z|", k.x, k.z);
  zs.marker = twin::Marker::circle;
  zs.marker_size = 4;
  auto& ds = bottom.series.emplace_back("ΔE00", k.x, k.de);
  ds.line = twin::LineStyle::dashed;
  double top_value = std::max(z_threshold, de_threshold);
  for (double v : k.z) if (std::isfinite(v)) top_value = std::max(top_value, v);
  for (double v : k.de) if (std::isfinite(v)) top_value = std::max(top_value, v);
  bottom.y.range(0, 1.1 * top_value);
  bottom.y_reference_lines = {z_threshold, de_threshold};
  bottom.title = fmt::format("divergence per point (thresholds: max |z| {:g}, ΔE00 {:g})", z_threshold,
                             de_threshold);
  twin::write_figure(fig, png.string());
}

// The demo's job against the goniod at `dir`: the scan, its table, summary and plot. Returns
// watch_scan's exit code.
int run_scan(const Options& o, const fs::path& dir, const fs::path& png) {
  Options so = o;
  so.state_dir = dir.string();
  so.connect = "unix:" + (dir / "goniod.sock").string();
  Session s(so);
  const auto info = s.call("system.info");
  const double z_threshold = info["divergence"]["z_threshold"].get<double>();
  const double de_threshold = info["divergence"]["delta_e_threshold"].get<double>();
  const double coverage_k = info["divergence"]["coverage_k"].get<double>();

  const json sample = demo_sample(s);
  std::cout << fmt::format("demo: sample '{}' (id {}): {}\n", kSampleName, cell(sample["id"]),
                           cell(sample["bsdf"]));
  const auto scan = s.call("scan.submit", json{{"sample", kSampleName},
                                              {"name", "demo: in-plane curve at 45°"},
                                              {"grids", {kGrid}},
                                              {"wavelengths", kWavelengths}});
  const auto id = scan["id"].get<std::int64_t>();
  std::cout << fmt::format("demo: scan {} queued: {} points, grid '{}', {} nm\n", id,
                           cell(scan["points_total"]), kGrid, kWavelengths);
  const int code = watch_scan(s, id, false);

  // Every point, measured beside predicted.
  const json points = all_points(s, id);
  if (points.empty()) throw Error(Errc::internal, "the demo scan stored no point");
  const Curve k = print_points(points);
  const auto alerts = s.call("alert.list", json{{"scan", id}, {"limit", 1000}});
  const auto verdict = s.call("scan.get", json{{"scan", id}})["verdict"];
  print_summary(k, points.size(), sample["tolerance"].get<double>(), coverage_k, alerts, verdict);
  plot(k, id, z_threshold, de_threshold, png);
  std::cout << fmt::format("\ndemo: plot written to {}\n", png.string());
  return code;
}

}  // namespace

int run_demo(const DemoOptions& d, const Options& o) {
  const fs::path dir = state_dir(d);
  const std::string goniod = d.goniod.empty() ? (self_dir() / "goniod").string() : d.goniod;
  const fs::path png = d.output.empty() ? dir / "demo.png" : fs::path(d.output);
  const auto config = write_config(dir, d.time_scale);
  std::cout << fmt::format("demo: starting goniod --mock in {}\n", dir.string());
  ::signal(SIGPIPE, SIG_IGN);  // a closed stdout must not leave goniod behind
  const pid_t pid = spawn_goniod(goniod, dir, config, d.keep_serving);
  int code = ctl_exit::ok;
  try {
    wait_ready(pid, dir);
    code = run_scan(o, dir, png);
  } catch (...) {
    if (!d.keep_serving) stop_goniod(pid);
    throw;
  }
  if (d.keep_serving) {
    std::cout << fmt::format(
        "demo: goniod (pid {}) keeps serving on unix:{}\n      try: gonioctl --state-dir {} scan list\n"
        "      stop it with: kill -TERM {}\n",
        pid, (dir / "goniod.sock").string(), dir.string(), pid);
    return code;
  }
  const int rc = stop_goniod(pid);
  std::cout << fmt::format("demo: goniod stopped (exit {}); state dir {} kept (store, log, plot)\n", rc,
                           dir.string());
  return code != ctl_exit::ok ? code : (rc == 0 ? ctl_exit::ok : ctl_exit::server);
}

}  // namespace gonio::daemon::ctl
