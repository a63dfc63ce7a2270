// Sum of lobes: f = Σ f_k. Sampling picks lobe k with probability p_k(wo) proportional
// to its albedo hint for this wo (a deterministic function of wo), reuses the rest of
// u_lobe inside that lobe, and reports the mixture density Σ p_k(wo) pdf_k(wo, wi), so
// one-sample MIS over the lobes is exact. Delta lobes of all parts are listed together.
// A sum does not enforce energy conservation: the parts' albedos add up.
#include <algorithm>
#include <array>

#include <fmt/format.h>

#include "gonio/twin/detail/bsdf/model.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::twin::bsdf {
namespace {

class Sum final : public Lobe {
 public:
  Sum(std::vector<BsdfPtr> lobes, const WavelengthGrid& grid, std::string spec)
      : Lobe(grid, std::move(spec)), lobes_(std::move(lobes)) {
    for (const auto& l : lobes_) has_delta_ = has_delta_ || l->has_delta();
  }

  void eval(const Vec3& wi, const Vec3& wo, std::span<double> out) const override {
    std::array<double, WavelengthGrid::kMaxChannels> tmp{};
    const std::span<double> part(tmp.data(), out.size());
    for (auto& v : out) v = 0.0;
    for (const auto& l : lobes_) {
      l->eval(wi, wo, part);
      for (std::size_t c = 0; c < out.size(); ++c) out[c] += part[c];
    }
  }

  std::optional<BsdfSample> sample_wi(const Vec3& wo, double u_lobe, Vec2 u) const override {
    std::array<double, kMaxLobeCount> w{};
    const double total = weights(wo, w);
    if (!(total > 0)) return std::nullopt;
    double acc = 0;
    for (std::size_t k = 0; k < lobes_.size(); ++k) {
      const double p = w[k] / total;
      if (p <= 0) continue;
      if (u_lobe < acc + p || k + 1 == lobes_.size()) {
        const double u_next = std::clamp((u_lobe - acc) / p, 0.0, std::nextafter(1.0, 0.0));
        const auto s = lobes_[k]->sample_wi(wo, u_next, u);
        if (!s) return std::nullopt;
        const double mix = pdf_with(wo, s->wi, w, total);
        if (!(mix > 0)) return std::nullopt;
        return BsdfSample{s->wi, mix};
      }
      acc += p;
    }
    return std::nullopt;
  }

  double pdf(const Vec3& wo, const Vec3& wi) const override {
    std::array<double, kMaxLobeCount> w{};
    const double total = weights(wo, w);
    return total > 0 ? pdf_with(wo, wi, w, total) : 0.0;
  }

  void delta_lobes(const Vec3& wo, std::vector<DeltaLobe>& out) const override {
    out.clear();
    std::vector<DeltaLobe> part;
    for (const auto& l : lobes_) {
      if (!l->has_delta()) continue;
      l->delta_lobes(wo, part);
      out.insert(out.end(), part.begin(), part.end());
    }
  }
  bool has_delta() const noexcept override { return has_delta_; }

  double albedo_hint(const Vec3& wo) const override {
    std::array<double, kMaxLobeCount> w{};
    return weights(wo, w);
  }

 private:
  static constexpr std::size_t kMaxLobeCount = 64;

  double weights(const Vec3& wo, std::array<double, kMaxLobeCount>& w) const {
    double total = 0;
    for (std::size_t k = 0; k < lobes_.size(); ++k) {
      w[k] = std::max(0.0, bsdf::albedo_hint(*lobes_[k], wo));
      total += w[k];
    }
    return total;
  }

  double pdf_with(const Vec3& wo, const Vec3& wi, const std::array<double, kMaxLobeCount>& w,
                  double total) const {
    double p = 0;
    for (std::size_t k = 0; k < lobes_.size(); ++k)
      if (w[k] > 0) p += w[k] / total * lobes_[k]->pdf(wo, wi);
    return p;
  }

  std::vector<BsdfPtr> lobes_;
  bool has_delta_ = false;
};

}  // namespace

BsdfPtr make_sum(std::vector<BsdfPtr> lobes, const WavelengthGrid& grid) {
  std::vector<BsdfPtr> flat;
  std::string spec;
  for (auto& l : lobes) {
    if (!l) throw Error(Errc::internal, "a sum of lobes got a null lobe");
    if (l->wavelengths() != grid)
      throw Error::invalid("bsdf", fmt::format("lobe '{}' is built for another wavelength grid", l->spec()));
    spec += (spec.empty() ? "" : "+") + l->spec();
    flat.push_back(std::move(l));
  }
  if (flat.size() < 2) throw Error::invalid("bsdf", "a sum needs at least two lobes");
  if (flat.size() > 64) throw Error::invalid("bsdf", "a sum has more than 64 lobes");
  return std::make_shared<Sum>(std::move(flat), grid, std::move(spec));
}

}  // namespace gonio::twin::bsdf
