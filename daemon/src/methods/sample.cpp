// The sample.* methods: the sample catalog.
#include <filesystem>
#include <sstream>

#include <fmt/format.h>

#include "gonio/twin/bsdf_io.hpp"

#include "methods/master.hpp"
#include "methods/params.hpp"
#include "methods/registrar.hpp"

namespace gonio::daemon {

using json_util::ObjectReader;
using nlohmann::json;

void register_sample(MethodRegistrar& reg, Services& s) {
  reg.add("sample.create", [&s](rpc::Call& c) {
    json params = c.params;
    json reference;
    if (params.is_object() && params.contains("reference")) {
      reference = params["reference"];
      params.erase("reference");
    }
    auto spec = params.get<SampleSpec>();
    if (reference.is_null()) {
      if (spec.bsdf) spec.bsdf = methods::confine_bsdf_files(*spec.bsdf, s.data_dir, "bsdf");
      if (spec.bsdf) (void)s.twin.make(*spec.bsdf, WavelengthGrid::visible(), "bsdf");
      return json(s.store.create_sample(spec, methods::actor(c)));
    }
    if (spec.bsdf)
      throw Error::invalid("bsdf", "give either a bsdf or a reference: a reference makes the catalogue");
    if (spec.model_u != 0)
      throw Error::invalid("model_u", "a catalogue made from a reference carries its own u");
    bool written = false;
    try {
      auto made = methods::make_catalogue(s, reference, spec.name, written);
      spec.bsdf = made.bsdf;
      (void)s.twin.make(*spec.bsdf, WavelengthGrid::visible(), "reference");
      return json(s.store.create_sample(spec, methods::actor(c), made.catalogue.stored()));
    } catch (...) {
      if (written) {
        std::error_code ec;
        std::filesystem::remove(s.state_dir / "masters" / (spec.name + ".ssdd"), ec);
      }
      throw;
    }
  });

  reg.add("sample.get", [&s](rpc::Call& c) {
    ObjectReader r(c.params, "");
    const auto* ref = r.raw("sample");
    r.finish();
    if (!ref) throw Error::invalid("sample", "is required (a sample id or name)");
    return json(methods::resolve_sample(s.store, *ref, "sample"));
  });

  reg.add("sample.export", [&s](rpc::Call& c) {
    ObjectReader r(c.params, "");
    const auto* ref = r.raw("sample");
    const auto format = r.optional<std::string>("format", "json");
    r.finish();
    if (!ref) throw Error::invalid("sample", "is required (a sample id or name)");
    if (format != "json" && format != "bsdf")
      throw Error::invalid("format", fmt::format("'{}' is not one of json, bsdf", format));
    const auto sample = methods::resolve_sample(s.store, *ref, "sample");
    const auto cat = Catalogue::of(sample);
    const auto doc = methods::master_document(sample, cat);
    if (format == "json") return json{{"format", format}, {"content", doc.dump(1) + "\n"}};
    // IS-SA holds one grey table: the mean of the master's channels.
    std::ostringstream out;
    twin::IssaWriteOptions o;
    o.comment = fmt::format("master of sample '{}'{}, instrument-corrected; the mean of its {} wavelength channels",
                            sample.spec.name,
                            cat.master_scan() ? fmt::format(" (scan {})", *cat.master_scan()) : std::string(),
                            cat.master_data()->channels());
    twin::write_issa(out, cat.master_data()->table(), false, o);
    return json{{"format", format}, {"content", out.str()}};
  });

  reg.add("sample.list", [&s](rpc::Call& c) {
    ObjectReader r(c.params, "");
    const auto offset = methods::read_offset(r);
    const auto limit = methods::read_count(r, "limit", 100, methods::kMaxPage);
    r.finish();
    json out = json::array();
    for (const auto& x : s.store.samples(offset, limit)) out.push_back(x);
    return out;
  });
}

}  // namespace gonio::daemon
