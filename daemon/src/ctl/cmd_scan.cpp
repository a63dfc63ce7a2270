// gonioctl scan: submit, get, list, pause, resume, cancel, points, export, fit, material, watch.
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "ctl/ctl_internal.hpp"
#include "gonio/daemon/ctl/ctl.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/proto/text.hpp"

namespace gonio::daemon::ctl {

using nlohmann::json;

namespace {

// A value and its u as two table cells, rounded as GUM §7.2.6 asks (text::format_measured);
// numbers too small or large for fixed decimals keep 4 significant digits.
std::pair<std::string, std::string> measured_cells(const json& value, const json& u) {
  if (!value.is_number() || !u.is_number()) return {cell(value), cell(u)};
  const auto text = text::format_measured(value.get<double>(), u.get<double>());
  const auto pm = text.find(" ± ");
  if (pm == std::string::npos || text.front() == '(') return {cell(value), cell(u)};
  return {text.substr(0, pm), text.substr(pm + std::string(" ± ").size())};
}

// The channel at `nm` (within half a nanometre); an error naming the scan's grid otherwise.
std::size_t channel_at(const json& wl, double nm) {
  std::size_t c = 0;
  for (std::size_t i = 0; i < wl.size(); ++i)
    if (std::abs(wl[i].get<double>() - nm) < std::abs(wl[c].get<double>() - nm)) c = i;
  if (wl.empty() || std::abs(wl[c].get<double>() - nm) > 0.5)
    throw Error::invalid("--wavelength", fmt::format("no channel at {:g} nm; the scan measured {} nm", nm,
                                                     text::format_value_list(wl.get<std::vector<double>>())));
  return c;
}

// One channel stands for the spectrum in a table: `nm` (550 nm by default, else the nearest).
void points_table(const json& points, std::optional<double> nm) {
  Table t({"index", "θi", "θr", "λ(nm)", "measured", "±u", "predicted", "±se", "max|z|", "ΔE00", "flags"});
  for (const auto& p : points) {
    const auto& m = p["measured"];
    const auto& wl = m["wavelengths_nm"];
    std::size_t c = 0;
    if (nm) {
      c = channel_at(wl, *nm);
    } else {
      for (std::size_t i = 0; i < wl.size(); ++i)
        if (std::abs(wl[i].get<double>() - 550) < std::abs(wl[c].get<double>() - 550)) c = i;
    }
    const auto& pr = p["predicted"];
    std::string flags;
    if (p["diverged"].get<bool>()) flags = "DIVERGED";
    for (const auto& f : p["flags"]) {
      const auto s = f.get<std::string>();
      if (s == "reference_read") continue;
      flags += (flags.empty() ? "" : ",") + s;
    }
    const auto [mv, mu] = measured_cells(m["values"][c], m["std_uncertainty"][c]);
    const auto [pv, pu] = pr.is_null() ? std::pair<std::string, std::string>{"-", "-"}
                                       : measured_cells(pr["values"][c], pr["std_uncertainty"][c]);
    t.add({cell(p["index"]), cell(p["planned"]["theta_i"]), cell(p["planned"]["theta_r"]), cell(wl[c]), mv, mu, pv, pu,
           p["z_max"].is_null() ? "-" : fmt::format("{:.2f}", p["z_max"].get<double>()),
           p["delta_e00"].is_null() ? "-" : fmt::format("{:.2f}", p["delta_e00"].get<double>()), flags});
  }
  std::cout << t.render();
}

// A scan for people: its sample by name (when known), the wavelength grid as 400:700:10,
// and with `alerts` (scan get) the verdict and the scan's alerts.
void scan_human(const json& s, const std::string& sample_name = {}, const ScanAlerts* alerts = nullptr) {
  std::cout << fmt::format("scan {}: {}{}\n", cell(s["id"]), cell(s["state"]),
                           s["reason"].get<std::string>().empty() ? "" : " (" + cell(s["reason"]) + ")");
  const auto sample = sample_name.empty() ? cell(s["plan"]["sample"])
                                          : fmt::format("{} ({})", sample_name, cell(s["plan"]["sample"]));
  std::cout << fmt::format("  sample {}  points {}/{}  diverged {}  priority {}\n", sample,
                           cell(s["points_done"]), cell(s["points_total"]), cell(s["points_diverged"]),
                           cell(s["plan"]["priority"]));
  const auto& wl = s["plan"]["wavelengths"];
  std::cout << fmt::format("  wavelengths {} nm  repeats {}  reference {}\n",
                           wl.is_array() ? text::format_value_list(wl.get<std::vector<double>>()) : cell(wl),
                           cell(s["plan"]["repeats"]), cell(s["plan"]["reference"]["mode"]));
  std::cout << fmt::format("  submitted {} by {}  started {}  finished {}\n", cell(s["submitted_at"]),
                           cell(s["submitted_by"]), cell(s["started_at"]), cell(s["finished_at"]));
  if (!s["predicted"].get<bool>()) std::cout << "  no predictions: the sample has no reference BSDF\n";
  if (s.contains("adaptive") && s["adaptive"].is_object()) {
    const auto& a = s["adaptive"];
    std::cout << fmt::format("  adaptive {}: {}, {} points used", cell(a["mode"]), cell(a["state"]),
                             cell(a["points_used"]));
    if (a.contains("estimated_error") && !a["estimated_error"].is_null())
      std::cout << fmt::format(", estimated error {:.2f} %", 100 * a["estimated_error"].get<double>());
    std::cout << "\n";
    for (const auto& p : a.value("parameters", json::array())) {
      const double v = p["value"].get<double>(), u = p["u"].get<double>();
      std::cout << fmt::format("    {} = {} ({:.2g} %)\n", cell(p["name"]), text::format_measured(v, u),
                               100 * u / std::max(std::abs(v), 1e-300));
    }
    for (const auto& w : a.value("warnings", json::array())) std::cout << "    warning: " << cell(w) << "\n";
  }
  if (s.contains("note")) std::cout << "  " << cell(s["note"]) << "\n";
  if (alerts) {
    // Indented under the scan, like its other lines.
    std::string text = verdict_text(s.value("verdict", json())) + alerts_text(*alerts, s["id"].get<std::int64_t>());
    for (std::size_t at = 0; at < text.size(); at = text.find('\n', at) + 1) text.insert(at, "  ");
    std::cout << text;
  }
}

std::string sample_name_of(Session& session, const json& scan) {
  try {
    return session.call("sample.get", json{{"sample", scan["plan"]["sample"]}}).value("name", std::string());
  } catch (const RpcError&) {
    return {};  // a sample since deleted: its id alone
  }
}

struct ScanArgs {
  std::string sample, name, wavelengths = "400:700:10", reference = "every_point", not_before, state;
  std::vector<std::string> geometries, grids;
  int repeats = 1, reference_interval = 10, priority = 0;
  bool watch = false, exit_status = false;
  std::optional<double> wavelength;  // scan points
  std::int64_t id = 0;
  std::string reason;
  std::string since, until, text;  // scan list
  std::size_t offset = 0, limit = 100;
  std::string format = "csv", output;
  std::string model;
  std::uint64_t samples = 0;
  std::int64_t fit = 0;  // scan material: 0 for the newest fit
  std::string adaptive;  // scan submit: "parameters" or "curve"
  double target_rel_u = 0.05, tolerance = 0.01;
  int max_points = 50;
};

// gonioctl scan material ID --format mitsuba|gltf [--fit N] [-o FILE]: scan.material's file
// written out, with the glTF approximation's ΔE00 and the notes (twin/material.md).
void add_material_command(CLI::App* scan, Context& ctx, const std::shared_ptr<ScanArgs>& a) {
  auto* c = scan->add_subcommand("material", "write a stored fit's material for a renderer: Mitsuba 3 XML or glTF 2.0");
  c->add_option("scan", a->id, "scan id")->required();
  c->add_option("--format", a->format, "mitsuba or gltf")->check(CLI::IsMember({"mitsuba", "gltf"}))->required();
  c->add_option("--fit", a->fit, "the fit's id (default: the newest)");
  c->add_option("--output,-o", a->output, "file (default: scanN-fitM.xml or .gltf)");
  c->callback([&ctx, a] {
    ctx.action = [a](Session& s) {
      json p{{"scan", a->id}, {"format", a->format}};
      if (a->fit > 0) p["fit"] = a->fit;
      const auto r = s.call("scan.material", p);
      const auto path = a->output.empty() ? r["filename"].get<std::string>() : a->output;
      std::ofstream out(path, std::ios::binary | std::ios::trunc);
      out << r["content"].get<std::string>();
      out.close();
      if (!out) throw Error(Errc::io_error, fmt::format("cannot write {}", path));
      json summary = r;
      summary.erase("content");
      summary["file"] = path;
      print(s.options(), summary, [&] {
        std::cout << fmt::format("wrote {} (scan {} fit {}, {})\n", path, cell(r["scan"]), cell(r["fit"]), cell(r["format"]));
        if (r.contains("gltf")) {
          const auto& d = r["gltf"]["delta_e_geometries"];
          std::cout << fmt::format("glTF approximation: ΔE00 over {} geometries: mean {:.2f}, p95 {:.2f}, max {:.2f}\n",
                                   cell(d["samples"]), d["mean"].get<double>(), d["p95"].get<double>(), d["max"].get<double>());
        }
        for (const auto& n : r["notes"]) std::cout << "note: " << n.get<std::string>() << '\n';
      });
      return 0;
    };
  });
}

}  // namespace

void fit_human(const json& f) {
  const auto& r = f["result"];
  std::cout << fmt::format("{} {} of scan {}: {}\n", cell(r["kind"]), cell(f["id"]), cell(f["scan"]),
                           cell(r["status"]));
  Table t({"parameter", "value", "±u", "start", "bounds", "notes"});
  for (const auto& p : r["parameters"]) {
    std::string notes;
    if (p.value("at_bound", false)) notes = "at bound";
    if (!p.value("identifiable", true)) notes += (notes.empty() ? "" : ", ") + std::string("not identifiable");
    const auto [value, u] = p["u"].is_null() ? std::pair<std::string, std::string>{cell(p["value"]), "-"}
                                             : measured_cells(p["value"], p["u"]);
    t.add({cell(p["name"]), value, u, cell(p["start"]),
           fmt::format("[{}, {}]", cell(p["bounds"][0]), cell(p["bounds"][1])), notes});
  }
  std::cout << t.render();
  std::cout << fmt::format("  spec {}\n  chi2/dof {} (dof {})  evaluations {}  {} s\n", cell(r["spec"]),
                           cell(r["chi2_per_dof"]), cell(r["dof"]), cell(r["evaluations"]),
                           cell(r["seconds"]));
  if (r.contains("naive") && r["naive"].is_object() && r["naive"].contains("parameters")) {
    std::string naive;
    for (const auto& p : r["naive"]["parameters"])
      naive += fmt::format("{}{} = {}", naive.empty() ? "" : ", ", cell(p["name"]), cell(p["value"]));
    std::cout << fmt::format("  without the instrument: {} (chi2/dof {})\n", naive,
                             cell(r["naive"]["chi2_per_dof"]));
  }
  for (const auto& w : r["warnings"]) std::cout << "  warning: " << cell(w) << "\n";
}

void scans_table(const json& list, const std::map<std::int64_t, std::string>& names) {
  Table t({"id", "state", "sample", "points", "diverged", "priority", "submitted", "reason"});
  for (const auto& s : list) {
    const auto& id = s["plan"]["sample"];
    const auto it = id.is_number_integer() ? names.find(id.get<std::int64_t>()) : names.end();
    t.add({cell(s["id"]), cell(s["state"]), it == names.end() ? cell(id) : it->second,
           fmt::format("{}/{}", cell(s["points_done"]), cell(s["points_total"])),
           cell(s["points_diverged"]), cell(s["plan"]["priority"]), cell(s["submitted_at"]),
           cell(s["reason"])});
  }
  std::cout << t.render();
}

namespace {

using Args = std::shared_ptr<ScanArgs>;

// A subcommand of `scan` taking the scan id as its one positional argument.
CLI::App* id_command(CLI::App* scan, const Args& a, const std::string& name, const std::string& help) {
  auto* c = scan->add_subcommand(name, help);
  c->add_option("scan", a->id, "scan id")->required();
  return c;
}

void add_submit(CLI::App* scan, Context& ctx, const Args& a) {
  auto* submit = scan->add_subcommand("submit", "queue a scan");
  submit->add_option("--sample", a->sample, "sample id or name")->required();
  submit->add_option("--geometry", a->geometries, "45as15, 45/-30 or astm (repeatable)");
  submit->add_option("--grid", a->grids, "grid, e.g. 'in=45;out=-30:80:2' (repeatable)");
  submit->add_option("--wavelengths", a->wavelengths, "e.g. 400:700:10");
  submit->add_option("--repeats", a->repeats);
  submit->add_option("--reference", a->reference, "every_point, interval or start");
  submit->add_option("--reference-interval", a->reference_interval);
  submit->add_option("--priority", a->priority, "-100..100, higher runs first");
  submit->add_option("--not-before", a->not_before, "UTC time, e.g. 2025-01-31T18:00:00Z");
  submit->add_option("--name", a->name);
  submit->add_option("--adaptive", a->adaptive,
                     "the grids are candidates and the twin chooses among them: parameters or curve")
      ->check(CLI::IsMember({"parameters", "curve"}));
  submit->add_option("--model", a->model, "--adaptive parameters: BSDF spec with '?' marks");
  submit->add_option("--target-rel-u", a->target_rel_u, "--adaptive parameters: stop at this relative u")
      ->capture_default_str();
  auto* curve_error =
      submit->add_option("--curve-error", a->tolerance, "--adaptive curve: stop at this estimated relative error")
          ->capture_default_str();
  // The old name: --tolerance is the sample's acceptance limit (sample create).
  auto* old_name = submit->add_option("--tolerance", a->tolerance)->group("");
  submit->add_option("--max-points", a->max_points, "--adaptive: at most this many points")->capture_default_str();
  auto* watch_flag = submit->add_flag("--watch", a->watch, "follow the scan until it ends, then print its verdict");
  submit->add_flag("--exit-status", a->exit_status,
                   "with --watch: exit 10 when the verdict is out_of_tolerance, 11 when instrument_out_of_spec")
      ->needs(watch_flag);
  submit->callback([&ctx, a, old_name, curve_error] {
    if (old_name->count() > 0 && curve_error->count() > 0)
      throw CLI::ValidationError("--tolerance", "give --curve-error alone (--tolerance is its old name here)");
    if (old_name->count() > 0) std::cerr << "gonioctl: --tolerance is now --curve-error here (--tolerance is a sample's acceptance limit)\n";
    ctx.action = [a](Session& s) {
      json p{{"sample", sample_ref(a->sample)},
             {"wavelengths", a->wavelengths},
             {"repeats", a->repeats},
             {"reference", {{"mode", a->reference}, {"interval", a->reference_interval}}},
             {"priority", a->priority},
             {"name", a->name}};
      if (!a->geometries.empty()) p["geometries"] = a->geometries;
      if (!a->grids.empty()) p["grids"] = a->grids;
      if (!a->not_before.empty()) p["not_before"] = a->not_before;
      if (!a->adaptive.empty()) {
        json ad{{"mode", a->adaptive}, {"max_points", a->max_points}};
        if (a->adaptive == "parameters") {
          ad["model"] = a->model;
          ad["target_rel_u"] = a->target_rel_u;
        } else {
          ad["tolerance"] = a->tolerance;
        }
        p["adaptive"] = std::move(ad);
      }
      const auto r = s.call("scan.submit", p);
      print(s.options(), r, [&] { scan_human(r, sample_name_of(s, r)); });
      if (a->watch) return watch_scan(s, r["id"].get<std::int64_t>(), s.options().json, a->exit_status);
      return 0;
    };
  });
}

void add_get(CLI::App* scan, Context& ctx, const Args& a) {
  auto* get = id_command(scan, a, "get", "one scan, its verdict and alerts");
  get->add_flag("--exit-status", a->exit_status,
                "exit 10 when the verdict is out_of_tolerance, 11 when instrument_out_of_spec");
  get->callback([&ctx, a] {
    ctx.action = [a](Session& s) {
      const auto r = s.call("scan.get", json{{"scan", a->id}});
      print(s.options(), r, [&] {
        const auto alerts = scan_alerts(s, a->id);
        scan_human(r, sample_name_of(s, r), &alerts);
      });
      return a->exit_status ? verdict_exit_code(r) : 0;
    };
  });
}

void add_list(CLI::App* scan, Context& ctx, const Args& a) {
  auto* slist = scan->add_subcommand("list", "recent scans");
  slist->add_option("--state", a->state);
  slist->add_option("--sample", a->sample);
  slist->add_option("--since", a->since, "submitted at or after this UTC time (2025-01-31T00:00:00Z)");
  slist->add_option("--until", a->until, "submitted before this UTC time");
  slist->add_option("--text", a->text, "text in the label");
  slist->callback([&ctx, a] {
    ctx.action = [a](Session& s) {
      json p{{"limit", 100}};
      if (!a->state.empty()) p["state"] = a->state;
      if (!a->sample.empty()) p["sample"] = sample_ref(a->sample);
      if (!a->since.empty()) p["since"] = a->since;
      if (!a->until.empty()) p["until"] = a->until;
      if (!a->text.empty()) p["text"] = a->text;
      const auto r = s.call("scan.list", p);
      print(s.options(), r, [&] { scans_table(r, sample_names(s)); });
      return 0;
    };
  });
}

// pause, resume and cancel.
void add_control(CLI::App* scan, Context& ctx, const Args& a) {
  for (const char* verb : {"pause", "resume", "cancel"}) {
    auto* c = id_command(scan, a, verb, fmt::format("{} a scan", verb));
    if (std::string(verb) != "resume") c->add_option("--reason", a->reason);
    c->callback([&ctx, a, verb] {
      ctx.action = [a, verb](Session& s) {
        json p{{"scan", a->id}};
        if (!a->reason.empty()) p["reason"] = a->reason;
        const auto r = s.call(std::string("scan.") + verb, p);
        print(s.options(), r, [&] { scan_human(r); });
        return 0;
      };
    });
  }
}

void add_points(CLI::App* scan, Context& ctx, const Args& a) {
  auto* pts = id_command(scan, a, "points", "measured and predicted points (paged)");
  pts->add_option("--offset", a->offset);
  pts->add_option("--limit", a->limit);
  pts->add_option("--wavelength", a->wavelength, "the channel to show, nm (default: the one nearest 550 nm)");
  pts->callback([&ctx, a] {
    ctx.action = [a](Session& s) {
      const auto r = s.call("scan.points", json{{"scan", a->id}, {"offset", a->offset}, {"limit", a->limit}});
      print(s.options(), r, [&] {
        points_table(r["points"], a->wavelength);
        if (!r["next_offset"].is_null())
          std::cout << fmt::format("(more: --offset {})\n", cell(r["next_offset"]));
      });
      return 0;
    };
  });
}

void add_export(CLI::App* scan, Context& ctx, const Args& a) {
  auto* ex = id_command(scan, a, "export", "write the scan as csv, json, bsdf (IS-SA) or ssdd");
  ex->add_option("--format", a->format)->check(CLI::IsMember({"csv", "json", "bsdf", "ssdd"}));
  ex->add_option("--output,-o", a->output, "file (default: scan-ID.FORMAT; '-' for stdout)");
  ex->callback([&ctx, a] {
    ctx.action = [a](Session& s) {
      // csv and json come in chunks (next_offset until null), written as they arrive.
      json r = s.call("scan.export", json{{"scan", a->id}, {"format", a->format}});
      const auto path = a->output.empty() ? r["filename"].get<std::string>() : a->output;
      std::ofstream file;
      if (path != "-") file.open(path, std::ios::binary | std::ios::trunc);
      std::ostream& out = path == "-" ? std::cout : file;
      std::size_t points = 0;
      for (;;) {
        out << r["content"].get<std::string>();
        points += r["points"].get<std::size_t>();
        if (!r.contains("next_offset") || r["next_offset"].is_null()) break;
        r = s.call("scan.export", json{{"scan", a->id}, {"format", a->format}, {"offset", r["next_offset"]}});
      }
      r["points"] = points;
      if (path == "-") return 0;
      file.close();
      if (!file) throw Error(Errc::io_error, fmt::format("cannot write {}", path));
      const auto bytes = std::filesystem::file_size(path);
      if (s.options().json)
        std::cout << json{{"file", path}, {"format", r["format"]}, {"points", r["points"]}, {"bytes", bytes}}.dump(2) << "\n";
      else
        std::cout << fmt::format("wrote {} ({} points, {}, {} bytes)\n", path, cell(r["points"]), cell(r["format"]),
                                 bytes);
      return 0;
    };
  });
}

void add_fit(CLI::App* scan, Context& ctx, const Args& a) {
  auto* fit = id_command(scan, a, "fit", "fit a BSDF model's free ('?') parameters to the scan through the twin");
  fit->add_option("--model", a->model, "BSDF spec with '?' marks, e.g. 'conductor:alpha=?,eta=0.2,k=3.9'")
      ->required();
  fit->add_option("--samples", a->samples, "twin paths per geometry and evaluation (default 8192)");
  fit->callback([&ctx, a] {
    ctx.action = [a](Session& s) {
      json p{{"scan", a->id}, {"model", a->model}};
      if (a->samples) p["samples"] = a->samples;
      const auto r = s.call("scan.fit", p);
      print(s.options(), r, [&] { fit_human(r); });
      return 0;
    };
  });
}

void add_watch(CLI::App* scan, Context& ctx, const Args& a) {
  auto* watch = id_command(scan, a, "watch", "follow a scan live until it ends, then print its verdict");
  watch->add_flag("--exit-status", a->exit_status,
                  "exit 10 when the verdict is out_of_tolerance, 11 when instrument_out_of_spec");
  watch->callback([&ctx, a] {
    ctx.action = [a](Session& s) { return watch_scan(s, a->id, s.options().json, a->exit_status); };
  });
}

}  // namespace

// The subcommands in the order `gonioctl scan --help` lists them.
void add_scan_commands(CLI::App& app, Context& ctx) {
  auto a = std::make_shared<ScanArgs>();
  auto* scan = app.add_subcommand("scan", "scans: submit, follow, control, export");
  scan->require_subcommand(1);
  add_submit(scan, ctx, a);
  add_get(scan, ctx, a);
  add_list(scan, ctx, a);
  add_control(scan, ctx, a);
  add_points(scan, ctx, a);
  add_export(scan, ctx, a);
  add_fit(scan, ctx, a);
  add_material_command(scan, ctx, a);
  add_watch(scan, ctx, a);
}

}  // namespace gonio::daemon::ctl
