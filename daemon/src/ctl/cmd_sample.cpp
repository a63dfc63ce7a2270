// gonioctl sample: the sample catalog (create, get, list, export).
#include <iostream>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>

#include "ctl/ctl_internal.hpp"
#include "gonio/daemon/ctl/ctl.hpp"

namespace gonio::daemon::ctl {

using nlohmann::json;

namespace {

struct SampleArgs {
  std::string name, notes, bsdf, ref, model, file, format = "json";
  double tolerance = 0.02, model_u = 0;
  std::int64_t reference_scan = 0;
};

}  // namespace

json sample_ref(const std::string& text) {
  const bool id = !text.empty() && text.find_first_not_of("0123456789") == std::string::npos;
  return id ? json(std::stoll(text)) : json(text);
}

std::map<std::int64_t, std::string> sample_names(Session& s) {
  std::map<std::int64_t, std::string> names;
  for (std::size_t offset = 0;; offset += 1000) {
    const auto page = s.call("sample.list", json{{"offset", offset}, {"limit", 1000}});
    for (const auto& x : page) names[x["id"].get<std::int64_t>()] = x.value("name", std::string());
    if (page.size() < 1000) return names;
  }
}

void add_sample_commands(CLI::App& app, Context& ctx) {
  auto args = std::make_shared<SampleArgs>();
  auto* sample = app.add_subcommand("sample", "the sample catalog");
  sample->require_subcommand(1);
  auto* screate = sample->add_subcommand("create", "add a sample");
  screate->add_option("name", args->name)->required();
  screate->add_option("--bsdf", args->bsdf, "reference BSDF spec for the twin (none: no predictions)");
  screate->add_option("--tolerance", args->tolerance, "relative tolerance of the divergence test");
  screate->add_option("--notes", args->notes);
  screate->add_option("--model-u", args->model_u, "the BSDF spec's stated relative u (0..0.5)");
  auto* rscan = screate->add_option("--reference-scan", args->reference_scan,
                                    "make the catalogue from this completed scan (a master)");
  screate->add_option("--model", args->model, "fit this spec ('?' marks) to the master scan")->needs(rscan);
  screate->add_option("--reference-file", args->file,
                      "a master exported by `sample export` (.json) or a BSDF table, in the data directory")
      ->excludes(rscan);
  screate->callback([&ctx, args] {
    ctx.action = [args](Session& s) {
      json p{{"name", args->name}, {"notes", args->notes}, {"tolerance", args->tolerance}};
      if (args->reference_scan || !args->file.empty()) {
        json ref = args->file.empty() ? json{{"scan", args->reference_scan}} : json{{"file", args->file}};
        if (!args->model.empty()) ref["model"] = args->model;
        p["reference"] = std::move(ref);
      } else {
        p["bsdf"] = args->bsdf.empty() ? json(nullptr) : json(args->bsdf);
      }
      if (args->model_u != 0) p["model_u"] = args->model_u;
      const auto r = s.call("sample.create", p);
      print(s.options(), r, [&] { print_fields(r); });
      return 0;
    };
  });
  auto* sget = sample->add_subcommand("get", "one sample by id or name");
  sget->add_option("sample", args->ref)->required();
  sget->callback([&ctx, args] {
    ctx.action = [args](Session& s) {
      const auto r = s.call("sample.get", json{{"sample", sample_ref(args->ref)}});
      print(s.options(), r, [&] { print_fields(r); });
      return 0;
    };
  });
  auto* sexport = sample->add_subcommand("export", "a sample's master, for another instrument (to stdout)");
  sexport->add_option("sample", args->ref)->required();
  sexport->add_option("--format", args->format, "json (the master, read back by --reference-file) or bsdf (IS-SA)")
      ->check(CLI::IsMember({"json", "bsdf"}));
  sexport->callback([&ctx, args] {
    ctx.action = [args](Session& s) {
      const auto r = s.call("sample.export", json{{"sample", sample_ref(args->ref)}, {"format", args->format}});
      if (s.options().json) std::cout << r.dump() << '\n';
      else std::cout << r.at("content").get<std::string>();
      return 0;
    };
  });
  sample->add_subcommand("list", "every sample")->callback([&ctx] {
    ctx.action = [](Session& s) {
      const auto r = s.call("sample.list", json{{"limit", 1000}});
      print(s.options(), r, [&] {
        Table t({"id", "name", "tolerance", "route", "bsdf", "notes"});
        for (const auto& x : r)
          t.add({cell(x["id"]), cell(x["name"]), cell(x["tolerance"]), cell(x.value("route", json("formula"))),
                 cell(x["bsdf"]), cell(x["notes"])});
        std::cout << t.render();
      });
      return 0;
    };
  });
}

}  // namespace gonio::daemon::ctl
