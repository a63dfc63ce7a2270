// mirror — ideal specular reflector with a (spectral) reflectance. It has no density:
// eval/pdf are zero and sample_wi draws nothing; its single path wi = reflect(wo, n)
// with weight = reflectance is listed by delta_lobes() for the estimator to treat exactly.
#include "gonio/twin/detail/bsdf/model.hpp"

namespace gonio::twin::bsdf {
namespace {

class Mirror final : public Lobe {
 public:
  Mirror(const Params& p, const WavelengthGrid& grid)
      : Lobe(grid, p.spec()), reflectance_(p.spectrum("reflectance")) {}

  void eval(const Vec3&, const Vec3&, std::span<double> out) const override {
    for (auto& v : out) v = 0.0;
  }
  std::optional<BsdfSample> sample_wi(const Vec3&, double, Vec2) const override {
    return std::nullopt;
  }
  double pdf(const Vec3&, const Vec3&) const override { return 0.0; }
  void delta_lobes(const Vec3& wo, std::vector<DeltaLobe>& out) const override {
    out.clear();
    if (wo.z == 0) return;
    out.push_back({reflect(wo, Vec3{0, 0, 1}), reflectance_});
  }
  bool has_delta() const noexcept override { return true; }
  // Nothing to sample: a sum never picks this lobe for sample_wi.
  double albedo_hint(const Vec3&) const override { return 0.0; }

 private:
  std::vector<double> reflectance_;
};

BsdfPtr build_mirror(const Params& p, const WavelengthGrid& grid) {
  return std::make_shared<Mirror>(p, grid);
}

}  // namespace

const Registrar kMirrorRegistered{{"mirror", {{"reflectance", true, 0, 1, false, 1.0, ""}}, &build_mirror}};

}  // namespace gonio::twin::bsdf
