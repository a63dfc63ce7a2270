// The twin.* methods: β(λ) predicted by the digital twin alone.
#include <optional>
#include <string>

#include <fmt/format.h>

#include "methods/params.hpp"
#include "methods/registrar.hpp"

namespace gonio::daemon {

using json_util::ObjectReader;
using nlohmann::json;

namespace {

// The most geometries one twin.predict call predicts.
constexpr std::size_t kMaxPredict = 1000;

}  // namespace

void register_twin(MethodRegistrar& reg, Services& s) {
  reg.add("twin.predict", [&s](rpc::Call& c) {
    ObjectReader r(c.params, "");
    const auto* bsdf = r.raw("bsdf");
    const auto* sample = r.raw("sample");
    json plan_json{{"sample", 1}};
    for (const char* key : {"geometries", "grids", "wavelengths"})
      if (const auto* v = r.raw(key)) plan_json[key] = *v;
    std::optional<double> rel_se;
    if (r.has("rel_se")) {
      rel_se = r.required<double>("rel_se");
      if (!(*rel_se >= 1e-4 && *rel_se <= 0.5)) throw Error::out_of_range("rel_se", *rel_se, 1e-4, 0.5);
    }
    r.finish();
    if ((bsdf == nullptr) == (sample == nullptr))
      throw Error::invalid("bsdf", "give exactly one of 'bsdf' (a spec string) and 'sample'");
    std::string spec;
    if (bsdf) spec = methods::confine_bsdf_files(json_util::get_as<std::string>(*bsdf, "bsdf"), s.data_dir, "bsdf");
    else {
      const auto x = methods::resolve_sample(s.store, *sample, "sample");
      if (!x.spec.bsdf)
        throw Error::wrong_state("sample", fmt::format("'{}' has no reference BSDF to predict with",
                                                       x.spec.name));
      spec = *x.spec.bsdf;
    }
    const auto plan = plan_json.get<ScanPlan>();
    if (plan.geometries.size() > kMaxPredict)
      throw Error(Errc::out_of_range,
                  fmt::format("geometries: {} geometries, more than one call predicts ({})",
                              plan.geometries.size(), kMaxPredict),
                  "geometries");
    const auto tw = s.twin.make(spec, plan.wavelengths, bsdf ? "bsdf" : "sample.bsdf");
    auto options = s.twin.options();
    if (rel_se) options.rel_se = *rel_se;
    const auto preds = s.twin.predict(*tw, plan.geometries, options);
    json out = json::array();
    for (const auto& p : preds)
      out.push_back(json{{"geometry", p.geometry},
                         {"wavelengths_nm", p.wavelengths.values()},
                         {"radiance_factor", p.beta},
                         {"std_error", p.std_error},
                         {"samples", p.samples},
                         {"seconds", p.seconds},
                         {"converged", p.diagnostics.converged},
                         {"seen_fraction", p.diagnostics.seen_fraction}});
    return json{{"twin_version", s.twin.version()}, {"bsdf", spec}, {"predictions", std::move(out)}};
  });
}

}  // namespace gonio::daemon
