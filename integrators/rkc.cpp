// Second-order Runge–Kutta–Chebyshev (rkc.hpp).
#include "integrators/rkc.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>

#include "integrators/motion.hpp"
#include "integrators/registry.hpp"
#include "lib/error.hpp"

namespace jamflow {

namespace {

constexpr double kDamping = 2.0 / 13.0;
// h rho <= beta(s) ~ 0.653 (s^2 - 1), so s^2 >= 1 + 1.54 h rho (Sommeijer et al.'s choice).
constexpr double kStageFactor = 1.54;
// Power iteration: at most this many force differences, stopping when two successive
// estimates differ by less than kDomEigTolerance relative.
constexpr int kDomEigIterations = 50;
constexpr double kDomEigTolerance = 0.01;
// Step control: h_new = kSafety err^(-1/2) h. The local error of a smooth second-order step goes
// as h^3, but near jamming the steps are limited by contacts that open and close within them,
// where the force is not smooth, and the measured error grows about as h (h = 3.7, 5.8, 11 and
// 27 gave err = 1.4, 2.0, 3.5 and 7.6). With the h^3 law (err^(-1/3), safety 0.8) and the RKC
// code's predictive controller, 31% of steps were rejected at N = 1000, J = 0.1, P = 1e-5; with
// err^(-1/2) and 0.7, 14%, and 22% fewer force passes per tau_0 (1.31 against 1.68).
constexpr double kSafety = 0.7;
// Rejections in a row that end the run: the step has shrunk by 0.1^kMaxRejections at least.
constexpr int kMaxRejections = 60;

using Vec = Eigen::Map<Eigen::VectorXd>;
using ConstVec = Eigen::Map<const Eigen::VectorXd>;

double pressure_scale(const Ensemble& ensemble, const Evaluation& ev) {
  if (const auto p = ensemble.imposed_pressure())
    return *p;
  return ev.pressure;
}

// A fixed pseudo-random vector (splitmix64 of the index) in [-1, 1): the power iteration's start
// depends on nothing but the size.
double start_component(std::size_t k) {
  std::uint64_t z = 0x9E3779B97F4A7C15ull * (std::uint64_t(k) + 1);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  z ^= z >> 31;
  return double(z >> 11) * 0x1.0p-52 - 1.0;
}

// Power iteration on (f(dv) - f(0)) / |dv| about the system's reference, with |dv| = `norm`.
double power_iteration(EquationOfMotion& sys, double t0, const std::vector<double>& f0, double norm,
                       long long* evaluations) {
  const std::size_t n = sys.size();
  std::vector<double> v(n), fv(n);
  for (std::size_t k = 0; k < n; ++k)
    v[k] = start_component(k);
  Vec(v.data(), Eigen::Index(n)) *= norm / Vec(v.data(), Eigen::Index(n)).norm();
  double sigma = 0.0, last = 0.0;
  for (int it = 0; it < kDomEigIterations; ++it) {
    sys.rhs(t0, v.data(), fv.data());
    ++*evaluations;
    Vec d(fv.data(), Eigen::Index(n));
    d -= ConstVec(f0.data(), Eigen::Index(n));
    const double dn = d.norm();
    if (!(dn > 0.0) || !std::isfinite(dn))
      break;
    sigma = dn / norm;
    if (it > 0 && std::abs(sigma - last) <= kDomEigTolerance * sigma)
      break;
    last = sigma;
    Vec(v.data(), Eigen::Index(n)) = d * (norm / dn);
  }
  return sigma;
}

// The perturbation of the power iteration: a thousandth of the overlap, in box lengths, so that
// contacts stay in their linear range.
double perturbation(const Model& model, double pressure) {
  const double l = std::cbrt(model.state().box.volume());
  return 1e-3 * typical_overlap(pressure, model.force_field().alpha()) / l;
}

}  // namespace

void RkcOptions::validate() const {
  if (!(rtol > 0.0 && rtol < 1.0))
    throw ConfigError("[integrator] rtol = " + fmt(rtol) + " is out of range; allowed (0, 1)");
  if (atol && !(*atol > 0.0 && std::isfinite(*atol)))
    throw ConfigError("[integrator] atol = " + fmt(*atol) + " is out of range; allowed > 0");
  if (max_stages < 2 || max_stages > 10000)
    throw ConfigError("[integrator] max_stages = " + std::to_string(max_stages) +
                      " is out of range; allowed [2, 10000]");
  if (!(dom_eig_safety >= 1.0 && std::isfinite(dom_eig_safety)))
    throw ConfigError("[integrator] dom_eig_safety = " + fmt(dom_eig_safety) +
                      " is out of range; allowed >= 1");
  if (dom_eig_frequency < 1)
    throw ConfigError("[integrator] dom_eig_frequency = " + std::to_string(dom_eig_frequency) +
                      " is out of range; allowed >= 1");
}

double rkc_default_atol(double pressure, double alpha) {
  return 1e-2 * typical_overlap(pressure, alpha);
}

RkcCoefficients rkc_coefficients(int s) {
  if (s < 2)
    throw std::logic_error("RKC needs at least 2 stages");
  const double w0 = 1.0 + kDamping / (double(s) * double(s));
  std::vector<double> t(s + 1), dt(s + 1), ddt(s + 1);
  t[0] = 1.0;
  t[1] = w0;
  dt[0] = 0.0;
  dt[1] = 1.0;
  ddt[0] = 0.0;
  ddt[1] = 0.0;
  for (int j = 2; j <= s; ++j) {
    t[j] = 2.0 * w0 * t[j - 1] - t[j - 2];
    dt[j] = 2.0 * t[j - 1] + 2.0 * w0 * dt[j - 1] - dt[j - 2];
    ddt[j] = 4.0 * dt[j - 1] + 2.0 * w0 * ddt[j - 1] - ddt[j - 2];
  }
  const double w1 = dt[s] / ddt[s];
  std::vector<double> b(s + 1);
  for (int j = 2; j <= s; ++j)
    b[j] = ddt[j] / (dt[j] * dt[j]);
  b[0] = b[1] = b[2];
  RkcCoefficients c;
  c.mu.assign(s + 1, 0.0);
  c.nu.assign(s + 1, 0.0);
  c.mu_tilde.assign(s + 1, 0.0);
  c.gamma_tilde.assign(s + 1, 0.0);
  c.c.assign(s + 1, 0.0);
  c.mu_tilde[1] = b[1] * w1;
  for (int j = 2; j <= s; ++j) {
    const double a_prev = 1.0 - b[j - 1] * t[j - 1];
    c.mu[j] = 2.0 * b[j] * w0 / b[j - 1];
    c.nu[j] = -b[j] / b[j - 2];
    c.mu_tilde[j] = 2.0 * b[j] * w1 / b[j - 1];
    c.gamma_tilde[j] = -a_prev * c.mu_tilde[j];
    c.c[j] = w1 * ddt[j] / dt[j];
  }
  c.c[1] = c.c[2] / dt[2];
  c.c[s] = 1.0;
  c.beta = (w0 + 1.0) * ddt[s] / dt[s];
  return c;
}

double rkc_spectral_radius(Model& model, const Ensemble& ensemble, long long* evaluations) {
  const double dv = perturbation(model, pressure_scale(ensemble, model.evaluate()));
  EquationOfMotion sys(model, ensemble, false);
  std::vector<double> f0(sys.size());
  sys.rhs_at_reference(f0.data());
  const double t0 = model.state().time;
  const double rho = power_iteration(sys, t0, f0, dv, evaluations);
  // Leave the model at its state (the last force difference moved it).
  std::vector<double> zero(sys.size(), 0.0);
  sys.apply(t0, zero.data());
  return rho;
}

// Work vectors, kept between calls so that steps do not allocate.
struct Rkc::Work {
  std::vector<double> f0, f1, y0, y1, y2, fj, weight, est;
  void resize(std::size_t n) {
    for (auto* v : {&f0, &f1, &y0, &y1, &y2, &fj, &weight, &est})
      v->assign(n, 0.0);
  }
};

Rkc::Rkc(const RkcOptions& options) : options_(options), work_(std::make_unique<Work>()) {
  options_.validate();
}

Rkc::~Rkc() = default;

void Rkc::reset() {
  need_dom_eig_ = true;
}

void Rkc::advance(Model& model, const Ensemble& ensemble, double t_end) {
  Work& w = *work_;
  // Another state than the one this integrator left (a restart, another integrator, an edited
  // state) is a discrete event. A fresh integrator goes by its (restored) need_dom_eig_.
  if (left_valid_ && model.state().time != left_time_)
    need_dom_eig_ = true;
  const double gdot = ensemble.shear_rate();
  while (model.state().time < t_end && !interrupted()) {
    const std::int64_t flips = model.state().box.flips;
    model.prepare_step();
    if (model.state().box.flips != flips)
      need_dom_eig_ = true;  // a remap: the same physics, but a discrete event of the cell
    // Evaluated before the reference is taken, so that no list wrap comes after it; the pressure
    // scale of the tolerances is this state's (the stages overwrite the model's evaluation).
    const double p_scale = pressure_scale(ensemble, model.evaluate());
    const double t0 = model.state().time;
    double t_stop = t_end;
    EquationOfMotion sys(model, ensemble, false);
    if (gdot != 0.0)
      t_stop = std::min(t_stop, sys.remap_time(t0, model.state().box.volume()));
    const std::size_t n = sys.size();
    const auto N = Eigen::Index(n);
    if (w.f0.size() != n)
      w.resize(n);
    sys.rhs_at_reference(w.f0.data());

    // Error weights: atol in box lengths for each particle, 3 atol / l for the relative volume.
    const double l = std::cbrt(model.state().box.volume());
    const double atol =
        options_.atol ? *options_.atol : rkc_default_atol(p_scale, model.force_field().alpha());
    const double atol_u = atol / l;
    const double atol_w = 3.0 * atol / l;
    const std::size_t np = 3 * model.state().size();

    int rejections = 0;
    bool fresh = false;  // rho was estimated at this step's start
    for (;;) {
      if (need_dom_eig_ && !fresh) {
        rho_ = power_iteration(sys, t0, w.f0, perturbation(model, p_scale), &dom_eig_evaluations_);
        if (!(rho_ > 0.0))
          rho_ = 1e-12;  // no contacts: any stage count is stable
        need_dom_eig_ = false;
        fresh = true;
        since_dom_eig_ = 0;
        ++dom_eig_estimates_;
      }
      const double rho = options_.dom_eig_safety * rho_;
      const double s_max = double(options_.max_stages);
      const double h_max = (s_max * s_max - 1.0) / (kStageFactor * rho);
      const double proposal = std::min(step_next_ > 0.0 ? step_next_ : 1.0 / rho, h_max);
      const double remaining = t_stop - t0;
      const bool to_stop = remaining <= 1.1 * proposal;
      const double h = to_stop ? remaining : proposal;
      const int s =
          std::clamp(int(1.0 + std::sqrt(1.0 + kStageFactor * h * rho)), 2, options_.max_stages);
      max_stages_used_ = std::max<long long>(max_stages_used_, s);
      const RkcCoefficients c = rkc_coefficients(s);
      const double t1 = to_stop ? t_stop : t0 + h;

      // Stages, with Y_0 = 0: Y_{j-2} in y0, Y_{j-1} in y1, Y_j into y2.
      double err = std::numeric_limits<double>::infinity();
      try {
        // Y_{j-2}, Y_{j-1} and Y_j rotate through three buffers.
        double* ym2 = w.y0.data();
        double* ym1 = w.y1.data();
        double* yj = w.y2.data();
        const ConstVec f0(w.f0.data(), N);
        const ConstVec fj(w.fj.data(), N);
        Vec(ym2, N).setZero();
        Vec(ym1, N) = (c.mu_tilde[1] * h) * f0;
        for (int j = 2; j <= s; ++j) {
          sys.rhs(t0 + c.c[j - 1] * h, ym1, w.fj.data());
          ++stage_evaluations_;
          Vec(yj, N) = c.mu[j] * ConstVec(ym1, N) + c.nu[j] * ConstVec(ym2, N) +
                       h * (c.mu_tilde[j] * fj + c.gamma_tilde[j] * f0);
          std::swap(ym2, ym1);
          std::swap(ym1, yj);
        }
        const ConstVec y1(ym1, N);
        // y_{n+1} = Y_s; F(y_{n+1}), the next step's F_0, for the error estimate.
        sys.rhs(t1, ym1, w.f1.data());
        ++stage_evaluations_;
        const ConstVec f1(w.f1.data(), N);
        Vec est(w.est.data(), N);
        est = (-12.0 * y1 + (6.0 * h) * (f0 + f1)) / 15.0;
        double sum = 0.0;
        for (std::size_t k = 0; k < n; ++k) {
          const double tol = (k < np ? atol_u : atol_w) + options_.rtol * std::abs(ym1[k]);
          const double e = w.est[k] / tol;
          sum += e * e;
        }
        err = std::sqrt(sum / double(n));
      } catch (const CellCollapse&) {
        throw;
      } catch (const IntegrationError&) {
        err = std::numeric_limits<double>::infinity();  // an unphysical stage: a rejection
      }

      if (!(err <= 1.0)) {
        ++rejected_;
        if (++rejections > kMaxRejections) {
          throw IntegrationError("RKC: " + std::to_string(rejections) +
                                 " rejected steps in a row at t = " + fmt(t0) + " (step " + fmt(h) +
                                 ")");
        }
        // kSafety err^(-1/2), at most 10x smaller; an unphysical stage: 10x smaller.
        const double fac = std::isfinite(err) ? std::max(0.1, kSafety / std::sqrt(err)) : 0.1;
        step_next_ = h * fac;
        // One rejection is the error control at work; a second in a row may be a stale rho, so
        // it is estimated anew (unless it was estimated at this very state, which would give
        // the same number). Re-estimating after every rejection spent 11% of all force passes
        // at N = 1000, J = 0.1, P = 1e-5, without changing the radius.
        need_dom_eig_ = !fresh && rejections >= 2;
        continue;
      }

      // Accepted: kSafety err^(-1/2), kept in [0.1, 10]; no growth right after a rejection.
      double next = h * std::clamp(kSafety / std::sqrt(err), 0.1, 10.0);
      if (rejections > 0)
        next = std::min(next, h);
      // A step cut short by its end is no guide to the next: the proposal stays.
      const bool cut = to_stop && h < proposal;
      if (cut)
        next = std::max(next, proposal);
      step_next_ = next;
      step_last_ = h;
      error_last_ = err;
      ++steps_;
      if (++since_dom_eig_ >= options_.dom_eig_frequency)
        need_dom_eig_ = true;
      break;
    }
    left_valid_ = true;
    left_time_ = model.state().time;
  }
}

double Rkc::force_passes_per_time(const Ensemble& /*ensemble*/) const {
  return std::numeric_limits<double>::quiet_NaN();
}

// CPU time per tau_0 at N = 1000, alpha_r = 2, constant pressure, one thread
// (benchmarks/README.md, "Time to science"): at atol = delta 7.3-7.7 us for P = 1e-5 (J = 0.1 to
// 1e-3) and 20.7 us at P = 1e-3, J = 0.1; at atol = 0.01 delta 22-22.5 and 78.8 us. The timestep
// study's standard runs agree (21-74 us at P = 1e-3, J = 0.1) and cost 1.4-3x more at J = 1:
// about P^0.21 (atol / delta)^-0.26 max(1, J / 0.1)^0.4. Below J = 0.1 the cost is flat in J at
// atol = delta (the benchmark), but at atol = 0.1 delta it falls with J: the soft-rheology
// standard runs (N = 1000) went from 22.9 to 12.2 ns per particle and tau_0 between J = 0.1 and
// 0.01 at P = 1e-4, and the hard-sphere standard runs took 4.5 ns at P = 1e-5, J = 3e-4
// (3,015 and 2,933 CPU-s for t = 6.66e8) against 13.9 ns at J = 0.1: about (J / 0.1)^0.2,
// which this model takes in full from atol <= 0.1 delta and not at atol >= delta.
// Below alpha_r = 2 the contacts stiffen as delta^(alpha_r - 2) (cvode.cpp), and RKC's stages
// with them: the softness study's standard comparisons (N = 250, atol = 0.01-1 delta) cost
// 52-60x the harmonic model at alpha_r = 1.5, delta = 1e-4 (factor 100), 20-45x at delta = 0.03
// (5.8), 9.6-11x at alpha_r = 1.75, delta = 1e-4 (10) and 6.8-15x at delta = 0.03 (2.4). With
// the factor to the power 0.75 the model is still 1.7-1.9x below them at delta = 1e-4 and
// 3.5-12x below at delta = 0.03 (P = 0.07-0.17: high pressure, where at alpha_r = 2 too, P =
// 0.03, the runs cost 2.4-6.7x the model).
double Rkc::cpu_seconds_per_particle_time(const Ensemble& /*ensemble*/, const CostPoint& at) const {
  const double p = std::clamp(at.pressure, 1e-7, 1e-1);
  const double delta = typical_overlap(p, at.alpha);
  const double atol = options_.atol ? *options_.atol : rkc_default_atol(p, at.alpha);
  const double tolerance = std::clamp(atol / delta, 1e-4, 1e2);
  const double j = std::clamp(at.viscous_number() / 0.1, 1e-6, 1e6);
  const double slow = 0.2 * std::clamp(-std::log10(tolerance), 0.0, 1.0);  // exponent below 0.1
  const double stiffness = contact_stiffness_factor(p, at.alpha);
  return 7.7e-9 * std::pow(p / 1e-5, 0.21) * std::pow(tolerance, -0.26) *
         (j >= 1.0 ? std::pow(j, 0.4) : std::pow(j, slow)) * std::pow(stiffness, 0.75);
}

std::vector<std::pair<std::string, double>> Rkc::statistics() const {
  return {{"steps", double(steps_)},
          {"rejected_steps", double(rejected_)},
          {"stage_evaluations", double(stage_evaluations_)},
          {"dom_eig_estimates", double(dom_eig_estimates_)},
          {"dom_eig_evaluations", double(dom_eig_evaluations_)},
          {"max_stages_used", double(max_stages_used_)},
          {"spectral_radius", rho_},
          {"step_next", step_next_},
          {"step_last", step_last_},
          {"error_last", error_last_},
          {"steps_since_dom_eig", double(since_dom_eig_)},
          {"need_dom_eig", need_dom_eig_ ? 1.0 : 0.0}};
}

void Rkc::restore_statistics(const std::vector<std::pair<std::string, double>>& stats) {
  steps_ = static_cast<long long>(statistic(stats, "steps"));
  rejected_ = static_cast<long long>(statistic(stats, "rejected_steps"));
  stage_evaluations_ = static_cast<long long>(statistic(stats, "stage_evaluations"));
  dom_eig_estimates_ = static_cast<long long>(statistic(stats, "dom_eig_estimates"));
  dom_eig_evaluations_ = static_cast<long long>(statistic(stats, "dom_eig_evaluations"));
  max_stages_used_ = static_cast<long long>(statistic(stats, "max_stages_used"));
  rho_ = statistic(stats, "spectral_radius");
  step_next_ = statistic(stats, "step_next");
  step_last_ = statistic(stats, "step_last");
  error_last_ = statistic(stats, "error_last");
  since_dom_eig_ = static_cast<long long>(statistic(stats, "steps_since_dom_eig"));
  need_dom_eig_ = statistic(stats, "need_dom_eig", 1.0) != 0.0;
  left_valid_ = false;
}

namespace {

std::unique_ptr<Integrator> make_rkc(ConfigSection& section) {
  RkcOptions o;
  o.rtol = section.number("rtol", o.rtol, Range{0.0, 1.0, true, true});
  if (section.has("atol"))
    o.atol = section.number("atol", Range::positive());
  o.max_stages = static_cast<int>(section.integer("max_stages", o.max_stages, 2, 10000));
  o.dom_eig_safety = section.number("dom_eig_safety", o.dom_eig_safety, Range{1.0, 1e6});
  o.dom_eig_frequency =
      static_cast<int>(section.integer("dom_eig_frequency", o.dom_eig_frequency, 1, 1000000));
  return std::make_unique<Rkc>(o);
}

const IntegratorRegistrar registrar{
    "rkc", make_rkc, "Runge–Kutta–Chebyshev, second order, stabilized explicit (rtol, atol, ...)"};
}  // namespace

}  // namespace jamflow
