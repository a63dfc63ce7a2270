// The sample.* methods: the sample catalog.
#include "methods/params.hpp"
#include "methods/registrar.hpp"

namespace gonio::daemon {

using json_util::ObjectReader;
using nlohmann::json;

void register_sample(MethodRegistrar& reg, Services& s) {
  reg.add("sample.create", [&s](rpc::Call& c) {
    auto spec = c.params.get<SampleSpec>();
    if (spec.bsdf) spec.bsdf = methods::confine_bsdf_files(*spec.bsdf, s.data_dir, "bsdf");
    if (spec.bsdf) (void)s.twin.make(*spec.bsdf, WavelengthGrid::visible(), "bsdf");
    return json(s.store.create_sample(spec, methods::actor(c)));
  });

  reg.add("sample.get", [&s](rpc::Call& c) {
    ObjectReader r(c.params, "");
    const auto* ref = r.raw("sample");
    r.finish();
    if (!ref) throw Error::invalid("sample", "is required (a sample id or name)");
    return json(methods::resolve_sample(s.store, *ref, "sample"));
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
