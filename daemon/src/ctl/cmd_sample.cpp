// gonioctl sample: the sample catalog (create, get, list).
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
  std::string name, notes, bsdf, ref;
  double tolerance = 0.02;
};

}  // namespace

json sample_ref(const std::string& text) {
  const bool id = !text.empty() && text.find_first_not_of("0123456789") == std::string::npos;
  return id ? json(std::stoll(text)) : json(text);
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
  screate->callback([&ctx, args] {
    ctx.action = [args](Session& s) {
      json p{{"name", args->name}, {"notes", args->notes}, {"tolerance", args->tolerance}};
      p["bsdf"] = args->bsdf.empty() ? json(nullptr) : json(args->bsdf);
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
  sample->add_subcommand("list", "every sample")->callback([&ctx] {
    ctx.action = [](Session& s) {
      const auto r = s.call("sample.list", json{{"limit", 1000}});
      print(s.options(), r, [&] {
        Table t({"id", "name", "tolerance", "bsdf", "notes"});
        for (const auto& x : r)
          t.add({cell(x["id"]), cell(x["name"]), cell(x["tolerance"]), cell(x["bsdf"]), cell(x["notes"])});
        std::cout << t.render();
      });
      return 0;
    };
  });
}

}  // namespace gonio::daemon::ctl
