// Levenberg–Marquardt on the weighted residuals (Eigen's unsupported module, a port of
// MINPACK's lmder: Moré 1978), the covariance from the Gauss–Newton approximation of the
// Hessian, and the identifiability analysis.
//
// Bounds: each parameter is fitted through x = lo + (hi − lo)(1 + sin y)/2 (in log x for
// log-scale parameters), the transformation MINUIT uses for bounded parameters (James &
// Roos 1975), so every trial point is inside its bounds. The covariance is computed in x
// at the optimum, from a Jacobian taken there.
//
// Jacobian: forward differences with steps of a few 1e-3 of the value. The virtual
// measurement uses the same random numbers at every evaluation (common random numbers), so
// its Monte Carlo error is a fixed, smooth function of the parameters and such steps give
// derivatives far less noisy than the standard error itself.
#include "gonio/twin/detail/fit/solver.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Dense>
#include <fmt/format.h>
#include <unsupported/Eigen/LevenbergMarquardt>

#include "gonio/twin/detail/core/sobol.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::twin::fit {
namespace {

struct Bounded {
  double lo, hi;
  bool log;
  double a() const { return log ? std::log(lo) : lo; }
  double b() const { return log ? std::log(hi) : hi; }
  double to_x(double y) const {
    const double t = 0.5 * (1 + std::sin(y));
    const double v = a() + (b() - a()) * t;
    return std::clamp(log ? std::exp(v) : v, lo, hi);
  }
  double dx_dy(double y) const {
    const double dt = 0.5 * std::cos(y);
    return (b() - a()) * dt * (log ? to_x(y) : 1.0);
  }
  double to_y(double x) const {
    const double v = log ? std::log(x) : x;
    const double s = std::clamp(2 * (v - a()) / (b() - a()) - 1, -1.0, 1.0);
    return std::asin(s);
  }
  // Forward-difference step in x, pointing inward near the upper bound.
  double step(double x) const {
    double h = log ? 3e-3 * x : std::max(3e-3 * std::abs(x), 1e-3 * (hi - lo));
    if (x + h > hi) h = -h;
    return h;
  }
};

std::string status_text(Eigen::LevenbergMarquardtSpace::Status s) {
  using namespace Eigen::LevenbergMarquardtSpace;
  switch (s) {
    case RelativeReductionTooSmall: return "converged: relative reduction of chi2 below tolerance";
    case RelativeErrorTooSmall: return "converged: relative change of parameters below tolerance";
    case RelativeErrorAndReductionTooSmall: return "converged: parameters and chi2 both stable";
    case CosinusTooSmall: return "converged: residuals orthogonal to the Jacobian";
    case TooManyFunctionEvaluation: return "stopped: iteration limit reached";
    case FtolTooSmall: return "stopped: chi2 tolerance too small to improve further";
    case XtolTooSmall: return "stopped: parameter tolerance too small to improve further";
    case GtolTooSmall: return "stopped: gradient tolerance too small to improve further";
    case ImproperInputParameters: return "failed: improper input";
    default: return "stopped";
  }
}

bool converged_status(Eigen::LevenbergMarquardtSpace::Status s) {
  using namespace Eigen::LevenbergMarquardtSpace;
  return s == RelativeReductionTooSmall || s == RelativeErrorTooSmall ||
         s == RelativeErrorAndReductionTooSmall || s == CosinusTooSmall || s == FtolTooSmall ||
         s == XtolTooSmall || s == GtolTooSmall;
}

class Evaluator {
 public:
  explicit Evaluator(const Problem& p) : p_(p) {
    for (const auto& q : p.params) bounds_.push_back({q.lo, q.hi, q.log_scale});
  }
  std::size_t n() const { return p_.params.size(); }
  std::size_t m() const { return p_.measured.size(); }
  const std::vector<Bounded>& bounds() const { return bounds_; }
  int evaluations() const { return evaluations_; }

  struct State {
    std::vector<double> x, beta, se, sigma;
  };
  // Whether the model accepts x (computing and caching it when it does).
  bool feasible(const std::vector<double>& x) {
    try {
      at(x);
      return true;
    } catch (const Error& e) {
      if (e.code() == Errc::internal) throw;
      return false;
    }
  }
  // The model at x, cached for the last point asked for.
  const State& at(const std::vector<double>& x) {
    if (!cache_.x.empty() && cache_.x == x) return cache_;
    cache_ = compute(x);
    return cache_;
  }
  State compute(const std::vector<double>& x) {
    State s;
    s.x = x;
    p_.evaluate(x, s.beta, s.se);
    ++evaluations_;
    if (s.beta.size() != m() || s.se.size() != m())
      throw Error(Errc::internal, "the model returned the wrong number of values");
    s.sigma.resize(m());
    for (std::size_t i = 0; i < m(); ++i) {
      s.sigma[i] = std::sqrt(p_.u[i] * p_.u[i] + s.se[i] * s.se[i]);
      if (!std::isfinite(s.beta[i]))
        throw Error(Errc::internal, fmt::format("the model gave a non-finite β at residual {}", i));
    }
    return s;
  }
  // The stepped points of every group at once (evaluate_steps); empty when the problem
  // has no such evaluation or the model refuses one of the steps.
  std::vector<State> steps_at_once(const std::vector<double>& x, int groups,
                                   std::vector<std::vector<double>>& h) {
    if (!p_.evaluate_steps) return {};
    std::vector<std::vector<double>> xs{x};
    h.assign(static_cast<std::size_t>(groups), std::vector<double>(n(), 0.0));
    for (int g = 0; g < groups; ++g) {
      auto xp = x;
      for (std::size_t j = 0; j < n(); ++j)
        if (p_.group[j] == g) xp[j] += (h[static_cast<std::size_t>(g)][j] = bounds_[j].step(x[j]));
      xs.push_back(std::move(xp));
    }
    std::vector<std::vector<double>> beta, se;
    try {
      p_.evaluate_steps(xs, beta, se);
    } catch (const Error& e) {
      if (e.code() == Errc::internal) throw;
      return {};
    }
    evaluations_ += static_cast<int>(xs.size()) - 1;
    std::vector<State> out;
    for (std::size_t k = 1; k < xs.size(); ++k) {
      State s;
      s.x = xs[k];
      s.beta = std::move(beta[k]);
      s.se = std::move(se[k]);
      if (s.beta.size() != m() || s.se.size() != m())
        throw Error(Errc::internal, "the model returned the wrong number of values");
      out.push_back(std::move(s));
    }
    return out;
  }

  // Jacobian of the weighted residuals in x (scale[j] = dx/dy turns it into y).
  Eigen::MatrixXd jacobian(const std::vector<double>& x, const std::vector<double>& scale) {
    const State base = at(x);
    Eigen::MatrixXd J = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(m()),
                                              static_cast<Eigen::Index>(n()));
    const int groups = n() == 0 ? 0 : *std::max_element(p_.group.begin(), p_.group.end()) + 1;
    // The columns of group g from the model moved by the steps h.
    const auto fill = [&](int g, const State& moved, const std::vector<double>& h) {
      for (std::size_t i = 0; i < m(); ++i) {
        const int c = static_cast<int>(i % p_.channels);
        for (std::size_t j = 0; j < n(); ++j) {
          if (p_.group[j] != g || (p_.channel[j] >= 0 && p_.channel[j] != c)) continue;
          J(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) =
              (moved.beta[i] - base.beta[i]) / (h[j] * base.sigma[i]) * scale[j];
        }
      }
    };
    std::vector<std::vector<double>> shared_h;
    const auto shared = steps_at_once(x, groups, shared_h);
    for (int g = 0; g < groups; ++g) {
      if (!shared.empty()) {
        fill(g, shared[static_cast<std::size_t>(g)], shared_h[static_cast<std::size_t>(g)]);
        continue;
      }
      auto xp = x;
      std::vector<double> h(n(), 0.0);
      for (std::size_t j = 0; j < n(); ++j)
        if (p_.group[j] == g) xp[j] += (h[j] = bounds_[j].step(x[j]));
      State moved;
      try {
        moved = compute(xp);
      } catch (const Error&) {
        // The model refuses the step (a constraint between parameters, such as abg's
        // energy): difference backwards instead.
        xp = x;
        for (std::size_t j = 0; j < n(); ++j)
          if (p_.group[j] == g) xp[j] += (h[j] = -h[j]);
        moved = compute(xp);
      }
      fill(g, moved, h);
    }
    return J;
  }

 private:
  const Problem& p_;
  std::vector<Bounded> bounds_;
  State cache_;
  int evaluations_ = 0;
};

struct Functor : Eigen::DenseFunctor<double> {
  Functor(Evaluator& e, const Problem& p)
      : Eigen::DenseFunctor<double>(static_cast<int>(e.n()), static_cast<int>(e.m())), ev(e),
        prob(p) {}
  std::vector<double> x_of(const InputType& y) const {
    std::vector<double> x(ev.n());
    for (std::size_t j = 0; j < x.size(); ++j)
      x[j] = ev.bounds()[j].to_x(y(static_cast<Eigen::Index>(j)));
    return x;
  }
  int operator()(const InputType& y, ValueType& f) const {
    const auto x = x_of(y);
    if (!ev.feasible(x)) {
      // A trial point the model refuses: a residual far above any real one, so that the
      // optimiser rejects the step and shortens its trust region.
      f.setConstant(1e10);
      return 0;
    }
    const auto& s = ev.at(x);
    for (std::size_t i = 0; i < ev.m(); ++i)
      f(static_cast<Eigen::Index>(i)) = (s.beta[i] - prob.measured[i]) / s.sigma[i];
    return 0;
  }
  int df(const InputType& y, JacobianType& J) const {
    last_x = x_of(y);
    last_jx = ev.jacobian(last_x, std::vector<double>(ev.n(), 1.0));
    J = last_jx;
    for (std::size_t j = 0; j < ev.n(); ++j)
      J.col(static_cast<Eigen::Index>(j)) *= ev.bounds()[j].dx_dy(y(static_cast<Eigen::Index>(j)));
    ++jacobians;
    return 0;
  }
  Evaluator& ev;
  const Problem& prob;
  mutable int jacobians = 0;
  mutable std::vector<double> last_x;  // where the last Jacobian was taken, and it in x
  mutable Eigen::MatrixXd last_jx;
};

// A parameter this close to a bound (share of its fitting range) is reported at the bound.
constexpr double kBoundMargin = 5e-3;

// One warning per parameter on a bound, or per mark for per-channel parameters
// ("lambert.albedo@550"): "on a bound at 12 of 31 channels" rather than 12 warnings.
void bound_warnings(const std::vector<FittedParameter>& params, const std::vector<int>& channel,
                    std::vector<std::string>& out) {
  std::vector<std::string> marks;
  std::vector<std::pair<int, int>> counts;  // on a bound, of
  std::vector<std::string> example;
  for (std::size_t j = 0; j < params.size(); ++j) {
    const auto& p = params[j];
    const auto at = p.name.find('@');
    if (channel[j] < 0 || at == std::string::npos) {
      if (p.at_bound)
        out.push_back(fmt::format("{} = {:g} is at a bound of [{:g}, {:g}]: the data push it "
                                  "there, so it is no estimate and its uncertainty means "
                                  "nothing; the model may not describe the data",
                                  p.name, p.value, p.lo, p.hi));
      continue;
    }
    const auto mark = p.name.substr(0, at);
    auto it = std::find(marks.begin(), marks.end(), mark);
    if (it == marks.end()) {
      marks.push_back(mark);
      counts.emplace_back(0, 0);
      example.emplace_back();
      it = marks.end() - 1;
    }
    const auto k = static_cast<std::size_t>(it - marks.begin());
    ++counts[k].second;
    if (p.at_bound && counts[k].first++ == 0)
      example[k] = fmt::format("{} = {:g}", p.name, p.value);
  }
  for (std::size_t k = 0; k < marks.size(); ++k)
    if (counts[k].first > 0)
      out.push_back(fmt::format("{} is at a bound of its range at {} of {} channels (e.g. {}): "
                                "no estimate there; the model may not describe the data",
                                marks[k], counts[k].first, counts[k].second, example[k]));
}

// Covariance (JᵀJ)⁻¹ through the unit-diagonal information matrix N = D⁻¹JᵀJD⁻¹, whose
// small eigenvalues are the directions the data do not constrain.
struct Information {
  Eigen::VectorXd d;       // D: the square roots of JᵀJ's diagonal
  Eigen::VectorXd lambda;  // N's eigenvalues, ascending
  Eigen::MatrixXd V;       // and eigenvectors
  Eigen::MatrixXd cov;     // scaled by max(1, χ²/dof)
  std::vector<bool> flat;  // parameters in a flat direction (or with no information)
};

Information information(const Eigen::MatrixXd& J, double chi2_per_dof) {
  const std::size_t n = static_cast<std::size_t>(J.cols());
  Information in;
  const Eigen::MatrixXd info = J.transpose() * J;
  auto& d = in.d;
  d.resize(J.cols());
  for (Eigen::Index j = 0; j < d.size(); ++j) d(j) = info(j, j) > 0 ? std::sqrt(info(j, j)) : 0;
  Eigen::MatrixXd N = Eigen::MatrixXd::Identity(d.size(), d.size());
  for (Eigen::Index a = 0; a < d.size(); ++a)
    for (Eigen::Index b = 0; b < d.size(); ++b)
      if (d(a) > 0 && d(b) > 0) N(a, b) = info(a, b) / (d(a) * d(b));
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(N);
  in.lambda = eig.eigenvalues();
  in.V = eig.eigenvectors();
  constexpr double kFlat = 1e-9;
  Eigen::MatrixXd Ninv = Eigen::MatrixXd::Zero(d.size(), d.size());
  in.flat.assign(n, false);
  for (Eigen::Index k = 0; k < in.lambda.size(); ++k) {
    if (in.lambda(k) > kFlat * static_cast<double>(n)) {
      Ninv += in.V.col(k) * in.V.col(k).transpose() / in.lambda(k);
    } else {
      for (Eigen::Index j = 0; j < d.size(); ++j)
        if (std::abs(in.V(j, k)) > 0.1) in.flat[static_cast<std::size_t>(j)] = true;
    }
  }
  for (std::size_t j = 0; j < n; ++j)
    if (d(static_cast<Eigen::Index>(j)) == 0) in.flat[j] = true;
  const double scale = std::max(1.0, chi2_per_dof);
  in.cov = Eigen::MatrixXd::Zero(d.size(), d.size());
  for (Eigen::Index a = 0; a < d.size(); ++a)
    for (Eigen::Index b = 0; b < d.size(); ++b)
      if (d(a) > 0 && d(b) > 0) in.cov(a, b) = scale * Ninv(a, b) / (d(a) * d(b));
  return in;
}

// A model that misses leaves residuals with a shape of its own, alike in every channel of a
// geometry and between neighbouring geometries, which √(χ²/dof) treats as independent noise.
// The cluster-robust ("sandwich") covariance by geometry (White, Econometrica 50 (1982) 1;
// Liang & Zeger, Biometrika 73 (1986) 13) takes the scatter of each geometry's pull on the
// parameters instead: A⁻¹ B A⁻¹ with A = JᵀJ and B = Σ_g (J_gᵀ z_g)(J_gᵀ z_g)ᵀ, times
// G/(G − n) for G geometries. Each parameter's variance becomes the larger of the two,
// keeping the scaled covariance's correlations.
void widen_for_misfit(const Eigen::MatrixXd& J, const std::vector<double>& z, std::size_t channels,
                      double chi2_per_dof, Information& in) {
  const Eigen::Index n = J.cols();
  const std::size_t groups = channels == 0 ? 0 : z.size() / channels;
  if (groups <= static_cast<std::size_t>(n) || groups * channels != z.size()) return;
  const Eigen::MatrixXd Ainv = in.cov / std::max(1.0, chi2_per_dof);
  Eigen::MatrixXd B = Eigen::MatrixXd::Zero(n, n);
  for (std::size_t g = 0; g < groups; ++g) {
    const auto rows = static_cast<Eigen::Index>(channels), first = static_cast<Eigen::Index>(g * channels);
    const Eigen::Map<const Eigen::VectorXd> zg(z.data() + first, rows);
    const Eigen::VectorXd s = J.middleRows(first, rows).transpose() * zg;
    B.noalias() += s * s.transpose();
  }
  const double small = static_cast<double>(groups) / static_cast<double>(groups - static_cast<std::size_t>(n));
  const Eigen::MatrixXd robust = small * Ainv * B * Ainv;
  Eigen::VectorXd widen = Eigen::VectorXd::Ones(n);
  for (Eigen::Index j = 0; j < n; ++j)
    if (in.cov(j, j) > 0 && robust(j, j) > in.cov(j, j)) widen(j) = std::sqrt(robust(j, j) / in.cov(j, j));
  in.cov = widen.asDiagonal() * in.cov * widen.asDiagonal();
}

std::vector<std::vector<double>> correlation_of(const Eigen::MatrixXd& cov) {
  const auto n = static_cast<std::size_t>(cov.rows());
  std::vector<std::vector<double>> rho(n, std::vector<double>(n, 0.0));
  for (std::size_t a = 0; a < n; ++a) {
    for (std::size_t b = 0; b < n; ++b) {
      const auto A = static_cast<Eigen::Index>(a), B = static_cast<Eigen::Index>(b);
      const double den = std::sqrt(cov(A, A) * cov(B, B));
      rho[a][b] = a == b ? 1.0 : (den > 0 ? cov(A, B) / den : 0.0);
    }
  }
  return rho;
}

// χ² at the optimum (and, for `at`, the values and normalised residuals there).
double chi2_at(const Evaluator::State& state, const Problem& problem, Optimum* at) {
  const std::size_t m = state.beta.size();
  double chi2 = 0;
  for (std::size_t i = 0; i < m; ++i) {
    const double z = (state.beta[i] - problem.measured[i]) / state.sigma[i];
    chi2 += z * z;
  }
  if (at != nullptr) {
    at->beta = state.beta;
    at->z.resize(m);
    for (std::size_t i = 0; i < m; ++i)
      at->z[i] = (state.beta[i] - problem.measured[i]) / state.sigma[i];
  }
  return chi2;
}

// Each parameter's value, uncertainty and flags; a warning for each one not identifiable.
void add_parameters(const Problem& problem, const std::vector<double>& x, const Eigen::VectorXd& y,
                    const Information& in, FitResult& r) {
  for (std::size_t j = 0; j < x.size(); ++j) {
    const auto& p = problem.params[j];
    FittedParameter fp;
    fp.name = p.name;
    fp.value = x[j];
    fp.start = p.start, fp.lo = p.lo, fp.hi = p.hi;
    // Within half a percent of the range (in the fitting coordinate, log for log-scale
    // parameters) of a bound: the optimiser may stop just short of the bound it is
    // pressing against, and such a value is no estimate either.
    const double t = 0.5 * (1 + std::sin(y(static_cast<Eigen::Index>(j))));
    fp.at_bound = t < kBoundMargin || t > 1 - kBoundMargin;
    fp.identifiable = !in.flat[j];
    const double var = in.cov(static_cast<Eigen::Index>(j), static_cast<Eigen::Index>(j));
    fp.u = in.flat[j] ? std::numeric_limits<double>::quiet_NaN() : std::sqrt(var);
    if (in.flat[j])
      r.warnings.push_back(fmt::format("{} is not identifiable: the data do not constrain it "
                                       "(a flat direction of chi2)", p.name));
    r.parameters.push_back(fp);
  }
}

// Pairs correlated beyond options.correlation_limit are not identifiable either.
void correlation_warnings(const Problem& problem, const Information& in, double limit,
                          FitResult& r) {
  const std::size_t n = r.parameters.size();
  for (std::size_t a = 0; a < n; ++a)
    for (std::size_t b = a + 1; b < n; ++b)
      if (std::abs(r.correlation[a][b]) > limit && !in.flat[a] && !in.flat[b]) {
        r.parameters[a].identifiable = r.parameters[b].identifiable = false;
        r.warnings.push_back(fmt::format("{} and {} are correlated (rho = {:.3f}): the data "
                                         "hardly separate them", problem.params[a].name,
                                         problem.params[b].name, r.correlation[a][b]));
      }
}

// Directions along which χ² hardly changes, in parameters scaled by their information.
void add_degeneracies(const Problem& problem, const Information& in, double limit, FitResult& r) {
  const std::size_t n = r.parameters.size();
  for (Eigen::Index k = 0; k < in.lambda.size(); ++k) {
    if (in.lambda(k) >= 1 - limit || n < 2) continue;
    Degeneracy dg;
    dg.eigenvalue = std::max(0.0, in.lambda(k));
    for (Eigen::Index j = 0; j < in.d.size(); ++j)
      if (std::abs(in.V(j, k)) > 0.05)
        dg.combination.emplace_back(problem.params[static_cast<std::size_t>(j)].name, in.V(j, k));
    if (dg.combination.size() >= 2) {
      std::string text;
      for (const auto& [name, c] : dg.combination)
        text += fmt::format("{}{:+.2f}·{}", text.empty() ? "" : " ", c, name);
      r.warnings.push_back(fmt::format("the data cannot separate the combination {} "
                                       "(eigenvalue {:.2g} of the normalised information)",
                                       text, dg.eigenvalue));
    }
    r.degenerate.push_back(std::move(dg));
  }
}

}  // namespace

FitResult solve(const Problem& problem, const FitOptions& options, Optimum* at) {
  Evaluator ev(problem);
  const std::size_t n = ev.n(), m = ev.m();
  if (n == 0) throw Error::invalid("model", "no free parameter");
  if (m <= n)
    throw Error::invalid("measured", fmt::format("{} measured values cannot determine {} "
                                                 "parameters", m, n));
  Functor functor(ev, problem);
  Eigen::VectorXd y(static_cast<Eigen::Index>(n));
  for (std::size_t j = 0; j < n; ++j)
    y(static_cast<Eigen::Index>(j)) = ev.bounds()[j].to_y(problem.params[j].start);

  Eigen::LevenbergMarquardt<Functor> lm(functor);
  lm.setXtol(options.tolerance);
  lm.setFtol(options.tolerance);
  lm.setMaxfev(static_cast<Eigen::Index>(options.max_iterations) * 2);
  const auto status = lm.minimize(y);

  FitResult r;
  r.iterations = functor.jacobians;
  r.status = status_text(status);
  r.converged = converged_status(status);
  if (!r.converged) r.warnings.push_back("the optimiser did not converge: " + r.status);

  // The optimum in x, its χ², and the Jacobian there.
  std::vector<double> x(n);
  for (std::size_t j = 0; j < n; ++j) x[j] = ev.bounds()[j].to_x(y(static_cast<Eigen::Index>(j)));
  Optimum here;
  r.chi2 = chi2_at(ev.at(x), problem, &here);
  r.dof = static_cast<long>(m) - static_cast<long>(n);
  r.chi2_per_dof = r.chi2 / static_cast<double>(r.dof);
  // The optimiser's last Jacobian is reused when it was taken at the optimum.
  const Eigen::MatrixXd J =
      functor.last_x == x ? functor.last_jx : ev.jacobian(x, std::vector<double>(n, 1.0));
  r.evaluations = ev.evaluations();

  Information in = information(J, r.chi2_per_dof);
  if (r.chi2_per_dof > options.misfit_limit) widen_for_misfit(J, here.z, problem.channels, r.chi2_per_dof, in);
  if (at != nullptr) *at = std::move(here);
  r.correlation = correlation_of(in.cov);
  add_parameters(problem, x, y, in, r);
  bound_warnings(r.parameters, problem.channel, r.warnings);
  correlation_warnings(problem, in, options.correlation_limit, r);
  add_degeneracies(problem, in, options.correlation_limit, r);
  return r;
}

std::vector<double> global_start(const Problem& problem, const FitOptions& options) {
  const std::size_t n = problem.params.size();
  std::vector<double> best(n);
  for (std::size_t j = 0; j < n; ++j) best[j] = problem.params[j].start;
  std::vector<std::size_t> scalar;  // the parameters that act on every channel
  for (std::size_t j = 0; j < n; ++j)
    if (problem.channel[j] < 0) scalar.push_back(j);
  if (scalar.empty() || options.starts <= 1) return best;

  auto quick = options;
  quick.max_iterations = 4;
  double best_chi2 = std::numeric_limits<double>::infinity();
  const auto& sobol = detail::SobolTable::get(static_cast<std::uint64_t>(options.starts) + 1);
  for (int c = 0; c < options.starts; ++c) {
    auto p = problem;
    // Candidate 0 is the given start; the others are Sobol points 1, 2, … (point 1 is the
    // centre of the box), kept 2 % away from the bounds.
    if (c > 0) {
      for (std::size_t d = 0; d < scalar.size(); ++d) {
        auto& q = p.params[scalar[d]];
        const std::uint32_t raw =
            d < static_cast<std::size_t>(detail::kSobolDims)
                ? sobol[static_cast<std::size_t>(c) * detail::kSobolDims + d]
                : static_cast<std::uint32_t>(detail::mix64(c * 0x9E3779B97F4A7C15ull + d) >> 32);
        const double t = 0.02 + 0.96 * (raw / 4294967296.0);
        const bool log = q.log_scale && q.lo > 0;
        const double a = log ? std::log(q.lo) : q.lo, b = log ? std::log(q.hi) : q.hi;
        const double v = a + (b - a) * t;
        q.start = std::clamp(log ? std::exp(v) : v, q.lo, q.hi);
      }
    }
    FitResult r;
    try {
      r = solve(p, quick);
    } catch (const Error&) {
      continue;  // a candidate where the model fails is no start
    }
    if (!(r.chi2 < best_chi2)) continue;
    best_chi2 = r.chi2;
    for (std::size_t j = 0; j < n; ++j) {
      const auto& q = problem.params[j];
      // Just inside the bounds: the sine transformation has no gradient on them.
      const double margin = 1e-3 * (q.hi - q.lo);
      best[j] = std::clamp(r.parameters[j].value, q.lo + margin, q.hi - margin);
    }
  }
  return best;
}

}  // namespace gonio::twin::fit
