// gonioctl: command-line parsing and one function per command (see ctl.hpp).
#include <sys/stat.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <iostream>
#include <sstream>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "ctl/ctl_internal.hpp"
#include "gonio/daemon/auth.hpp"
#include "gonio/daemon/ctl.hpp"
#include "gonio/daemon/rpc.hpp"
#include "gonio/proto/error.hpp"

#ifndef GONIO_VERSION
#define GONIO_VERSION "0.0.0"
#endif

namespace gonio::daemon {
namespace ctl {

using nlohmann::json;

std::string default_state_dir() {
  if (const char* e = std::getenv("GONIO_STATE_DIR"); e && *e) return e;
  return "/var/lib/gonio";
}

Client& Session::client() {
  if (client_) return *client_;
  const auto timeout = std::chrono::milliseconds(static_cast<long long>(o_.timeout_s * 1000));
  const auto uri = o_.connect.empty() ? "unix:" + o_.state_dir + "/goniod.sock" : o_.connect;
  client_.emplace(uri, timeout);
  if (!uri.starts_with("unix:")) {
    std::string token = o_.token;
    if (token.empty()) {
      const auto file = o_.token_file.empty() ? o_.state_dir + "/admin.token" : o_.token_file;
      std::ifstream in(file);
      if (in) std::getline(in, token);
    }
    if (token.empty())
      throw RpcError(rpc::code::unauthorized, "a token is needed over TCP: --token, --token-file or a "
                                       "readable <state-dir>/admin.token",
                     json::object());
    client_->login(token);
  }
  return *client_;
}

void print_fields(const json& obj, const std::string& prefix) {
  if (!obj.is_object()) {
    std::cout << cell(obj) << "\n";
    return;
  }
  for (const auto& [k, v] : obj.items()) {
    const auto key = prefix.empty() ? k : prefix + "." + k;
    if (v.is_object() && !v.empty()) print_fields(v, key);
    else if (v.is_array() && v.size() > 8) std::cout << key << ": [" << v.size() << " items]\n";
    else std::cout << key << ": " << cell(v) << "\n";
  }
}

void print(const Options& o, const json& result, const std::function<void()>& human) {
  if (o.json) std::cout << result.dump(2) << "\n";
  else human();
}

}  // namespace ctl

namespace {

using ctl::Options;
using ctl::Session;
using nlohmann::json;

json parse_json_arg(const std::string& text, const std::string& what) {
  json j = json::parse(text, nullptr, false);
  if (j.is_discarded()) throw Error::invalid(what, fmt::format("'{}' is not JSON", text));
  return j;
}

void scans_table(const json& list) {
  Table t({"id", "state", "sample", "points", "diverged", "priority", "submitted", "reason"});
  for (const auto& s : list)
    t.add({cell(s["id"]), cell(s["state"]), cell(s["plan"]["sample"]),
           fmt::format("{}/{}", cell(s["points_done"]), cell(s["points_total"])),
           cell(s["points_diverged"]), cell(s["plan"]["priority"]), cell(s["submitted_at"]),
           cell(s["reason"])});
  std::cout << t.render();
}

void alerts_table(const json& list) {
  Table t({"id", "severity", "kind", "scan", "count", "ack", "last", "message"});
  for (const auto& a : list)
    t.add({cell(a["id"]), cell(a["severity"]), cell(a["kind"]), cell(a["scan_id"]), cell(a["count"]),
           a["acknowledged"].get<bool>() ? cell(a["acknowledged_by"]) : "-", cell(a["last_at"]),
           cell(a["message"])});
  std::cout << t.render();
}

void points_table(const json& points) {
  Table t({"index", "θi", "θr", "λ(nm)", "measured", "±u", "predicted", "±se", "max|z|", "ΔE00", "flags"});
  for (const auto& p : points) {
    const auto& m = p["measured"];
    const auto& wl = m["wavelengths_nm"];
    // The channel nearest 550 nm stands for the spectrum in a table.
    std::size_t c = 0;
    for (std::size_t i = 0; i < wl.size(); ++i)
      if (std::abs(wl[i].get<double>() - 550) < std::abs(wl[c].get<double>() - 550)) c = i;
    const auto& pr = p["predicted"];
    std::string flags;
    if (p["diverged"].get<bool>()) flags = "DIVERGED";
    for (const auto& f : p["flags"]) {
      const auto s = f.get<std::string>();
      if (s == "reference_read") continue;
      flags += (flags.empty() ? "" : ",") + s;
    }
    t.add({cell(p["index"]), cell(p["planned"]["theta_i"]), cell(p["planned"]["theta_r"]), cell(wl[c]),
           cell(m["values"][c]), cell(m["std_uncertainty"][c]),
           pr.is_null() ? "-" : cell(pr["values"][c]), pr.is_null() ? "-" : cell(pr["std_uncertainty"][c]),
           p["z_max"].is_null() ? "-" : fmt::format("{:.2f}", p["z_max"].get<double>()),
           p["delta_e00"].is_null() ? "-" : fmt::format("{:.2f}", p["delta_e00"].get<double>()), flags});
  }
  std::cout << t.render();
}

void scan_human(const json& s) {
  std::cout << fmt::format("scan {}: {}{}\n", cell(s["id"]), cell(s["state"]),
                           s["reason"].get<std::string>().empty() ? "" : " (" + cell(s["reason"]) + ")");
  std::cout << fmt::format("  sample {}  points {}/{}  diverged {}  priority {}\n", cell(s["plan"]["sample"]),
                           cell(s["points_done"]), cell(s["points_total"]), cell(s["points_diverged"]),
                           cell(s["plan"]["priority"]));
  std::cout << fmt::format("  wavelengths {}  repeats {}  reference {}\n", cell(s["plan"]["wavelengths"]),
                           cell(s["plan"]["repeats"]), cell(s["plan"]["reference"]["mode"]));
  std::cout << fmt::format("  submitted {} by {}  started {}  finished {}\n", cell(s["submitted_at"]),
                           cell(s["submitted_by"]), cell(s["started_at"]), cell(s["finished_at"]));
  if (!s["predicted"].get<bool>()) std::cout << "  no predictions: the sample has no reference BSDF\n";
  if (s.contains("note")) std::cout << "  " << cell(s["note"]) << "\n";
}

}  // namespace

int gonioctl_main(int argc, char** argv) {
  CLI::App app{"gonioctl — control goniod over JSON-RPC"};
  app.require_subcommand(1);
  Options o;
  o.state_dir = ctl::default_state_dir();
  app.add_option("--state-dir", o.state_dir, "goniod's state dir (socket and admin.token); "
                                             "default $GONIO_STATE_DIR or /var/lib/gonio");
  app.add_option("--connect", o.connect, "unix:PATH or tcp://HOST:PORT (default: the state dir's socket)");
  app.add_option("--token", o.token, "bearer token (TCP)");
  app.add_option("--token-file", o.token_file, "file holding the bearer token (TCP)");
  app.add_flag("--json", o.json, "print JSON results");
  app.add_option("--timeout", o.timeout_s, "seconds to wait for an answer")->check(CLI::Range(0.1, 86400.0));
  app.set_version_flag("--version", "gonioctl " GONIO_VERSION);

  std::function<int(Session&)> action;  // connects on first use, so local commands never do

  // ---- generic
  auto* info = app.add_subcommand("info", "daemon information (system.info)");
  info->callback([&] {
    action = [](Session& s) {
      const auto r = s.call("system.info");
      ctl::print(s.options(), r, [&] { ctl::print_fields(r); });
      return 0;
    };
  });
  auto* discover = app.add_subcommand("discover", "the OpenRPC document (rpc.discover)");
  discover->callback([&] {
    action = [](Session& s) {
      std::cout << s.call("rpc.discover").dump(2) << "\n";
      return 0;
    };
  });
  std::string call_method, call_params = "{}";
  auto* call = app.add_subcommand("call", "call any method: gonioctl call METHOD '{\"k\": v}'");
  call->add_option("method", call_method)->required();
  call->add_option("params", call_params, "params as a JSON object");
  call->callback([&] {
    action = [&](Session& s) {
      std::cout << s.call(call_method, parse_json_arg(call_params, "params")).dump(2) << "\n";
      return 0;
    };
  });

  // ---- instrument
  auto* inst = app.add_subcommand("instrument", "instrument status and manual control");
  inst->require_subcommand(1);
  inst->add_subcommand("status", "arm positions, state, drivers")->callback([&] {
    action = [](Session& s) {
      const auto r = s.call("instrument.status");
      ctl::print(s.options(), r, [&] { ctl::print_fields(r); });
      return 0;
    };
  });
  std::vector<std::string> home_axes;
  auto* home = inst->add_subcommand("home", "home axes (all when none named)");
  home->add_option("axes", home_axes, "incidence, receive, rotation, tilt");
  home->callback([&] {
    action = [&](Session& s) {
      json p = json::object();
      if (!home_axes.empty()) p["axes"] = home_axes;
      const auto r = s.call("instrument.home", p);
      ctl::print(s.options(), r, [&] { ctl::print_fields(r["positions"], "position"); });
      return 0;
    };
  });
  std::map<std::string, double> move_targets;
  auto* mv = inst->add_subcommand("move", "move arms: --incidence 45 --receive 30");
  for (const char* axis : {"incidence", "receive", "rotation", "tilt"})
    mv->add_option_function<double>(std::string("--") + axis, [&move_targets, axis](double v) { move_targets[axis] = v; },
                                    std::string(axis) + " angle in degrees");
  mv->callback([&] {
    action = [&](Session& s) {
      json p = json::object();
      for (const auto& [k, v] : move_targets) p[k] = v;
      const auto r = s.call("instrument.move", p);
      ctl::print(s.options(), r, [&] { ctl::print_fields(r["positions"], "position"); });
      return 0;
    };
  });
  inst->add_subcommand("stop", "stop every axis now (pauses the running scan)")->callback([&] {
    action = [](Session& s) {
      const auto r = s.call("instrument.stop");
      ctl::print(s.options(), r, [&] { std::cout << "stopped" << (r["scan"].is_null() ? "" : fmt::format("; scan {} pauses", cell(r["scan"]))) << "\n"; });
      return 0;
    };
  });
  inst->add_subcommand("reset", "clear alarms and the fault latch")->callback([&] {
    action = [](Session& s) {
      const auto r = s.call("instrument.reset");
      ctl::print(s.options(), r, [&] { std::cout << "state: " << cell(r["state"]) << "\n"; });
      return 0;
    };
  });

  // ---- samples
  auto* sample = app.add_subcommand("sample", "the sample catalog");
  sample->require_subcommand(1);
  std::string s_name, s_notes, s_bsdf, s_ref;
  double s_tol = 0.02;
  auto* screate = sample->add_subcommand("create", "add a sample");
  screate->add_option("name", s_name)->required();
  screate->add_option("--bsdf", s_bsdf, "reference BSDF spec for the twin (none: no predictions)");
  screate->add_option("--tolerance", s_tol, "relative tolerance of the divergence test");
  screate->add_option("--notes", s_notes);
  screate->callback([&] {
    action = [&](Session& s) {
      json p{{"name", s_name}, {"notes", s_notes}, {"tolerance", s_tol}};
      p["bsdf"] = s_bsdf.empty() ? json(nullptr) : json(s_bsdf);
      const auto r = s.call("sample.create", p);
      ctl::print(s.options(), r, [&] { ctl::print_fields(r); });
      return 0;
    };
  });
  auto* sget = sample->add_subcommand("get", "one sample by id or name");
  sget->add_option("sample", s_ref)->required();
  sget->callback([&] {
    action = [&](Session& s) {
      const bool id = !s_ref.empty() && s_ref.find_first_not_of("0123456789") == std::string::npos;
      const auto r = s.call("sample.get", json{{"sample", id ? json(std::stoll(s_ref)) : json(s_ref)}});
      ctl::print(s.options(), r, [&] { ctl::print_fields(r); });
      return 0;
    };
  });
  sample->add_subcommand("list", "every sample")->callback([&] {
    action = [](Session& s) {
      const auto r = s.call("sample.list", json{{"limit", 1000}});
      ctl::print(s.options(), r, [&] {
        Table t({"id", "name", "tolerance", "bsdf", "notes"});
        for (const auto& x : r)
          t.add({cell(x["id"]), cell(x["name"]), cell(x["tolerance"]), cell(x["bsdf"]), cell(x["notes"])});
        std::cout << t.render();
      });
      return 0;
    };
  });

  // ---- scans
  auto* scan = app.add_subcommand("scan", "scans: submit, follow, control, export");
  scan->require_subcommand(1);
  std::string sc_sample, sc_name, sc_wl = "400:700:10", sc_ref = "every_point", sc_not_before, sc_state;
  std::vector<std::string> sc_geoms, sc_grids;
  int sc_repeats = 1, sc_ref_interval = 10, sc_priority = 0;
  bool sc_watch = false;
  auto* submit = scan->add_subcommand("submit", "queue a scan");
  submit->add_option("--sample", sc_sample, "sample id or name")->required();
  submit->add_option("--geometry", sc_geoms, "45as15, 45/-30 or astm (repeatable)");
  submit->add_option("--grid", sc_grids, "grid, e.g. 'in=45;out=-80:80:2' (repeatable)");
  submit->add_option("--wavelengths", sc_wl, "e.g. 400:700:10");
  submit->add_option("--repeats", sc_repeats);
  submit->add_option("--reference", sc_ref, "every_point, interval or start");
  submit->add_option("--reference-interval", sc_ref_interval);
  submit->add_option("--priority", sc_priority, "-100..100, higher runs first");
  submit->add_option("--not-before", sc_not_before, "UTC time, e.g. 2025-01-31T18:00:00Z");
  submit->add_option("--name", sc_name);
  submit->add_flag("--watch", sc_watch, "follow the scan until it ends");
  submit->callback([&] {
    action = [&](Session& s) {
      const bool id = !sc_sample.empty() && sc_sample.find_first_not_of("0123456789") == std::string::npos;
      json p{{"sample", id ? json(std::stoll(sc_sample)) : json(sc_sample)},
             {"wavelengths", sc_wl},
             {"repeats", sc_repeats},
             {"reference", {{"mode", sc_ref}, {"interval", sc_ref_interval}}},
             {"priority", sc_priority},
             {"name", sc_name}};
      if (!sc_geoms.empty()) p["geometries"] = sc_geoms;
      if (!sc_grids.empty()) p["grids"] = sc_grids;
      if (!sc_not_before.empty()) p["not_before"] = sc_not_before;
      const auto r = s.call("scan.submit", p);
      ctl::print(s.options(), r, [&] { scan_human(r); });
      if (sc_watch) return ctl::watch_scan(s, r["id"].get<std::int64_t>(), s.options().json);
      return 0;
    };
  });
  std::int64_t sc_id = 0;
  auto id_cmd = [&](const char* name, const char* help) {
    auto* c = scan->add_subcommand(name, help);
    c->add_option("scan", sc_id, "scan id")->required();
    return c;
  };
  id_cmd("get", "one scan")->callback([&] {
    action = [&](Session& s) {
      const auto r = s.call("scan.get", json{{"scan", sc_id}});
      ctl::print(s.options(), r, [&] { scan_human(r); });
      return 0;
    };
  });
  auto* slist = scan->add_subcommand("list", "recent scans");
  slist->add_option("--state", sc_state);
  slist->add_option("--sample", sc_sample);
  slist->callback([&] {
    action = [&](Session& s) {
      json p{{"limit", 100}};
      if (!sc_state.empty()) p["state"] = sc_state;
      if (!sc_sample.empty()) {
        const bool id = sc_sample.find_first_not_of("0123456789") == std::string::npos;
        p["sample"] = id ? json(std::stoll(sc_sample)) : json(sc_sample);
      }
      const auto r = s.call("scan.list", p);
      ctl::print(s.options(), r, [&] { scans_table(r); });
      return 0;
    };
  });
  std::string sc_reason;
  for (const char* verb : {"pause", "resume", "cancel"}) {
    auto* c = id_cmd(verb, fmt::format("{} a scan", verb).c_str());
    if (std::string(verb) != "resume") c->add_option("--reason", sc_reason);
    c->callback([&, verb] {
      action = [&, verb](Session& s) {
        json p{{"scan", sc_id}};
        if (!sc_reason.empty()) p["reason"] = sc_reason;
        const auto r = s.call(std::string("scan.") + verb, p);
        ctl::print(s.options(), r, [&] { scan_human(r); });
        return 0;
      };
    });
  }
  std::size_t pt_offset = 0, pt_limit = 100;
  auto* pts = id_cmd("points", "measured and predicted points (paged)");
  pts->add_option("--offset", pt_offset);
  pts->add_option("--limit", pt_limit);
  pts->callback([&] {
    action = [&](Session& s) {
      const auto r = s.call("scan.points", json{{"scan", sc_id}, {"offset", pt_offset}, {"limit", pt_limit}});
      ctl::print(s.options(), r, [&] {
        points_table(r["points"]);
        if (!r["next_offset"].is_null())
          std::cout << fmt::format("(more: --offset {})\n", cell(r["next_offset"]));
      });
      return 0;
    };
  });
  std::string ex_format = "csv", ex_output;
  auto* ex = id_cmd("export", "write the scan as csv, json, bsdf (IS-SA) or ssdd");
  ex->add_option("--format", ex_format)->check(CLI::IsMember({"csv", "json", "bsdf", "ssdd"}));
  ex->add_option("--output,-o", ex_output, "file (default: scan-ID.FORMAT; '-' for stdout)");
  ex->callback([&] {
    action = [&](Session& s) {
      const auto r = s.call("scan.export", json{{"scan", sc_id}, {"format", ex_format}});
      const auto path = ex_output.empty() ? r["filename"].get<std::string>() : ex_output;
      if (path == "-") {
        std::cout << r["content"].get<std::string>();
        return 0;
      }
      std::ofstream out(path, std::ios::binary | std::ios::trunc);
      out << r["content"].get<std::string>();
      if (!out) throw Error(Errc::io_error, fmt::format("cannot write {}", path));
      if (s.options().json)
        std::cout << json{{"file", path}, {"format", r["format"]}, {"points", r["points"]}}.dump(2) << "\n";
      else
        std::cout << fmt::format("wrote {} ({} points, {})\n", path, cell(r["points"]), cell(r["format"]));
      return 0;
    };
  });
  id_cmd("watch", "follow a scan live until it ends")->callback([&] {
    action = [&](Session& s) { return ctl::watch_scan(s, sc_id, s.options().json); };
  });

  // ---- queue
  auto* queue = app.add_subcommand("queue", "the scan queue");
  queue->require_subcommand(1);
  queue->add_subcommand("status", "running and waiting scans")->callback([&] {
    action = [](Session& s) {
      const auto r = s.call("queue.status");
      ctl::print(s.options(), r, [&] {
        std::cout << "instrument: " << cell(r["instrument"]) << "\n";
        std::cout << "running: " << (r["running"].is_null() ? "-" : cell(r["running"]["id"])) << "\n";
        json all = json::array();
        if (!r["running"].is_null()) all.push_back(r["running"]);
        for (const auto& w : r["waiting"]) all.push_back(w);
        scans_table(all);
      });
      return 0;
    };
  });
  std::size_t q_pos = 0;
  auto* reorder = queue->add_subcommand("reorder", "move a waiting scan to a position (0 = next)");
  reorder->add_option("scan", sc_id)->required();
  reorder->add_option("position", q_pos)->required();
  reorder->callback([&] {
    action = [&](Session& s) {
      const auto r = s.call("queue.reorder", json{{"scan", sc_id}, {"position", q_pos}});
      ctl::print(s.options(), r, [&] { scans_table(r["waiting"]); });
      return 0;
    };
  });

  // ---- alerts
  auto* alert = app.add_subcommand("alert", "divergence and instrument alerts");
  alert->require_subcommand(1);
  bool al_all = false;
  std::int64_t al_scan = 0, al_id = 0;
  auto* alist = alert->add_subcommand("list", "open alerts (--all: also acknowledged ones)");
  alist->add_flag("--all", al_all);
  alist->add_option("--scan", al_scan);
  alist->callback([&] {
    action = [&](Session& s) {
      json p{{"limit", 1000}};
      if (!al_all) p["acknowledged"] = false;
      if (al_scan) p["scan"] = al_scan;
      const auto r = s.call("alert.list", p);
      ctl::print(s.options(), r, [&] { alerts_table(r); });
      return 0;
    };
  });
  auto* ack = alert->add_subcommand("ack", "acknowledge an alert");
  ack->add_option("alert", al_id)->required();
  ack->callback([&] {
    action = [&](Session& s) {
      const auto r = s.call("alert.ack", json{{"alert", al_id}});
      ctl::print(s.options(), r, [&] { alerts_table(json::array({r})); });
      return 0;
    };
  });

  // ---- twin
  auto* tw = app.add_subcommand("twin", "the twin without hardware");
  tw->require_subcommand(1);
  std::string tw_bsdf, tw_sample, tw_wl = "400:700:10";
  std::vector<std::string> tw_geoms, tw_grids;
  auto* predict = tw->add_subcommand("predict", "β(λ) the instrument would report");
  predict->add_option("--bsdf", tw_bsdf);
  predict->add_option("--sample", tw_sample);
  predict->add_option("--geometry", tw_geoms);
  predict->add_option("--grid", tw_grids);
  predict->add_option("--wavelengths", tw_wl);
  predict->callback([&] {
    action = [&](Session& s) {
      json p{{"wavelengths", tw_wl}};
      if (!tw_bsdf.empty()) p["bsdf"] = tw_bsdf;
      if (!tw_sample.empty()) p["sample"] = tw_sample;
      if (!tw_geoms.empty()) p["geometries"] = tw_geoms;
      if (!tw_grids.empty()) p["grids"] = tw_grids;
      const auto r = s.call("twin.predict", p);
      ctl::print(s.options(), r, [&] {
        Table t({"θi", "θr", "β(first λ)", "β(last λ)", "±se max", "converged"});
        for (const auto& x : r["predictions"]) {
          double se = 0;
          for (const auto& v : x["std_error"]) se = std::max(se, v.get<double>());
          t.add({cell(x["geometry"]["theta_i"]), cell(x["geometry"]["theta_r"]),
                 cell(x["radiance_factor"].front()), cell(x["radiance_factor"].back()), cell(json(se)),
                 cell(x["converged"])});
        }
        std::cout << t.render();
      });
      return 0;
    };
  });

  // ---- tokens
  auto* token = app.add_subcommand("token", "bearer tokens");
  token->require_subcommand(1);
  std::string tk_text, tk_name, tk_role;
  auto* hash = token->add_subcommand("hash", "SHA-256 of a token, for [[auth.token]] in the config");
  hash->add_option("token", tk_text)->required();
  hash->callback([&] {
    action = [&](Session&) {
      std::cout << sha256_hex(tk_text) << "\n";
      return 0;
    };
  });
  auto* tcreate = token->add_subcommand("create", "create a token (admin); prints it once");
  tcreate->add_option("name", tk_name)->required();
  tcreate->add_option("role", tk_role)->required()->check(CLI::IsMember({"viewer", "technician", "admin"}));
  tcreate->callback([&] {
    action = [&](Session& s) {
      const auto r = s.call("auth.create_token", json{{"name", tk_name}, {"role", tk_role}});
      ctl::print(s.options(), r, [&] { std::cout << r["token"].get<std::string>() << "\n"; });
      return 0;
    };
  });
  token->add_subcommand("list", "token names and roles (admin)")->callback([&] {
    action = [](Session& s) {
      const auto r = s.call("auth.list_tokens");
      ctl::print(s.options(), r, [&] {
        Table t({"name", "role"});
        for (const auto& x : r) t.add({cell(x["name"]), cell(x["role"])});
        std::cout << t.render();
      });
      return 0;
    };
  });
  auto* trevoke = token->add_subcommand("revoke", "revoke a stored token (admin)");
  trevoke->add_option("name", tk_name)->required();
  trevoke->callback([&] {
    action = [&](Session& s) {
      const auto r = s.call("auth.revoke_token", json{{"name", tk_name}});
      ctl::print(s.options(), r, [&] { std::cout << "revoked " << tk_name << "\n"; });
      return 0;
    };
  });

  // ---- demo
  ctl::DemoOptions demo;
  auto* dm = app.add_subcommand("demo", "start goniod --mock in a fresh state dir, measure a glossy sample, "
                                        "compare with the twin, plot, stop");
  dm->add_option("--demo-dir", demo.state_dir, "state dir for the demo's goniod (default: a new temporary one)");
  dm->add_option("--goniod", demo.goniod, "goniod executable (default: next to gonioctl)");
  dm->add_option("--output,-o", demo.output, "PNG plot (default: <demo-dir>/demo.png)");
  dm->add_option("--time-scale", demo.time_scale, "real seconds per virtual second of the mock's motion")
      ->check(CLI::Range(0.0, 10.0));
  dm->add_flag("--keep-serving", demo.keep_serving, "leave goniod running afterwards");
  dm->callback([&] {
    action = [&](Session& s) { return ctl::run_demo(demo, s.options()); };
  });

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : ctl_exit::usage;
  }
  Session session(o);
  try {
    return action ? action(session) : ctl_exit::usage;
  } catch (const RpcError& e) {
    std::cerr << "gonioctl: " << e.what();
    if (e.data().contains("field")) std::cerr << " [field " << e.data()["field"].get<std::string>() << "]";
    std::cerr << " (" << e.code() << ")\n";
    return exit_code_for_rpc(e.code());
  } catch (const ConnectionError& e) {
    std::cerr << "gonioctl: " << e.what() << "\n";
    return ctl_exit::connection;
  } catch (const Error& e) {
    std::cerr << "gonioctl: " << e.what() << "\n";
    return e.code() == Errc::io_error ? ctl_exit::server : ctl_exit::usage;
  } catch (const std::exception& e) {
    std::cerr << "gonioctl: internal error: " << e.what() << "\n";
    return ctl_exit::internal;
  }
}

}  // namespace gonio::daemon
