// The twin's flux estimators: randomised QMC with MIS (rqmc) and the founding paper's
// plain Monte Carlo over pupil and detector (baseline). See estimator.hpp for the integral.
#include "gonio/twin/detail/core/estimator.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "gonio/twin/detail/core/lobe_sampler.hpp"
#include "gonio/twin/detail/core/sobol.hpp"

namespace gonio::twin::detail {
namespace {

Vec3 source_axis(double theta, double phi) {
  return {-std::sin(theta) * std::cos(phi), -std::sin(theta) * std::sin(phi), std::cos(theta)};
}

// The reference white is a reflector; in a transmission geometry it is read as a perfect
// transmitting diffuser would be, i.e. with ωo mirrored through the sample plane.
Vec3 reference_wo(const Vec3& wo) { return {wo.x, wo.y, std::abs(wo.z)}; }

double channel_mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? 0 : s / static_cast<double>(v.size());
}

// The sample's MIS weight divided by the density of the strategy that drew the candidate
// (p_this; p_aperture, p_bsdf, p_lobe the densities of all three at it, 0 for one not in
// use): the balance heuristic 1 / Σp, or the power heuristic (β = 2) p_this / Σp² (Veach
// 1997, §9.2.2).
// Measured at a fixed budget (variance ratio over 7 geometries per α): with the aperture
// and the BSDF alone, the power heuristic wins 2.8–5× at the peak of an α = 0.02 lobe, as
// it keeps the rare aperture draws that land in the lobe from counting; with the narrow-lobe
// strategy as well, the balance heuristic wins off the peak (up to 5×).
double mis_over_pdf(double p_this, double p_aperture, double p_bsdf, double p_lobe, bool power) {
  return power ? p_this / (p_aperture * p_aperture + p_bsdf * p_bsdf + p_lobe * p_lobe)
               : 1.0 / (p_aperture + p_bsdf + p_lobe);
}

// MIS weights divided by the pdf for the reference white, drawn by the aperture and by its
// BSDF: the balance heuristic.
struct MisWeights {
  double aperture = 0, bsdf = 0;
};
MisWeights mis_weights(double pdf_aperture, double pdf_bsdf) {
  const double w = 1.0 / (pdf_aperture + pdf_bsdf);
  return {w, w};
}

double signed_receive_angle(const Vec3& w, double phi) {
  // θr signed in the receiver's plane of measurement (docs/architecture.md §2), degrees.
  const double in_plane = w.x * std::cos(phi) + w.y * std::sin(phi);
  return std::atan2(in_plane, w.z) * kRadToDeg;
}

}  // namespace

MeasurementSetup make_setup(const InstrumentProfile& profile, const Geometry& nominal) {
  MeasurementSetup s;
  const double ti = (nominal.theta_i + profile.arms.incidence_offset_deg) * kDegToRad;
  const double tr = (nominal.theta_r + profile.arms.receive_offset_deg) * kDegToRad;
  const double pi = nominal.phi_i * kDegToRad, pr = nominal.phi_r * kDegToRad;
  s.source = arm_frame(source_axis(ti, pi), pi);
  s.receiver = arm_frame({std::sin(tr) * std::cos(pr), std::sin(tr) * std::sin(pr), std::cos(tr)}, pr);
  s.source_aperture = Aperture::from(profile.source.aperture_deg, profile.source.aperture_shape);
  s.receiver_aperture =
      Aperture::from(profile.receiver.aperture_deg, profile.receiver.aperture_shape);
  s.beam = Footprint(s.source, profile.source.beam_mm, profile.source.beam_shape);
  s.field = Footprint(s.receiver, profile.receiver.field_mm, profile.receiver.field_shape);
  s.sample_mm = profile.sample_mm;
  s.reference_mm = profile.reference_mm;
  s.transmission = s.receiver.a.z < 0;
  s.receive_phi = pr;
  return s;
}

FluxEstimator::FluxEstimator(const MeasurementSetup& setup, const Bsdf& sample,
                             const Bsdf* reference, EstimatorKind kind, std::uint64_t seed,
                             int replicates, std::vector<const Bsdf*> variants)
    : setup_(setup), sample_(sample), reference_(reference), kind_(kind), seed_(seed),
      replicates_(replicates), channels_(sample.channels()),
      sums_(static_cast<std::size_t>(replicates) * channels_, 0.0),
      ref_sums_(static_cast<std::size_t>(replicates) * channels_, 0.0),
      variants_(std::move(variants)),
      variant_sums_(variants_.size() * static_cast<std::size_t>(replicates) * channels_, 0.0),
      sample_narrow_(narrow_at_aperture_scale(setup, sample, false)),
      reference_narrow_(reference && narrow_at_aperture_scale(setup, *reference, true)),
      lobe_scale_(kind == EstimatorKind::rqmc ? lobe_scale(setup, sample) : Vec2{0, 0}),
      lobe_alone_(lobe_alone(setup, sample, lobe_scale_)) {}

// The widths of the sample's reflection lobe in the source aperture's tangent units, seen
// from the receiver's axis: along each tangent axis, the offset from the mirror direction at
// which f falls to a quarter of its value there (for GGX, (1 + r²/s²)⁻², that is r = s:
// the scale of lobe_sampler.hpp's density). An axis along which the lobe is not narrower
// than the aperture's full width gets that width. {0, 0} — no lobe strategy — when neither
// axis is narrower than 3/4 of the full width, when the mirror direction is behind the
// source arm, and in transmission.
Vec2 FluxEstimator::lobe_scale(const MeasurementSetup& s, const Bsdf& bsdf) {
  if (s.transmission) return {0, 0};
  const Vec3 wo = s.receiver.a;
  Vec2 m;
  if (!tangent_of(s.source, {-wo.x, -wo.y, wo.z}, m)) return {0, 0};
  std::vector<double> f(bsdf.channels());
  const auto at = [&](double dx, double dy) {
    bsdf.eval(direction_from_tangent(s.source, {m.x + dx, m.y + dy}).w, wo, f);
    return channel_mean(f);
  };
  const double f0 = at(0, 0);
  if (!(f0 > 0)) return {0, 0};
  // Along (ex, ey): the limit when f is still above a quarter there, else the crossing
  // bracketed by halving and refined by bisection (to 1 %: a scale, not a root).
  const auto quarter = [&](double ex, double ey, double limit) {
    if (at(limit * ex, limit * ey) >= f0 / 4) return limit;
    double below = limit, above = limit / 2;
    for (int k = 0; k < 40 && at(above * ex, above * ey) < f0 / 4; ++k) below = above, above /= 2;
    for (int k = 0; k < 8; ++k) {
      const double mid = 0.5 * (above + below);
      (at(mid * ex, mid * ey) >= f0 / 4 ? above : below) = mid;
    }
    return 0.5 * (above + below);
  };
  const double wx = 2 * s.source_aperture.tx, wy = 2 * s.source_aperture.ty;
  const Vec2 scale{quarter(1, 0, wx), quarter(0, 1, wy)};
  // Worth its cost (a draw and a footprint clip more per point than the aperture's draw
  // alone) only below 3/4 of the full width in some axis: measured on conductors at 45°,
  // the aperture alone then needs at least twice the points; above, it needs as few.
  if (scale.x >= 0.75 * wx && scale.y >= 0.75 * wy) return {0, 0};
  return scale;
}

// Whether the lobe strategy can carry the sample alone: its density is positive on the whole
// aperture, so it is unbiased by itself, and when f / p varies little over the aperture its
// estimate is nearly constant — where the balance heuristic with the uniform draw would add
// the uniform draw's own variance, of the order of the flux squared (Veach 1997, Theorem
// 9.2), and an evaluation of f. Probed at the nominal directions on a 9 × 9 grid of the
// aperture: alone when f / p nowhere exceeds 4 times its value at the mirror direction (a
// GGX lobe: below 2; a lobe on a diffuse base that dominates the aperture's corners: not).
bool FluxEstimator::lobe_alone(const MeasurementSetup& s, const Bsdf& bsdf, Vec2 scale) {
  if (!(scale.x > 0)) return false;
  const Vec3 wo = s.receiver.a;
  Vec2 m;
  if (!tangent_of(s.source, {-wo.x, -wo.y, wo.z}, m)) return false;
  const Vec2 half{s.source_aperture.tx, s.source_aperture.ty};
  const LobeSampler lobe(m, scale, s.source_aperture);
  if (!lobe.usable()) return false;
  std::vector<double> f(bsdf.channels());
  const auto ratio = [&](Vec2 t) {
    bsdf.eval(direction_from_tangent(s.source, t).w, wo, f);
    return channel_mean(f) / lobe.pdf(t);
  };
  // The mirror direction, or the aperture's point nearest it along the line to the centre.
  Vec2 at_mirror{std::clamp(m.x, -half.x, half.x), std::clamp(m.y, -half.y, half.y)};
  if (s.source_aperture.ellipse) {
    const double r = std::hypot(m.x / half.x, m.y / half.y);
    at_mirror = r > 1 ? Vec2{m.x / r, m.y / r} : m;
  }
  const double r0 = ratio({0.98 * at_mirror.x, 0.98 * at_mirror.y});
  if (!(r0 > 0 && std::isfinite(r0))) return false;
  for (int i = 0; i < 9; ++i)
    for (int j = 0; j < 9; ++j) {
      const Vec2 t{0.98 * half.x * (i - 4) / 4.0, 0.98 * half.y * (j - 4) / 4.0};
      if (s.source_aperture.contains_tangent(t) && !(ratio(t) <= 4 * r0)) return false;
    }
  return true;
}

// Whether a BSDF varies on the scale of the source aperture for this geometry, i.e. whether
// BSDF sampling can beat uniform aperture sampling anywhere in it. Probes the density of
// BSDF sampling (given the nominal receiver direction) on a 5 × 5 grid of the aperture and
// at BSDF samples that land in it; a smooth model never reaches half the aperture's own
// density there. Smooth integrands then keep RQMC's fast convergence with one strategy,
// and MIS (with its discontinuous acceptance of BSDF samples) is used only where needed.
bool FluxEstimator::narrow_at_aperture_scale(const MeasurementSetup& s, const Bsdf& bsdf,
                                             bool reference) {
  const Vec3 wo = reference ? reference_wo(s.receiver.a) : s.receiver.a;
  const double area = s.source_aperture.tangent_area();
  const auto dense = [&](const Vec3& wi) {
    Vec2 t;
    if (!tangent_of(s.source, wi, t) || !s.source_aperture.contains_tangent(t)) return false;
    const double cg = dot(wi, s.source.a);
    return bsdf.pdf(wo, wi) >= 0.5 / (area * cg * cg * cg);
  };
  for (int i = 0; i < 5; ++i)
    for (int j = 0; j < 5; ++j)
      if (dense(direction_from_tangent(s.source, aperture_point(s.source_aperture, (i + 0.5) / 5,
                                                                (j + 0.5) / 5)).w))
        return true;
  for (int k = 0; k < 32; ++k) {
    const auto smp = bsdf.sample_wi(wo, (k + 0.5) / 32, {((k * 5) % 32 + 0.5) / 32, ((k * 13) % 32 + 0.5) / 32});
    if (smp && dense(smp->wi)) return true;
  }
  return false;
}

void FluxEstimator::run_until(std::uint64_t n) {
  if (n <= n_) return;
  for (int r = 0; r < replicates_; ++r) {
    if (kind_ == EstimatorKind::rqmc)
      run_rqmc(r, n_, n);
    else
      run_baseline(r, n_, n);
  }
  n_ = n;
}

Diagnostics FluxEstimator::diagnostics() const {
  Diagnostics d;
  if (kind_ == EstimatorKind::baseline)
    d.sampling = SourceSampling::baseline;
  else if (lobe_scale_.x > 0)
    d.sampling = lobe_alone_ ? SourceSampling::lobe : SourceSampling::lobe_aperture;
  else
    d.sampling = sample_narrow_ ? SourceSampling::aperture_bsdf : SourceSampling::aperture;
  // The baseline samples sample-plane points, not footprints: it cannot tell.
  if (kind_ == EstimatorKind::baseline)
    d.seen_fraction = std::numeric_limits<double>::quiet_NaN();
  else if (w_lit_ > 0)
    d.seen_fraction = w_seen_ / w_lit_;
  if (w_sum_ > 0) {
    d.mean_theta_i = w_theta_i_ / w_sum_;
    d.mean_theta_r = w_theta_r_ / w_sum_;
  }
  return d;
}

// Per-point scratch and the additions into one replicate's sums.
struct FluxEstimator::Accumulator {
  FluxEstimator& e;
  double* sample_sum;
  double* ref_sum;
  std::vector<double> f, fr;
  std::vector<DeltaLobe> lobes;

  Accumulator(FluxEstimator& est, int r)
      : e(est), sample_sum(&est.sums_[static_cast<std::size_t>(r) * est.channels_]),
        ref_sum(&est.ref_sums_[static_cast<std::size_t>(r) * est.channels_]),
        f(est.channels_), fr(est.channels_) {
    for (std::size_t v = 0; v < est.variants_.size(); ++v)
      variant_sum.push_back(&est.variant_sums_[(v * static_cast<std::size_t>(est.replicates_) +
                                                static_cast<std::size_t>(r)) * est.channels_]);
  }
  std::vector<double*> variant_sum;

  // Adds w·seen·f_v(wi, wo) to every variant's sums (the paths of the sample).
  void add_variants(double ws, const Vec3& wi, const Vec3& wo) {
    for (std::size_t v = 0; v < e.variants_.size(); ++v) {
      e.variants_[v]->eval(wi, wo, fv);
      for (std::size_t c = 0; c < e.channels_; ++c) variant_sum[v][c] += ws * fv[c];
    }
  }
  std::vector<double> fv = std::vector<double>(e.channels_);

  // Adds w·seen·f to the sample sums; `lit` is the lit footprint on the sample for the
  // same directions (diagnostics: which fraction of it the receiver sees). The diagnostics
  // are flux-weighted means, taken from the first replicate alone (`diagnose`): the lit
  // footprint is a polygon clip per draw that nothing else needs.
  bool diagnose = false;
  void add_sample(double w, double seen, double lit, const Vec3& wi, const Vec3& wo,
                  const std::vector<double>& values) {
    const double ws = w * seen;
    for (std::size_t c = 0; c < e.channels_; ++c) sample_sum[c] += ws * values[c];
    if (!diagnose) return;
    const double m = w * channel_mean(values);
    if (!(m > 0)) return;
    e.w_seen_ += m * seen;
    e.w_lit_ += m * lit;
    if (!(seen > 0)) return;
    e.w_sum_ += m * seen;
    e.w_theta_i_ += m * seen * std::acos(std::clamp(wi.z, -1.0, 1.0)) * kRadToDeg;
    e.w_theta_r_ += m * seen * signed_receive_angle(wo, e.setup_.receive_phi);
  }
  void add_reference(double w, const std::vector<double>& values) {
    for (std::size_t c = 0; c < e.channels_; ++c) ref_sum[c] += w * values[c];
  }
};

// One replicate's randomised QMC points (run_rqmc): the replicate's constants, and per point
// the receiver's draw, then each source strategy in turn — uniform over the source aperture,
// the lobe's shape, BSDF sampling — and the ideal specular paths. The sample's draws are
// combined by MIS (mis_over_pdf), the reference's by the balance heuristic.
struct FluxEstimator::RqmcPoint {
  RqmcPoint(FluxEstimator& est, int r)
      : e(est), S(est.setup_), src_area(S.source_aperture.tangent_area()),
        rcv_area(S.receiver_aperture.tangent_area()),
        sample_plate(Polygon::rectangle(0.5 * S.sample_mm.in_plane, 0.5 * S.sample_mm.perpendicular)),
        ref_plate(Polygon::rectangle(0.5 * S.reference_mm.in_plane, 0.5 * S.reference_mm.perpendicular)),
        same_plates(S.sample_mm == S.reference_mm), acc(est, r) {
    acc.diagnose = r == 0;
  }

  FluxEstimator& e;
  const MeasurementSetup& S;
  const double src_area, rcv_area;
  const Polygon sample_plate, ref_plate;
  const bool same_plates;
  Accumulator acc;
  // The point: its uniforms, the receiver's direction and the plates' regions it sees.
  const double* u = nullptr;
  Vec3 wo, wo_ref;
  double cos_o = 0, inv_pdf_o = 0;
  Polygon seen, seen_ref;
  // The lobe strategy's sampler about ωo's mirror direction, when it serves this point.
  std::optional<LobeSampler> lobe;
  // BSDF sampling serves what the lobe strategy does not: a narrow lobe through an elliptical
  // aperture, or one off the mirror direction. With it in the mix the sample's draws are
  // weighed by the power heuristic, else by the balance heuristic (see mis_over_pdf).
  bool bsdf_draws = false;

  // Draws ωo over the receiver's aperture and clips the plates to the receiver's field;
  // false when ωo is at or below the sample plane.
  bool receive(const double* uniforms) {
    u = uniforms;
    const auto od = direction_from_tangent(S.receiver, aperture_point(S.receiver_aperture, u[0], u[1]));
    wo = od.w;
    cos_o = std::abs(wo.z);
    if (cos_o <= 0) return false;
    inv_pdf_o = rcv_area * od.cos_gamma3;
    wo_ref = reference_wo(wo);
    seen = sample_plate;
    S.field.clip_to(seen, wo);
    seen_ref = ref_plate;
    if (e.reference_) {
      if (same_plates)
        seen_ref = seen;
      else
        S.field.clip_to(seen_ref, wo);
    }
    find_lobe();
    bsdf_draws = e.sample_narrow_ && !lobe;
    return true;
  }

  // Area lit along wi within a seen region; the lit footprint on the sample (diagnostics).
  double lit_area(const Polygon& region, const Vec3& wi) const {
    Polygon p = region;
    S.beam.clip_to(p, wi);
    return p.area();
  }
  double footprint_area(const Vec3& wi) const { return lit_area(sample_plate, wi); }

  double mis(double p_this, double p_aperture, double p_bsdf, double p_lobe) const {
    return mis_over_pdf(p_this, p_aperture, p_bsdf, p_lobe, bsdf_draws);
  }

  // One candidate source direction wi with its MIS weight for the sample and reference.
  void contribute(const Vec3& wi, double w_sample, double w_ref) {
    const double base = std::abs(wi.z) * cos_o * inv_pdf_o;
    double a_sample = -1;
    if (w_sample > 0) {
      a_sample = seen.n >= 3 ? lit_area(seen, wi) : 0.0;
      // Seen and lit implies lit: without diagnostics, a draw that is not seen adds nothing.
      const double lit = acc.diagnose ? footprint_area(wi) : a_sample;
      if (lit > 0) {
        e.sample_.eval(wi, wo, acc.f);
        acc.add_sample(base * w_sample, a_sample, lit, wi, wo, acc.f);
        if (!e.variants_.empty() && a_sample > 0) acc.add_variants(base * w_sample * a_sample, wi, wo);
      }
    }
    if (e.reference_ && w_ref > 0 && seen_ref.n >= 3) {
      const double a = !same_plates ? lit_area(seen_ref, wi) : a_sample >= 0 ? a_sample : lit_area(seen, wi);
      if (a > 0) {
        e.reference_->eval(wi, wo_ref, acc.fr);
        acc.add_reference(base * a * w_ref, acc.fr);
      }
    }
  }

  // The lobe strategy, for a lobe narrower than the source aperture: ωi from the lobe's shape
  // truncated to the aperture about ωo's mirror direction (lobe_sampler.hpp). Every draw lies
  // in the aperture and moves continuously with its uniforms — no acceptance test, unlike BSDF
  // sampling — and its density follows the lobe's, so f / p hardly varies. Off the peak, where
  // the lobe reaches the aperture only at its edge nearest the mirror direction, it puts the
  // draws there.
  void find_lobe() {
    lobe.reset();
    if (!(e.lobe_scale_.x > 0)) return;
    Vec2 m;
    if (!tangent_of(S.source, {-wo.x, -wo.y, wo.z}, m)) return;
    lobe.emplace(m, e.lobe_scale_, S.source_aperture);
    if (!lobe->usable()) lobe.reset();
  }
  // The lobe strategy's density in solid angle at a direction (0 outside the aperture).
  double lobe_pdf(const Vec3& wi) const {
    Vec2 t;
    if (!lobe || !tangent_of(S.source, wi, t)) return 0.0;
    const double cg = dot(wi, S.source.a);
    return lobe->pdf(t) / (cg * cg * cg);
  }

  // Uniform over the source aperture; when the lobe strategy carries the sample alone, the
  // draw serves the reference only.
  void from_aperture() {
    const auto id = direction_from_tangent(S.source, aperture_point(S.source_aperture, u[4], u[5]));
    const double p_aperture = 1.0 / (src_area * id.cos_gamma3);
    const double p_bsdf = bsdf_draws ? e.sample_.pdf(wo, id.w) : 0;
    const bool alone = lobe && e.lobe_alone_;
    const double p_lobe = alone ? 0 : lobe_pdf(id.w);
    const double p_ref_bsdf = e.reference_narrow_ ? e.reference_->pdf(wo_ref, id.w) : 0;
    contribute(id.w, alone ? 0.0 : mis(p_aperture, p_aperture, p_bsdf, p_lobe),
               e.reference_narrow_ ? mis_weights(p_aperture, p_ref_bsdf).aperture : 1.0 / p_aperture);
  }

  void from_lobe() {
    const auto draw = lobe->sample(u[7], u[6]);
    const auto id = direction_from_tangent(S.source, draw.t);
    const double p_aperture = 1.0 / (src_area * id.cos_gamma3);
    const double p_bsdf = bsdf_draws ? e.sample_.pdf(wo, id.w) : 0;
    const double p_lobe = draw.pdf / id.cos_gamma3;
    if (draw.pdf > 0)
      contribute(id.w, e.lobe_alone_ ? 1.0 / p_lobe : mis(p_lobe, p_aperture, p_bsdf, p_lobe), 0);
  }

  // BSDF importance sampling given ωo, kept when it lands in the aperture: for the sample or
  // for the reference.
  void from_bsdf(const Bsdf& bsdf, const Vec3& wo_b, bool for_sample) {
    const auto s = bsdf.sample_wi(wo_b, u[6], {u[2], u[3]});
    if (!s || !(s->pdf > 0)) return;
    Vec2 t;
    if (!tangent_of(S.source, s->wi, t) || !S.source_aperture.contains_tangent(t)) return;
    const double cg = dot(s->wi, S.source.a);
    const double p_aperture = 1.0 / (src_area * cg * cg * cg);
    const double w = for_sample ? mis(s->pdf, p_aperture, s->pdf, lobe_pdf(s->wi)) : mis_weights(p_aperture, s->pdf).bsdf;
    if (w == 0) return;
    if (for_sample)
      contribute(s->wi, w, 0);
    else
      contribute(s->wi, 0, w);
  }

  // Ideal specular paths, exactly: the sample's or the reference's.
  void specular(const Bsdf& bsdf, const Vec3& wo_b, bool for_sample) {
    bsdf.delta_lobes(wo_b, acc.lobes);
    for (const auto& l : acc.lobes) {
      Vec2 t;
      if (!tangent_of(S.source, l.wi, t) || !S.source_aperture.contains_tangent(t)) continue;
      const Polygon& region = for_sample ? seen : seen_ref;
      const double a = region.n >= 3 ? lit_area(region, l.wi) : 0.0;
      const double w = cos_o * inv_pdf_o;
      if (for_sample)
        acc.add_sample(w, a, acc.diagnose ? footprint_area(l.wi) : 0.0, l.wi, wo, l.weight);
      else if (a > 0)
        acc.add_reference(w * a, l.weight);
    }
  }

  // Each variant's own ideal specular paths (exact, so no sampling to share).
  void variant_specular() {
    for (std::size_t v = 0; v < e.variants_.size(); ++v) {
      if (!e.variants_[v]->has_delta()) continue;
      e.variants_[v]->delta_lobes(wo, acc.lobes);
      for (const auto& l : acc.lobes) {
        Vec2 t;
        if (!tangent_of(S.source, l.wi, t) || !S.source_aperture.contains_tangent(t)) continue;
        const double a = seen.n >= 3 ? lit_area(seen, l.wi) : 0.0;
        const double w = cos_o * inv_pdf_o * a;
        for (std::size_t c = 0; c < e.channels_; ++c) acc.variant_sum[v][c] += w * l.weight[c];
      }
    }
  }
};

void FluxEstimator::run_rqmc(int r, std::uint64_t begin, std::uint64_t end) {
  const auto& table = SobolTable::get(end);
  std::uint32_t scramble[kSobolDims];
  for (int d = 0; d < kSobolDims; ++d)
    scramble[d] = static_cast<std::uint32_t>(
        mix64(seed_ ^ mix64(static_cast<std::uint64_t>(r) * 64 + static_cast<std::uint64_t>(d))));
  RqmcPoint p(*this, r);
  const bool sample_delta = sample_.has_delta();
  const bool ref_delta = reference_ && reference_->has_delta();
  for (std::uint64_t i = begin; i < end; ++i) {
    double u[kSobolDims];
    for (int d = 0; d < kSobolDims; ++d)
      u[d] = to_unit(owen_scramble(table[i * kSobolDims + static_cast<std::uint64_t>(d)], scramble[d]));
    if (!p.receive(u)) continue;
    p.from_aperture();
    if (p.lobe) p.from_lobe();
    if (p.bsdf_draws) p.from_bsdf(sample_, p.wo, true);
    if (reference_narrow_) p.from_bsdf(*reference_, p.wo_ref, false);
    if (sample_delta) p.specular(sample_, p.wo, true);
    if (ref_delta) p.specular(*reference_, p.wo_ref, false);
    p.variant_specular();
  }
}

void FluxEstimator::run_baseline(int r, std::uint64_t begin, std::uint64_t end) {
  const auto& S = setup_;
  const double src_area = S.source_aperture.tangent_area();
  const double rcv_weight = S.receiver_aperture.tangent_area() * S.field.cross_section_area();
  const auto on_plate = [](const Extent& e, const Vec2& x) {
    return std::abs(x.x) <= 0.5 * e.in_plane && std::abs(x.y) <= 0.5 * e.perpendicular;
  };
  Accumulator acc(*this, r);
  acc.diagnose = true;
  const std::uint64_t stream = mix64(seed_ ^ (0xba5e11e5ull + static_cast<std::uint64_t>(r)));

  for (std::uint64_t i = begin; i < end; ++i) {
    double u[6];
    for (int d = 0; d < 6; ++d)
      u[d] = to_unit(static_cast<std::uint32_t>(mix64(stream ^ mix64(i * 8 + static_cast<std::uint64_t>(d))) >> 32));

    // A detector point fixes the direction (ideal lens); a pupil point fixes the ray.
    const auto od = direction_from_tangent(S.receiver, aperture_point(S.receiver_aperture, u[0], u[1]));
    const Vec3 wo = od.w;
    if (wo.z == 0) continue;
    const double cos_gamma = dot(wo, S.receiver.a);
    const double w_o = rcv_weight * od.cos_gamma3 * cos_gamma;  // (n·v)^4 / pdf
    const Vec2 pp = S.field.point(u[2], u[3]);
    const Vec3 o = S.receiver.t * pp.x + S.receiver.p * pp.y;
    const Vec3 hit = o - wo * (o.z / wo.z);
    const Vec2 x{hit.x, hit.y};
    const bool on_sample = on_plate(S.sample_mm, x);
    const bool on_ref = reference_ && on_plate(S.reference_mm, x);
    if (!on_sample && !on_ref) continue;
    const Vec3 wo_ref = reference_wo(wo);

    const auto id = direction_from_tangent(S.source, aperture_point(S.source_aperture, u[4], u[5]));
    const Vec3 wi = id.w;
    if (S.beam.contains(x, wi)) {
      const double w = std::abs(wi.z) * src_area * id.cos_gamma3 * w_o;
      if (on_sample) {
        sample_.eval(wi, wo, acc.f);
        acc.add_sample(w, 1, 0, wi, wo, acc.f);
        acc.add_variants(w, wi, wo);
      }
      if (on_ref) {
        reference_->eval(wi, wo_ref, acc.fr);
        acc.add_reference(w, acc.fr);
      }
    }
    const auto delta = [&](const Bsdf& bsdf, const Vec3& wo_b, bool for_sample) {
      bsdf.delta_lobes(wo_b, acc.lobes);
      for (const auto& lobe : acc.lobes) {
        Vec2 t;
        if (!tangent_of(S.source, lobe.wi, t) || !S.source_aperture.contains_tangent(t)) continue;
        if (!S.beam.contains(x, lobe.wi)) continue;
        if (for_sample)
          acc.add_sample(w_o, 1, 0, lobe.wi, wo, lobe.weight);
        else
          acc.add_reference(w_o, lobe.weight);
      }
    };
    if (on_sample && sample_.has_delta()) delta(sample_, wo, true);
    if (on_ref && reference_->has_delta()) delta(*reference_, wo_ref, false);
    for (std::size_t v = 0; on_sample && v < variants_.size(); ++v) {
      if (!variants_[v]->has_delta()) continue;
      variants_[v]->delta_lobes(wo, acc.lobes);
      for (const auto& lobe : acc.lobes) {
        Vec2 t;
        if (!tangent_of(S.source, lobe.wi, t) || !S.source_aperture.contains_tangent(t)) continue;
        if (!S.beam.contains(x, lobe.wi)) continue;
        for (std::size_t c = 0; c < channels_; ++c) acc.variant_sum[v][c] += w_o * lobe.weight[c];
      }
    }
  }
}

}  // namespace gonio::twin::detail
