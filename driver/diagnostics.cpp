#include "driver/diagnostics.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <functional>
#include <limits>
#include <numbers>

#include "driver/simulation.hpp"
#include "lib/error.hpp"
#include "lib/statistics.hpp"

namespace jamflow::diagnostics {

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
}  // namespace

double lag1_autocorrelation(const std::vector<double>& x) {
  const std::size_t n = x.size();
  if (n < 3)
    return 0.0;
  double m = 0.0;
  for (double v : x)
    m += v;
  m /= double(n);
  double num = 0.0, den = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    den += (x[i] - m) * (x[i] - m);
    if (i + 1 < n)
      num += (x[i] - m) * (x[i + 1] - m);
  }
  return den > 0.0 ? num / den : 0.0;
}

std::vector<double> increments(const std::vector<double>& x) {
  std::vector<double> d;
  if (x.size() < 2)
    return d;
  d.reserve(x.size() - 1);
  for (std::size_t i = 1; i < x.size(); ++i)
    d.push_back(x[i] - x[i - 1]);
  return d;
}

// ---- Paired comparison ---------------------------------------------------------------------

// Error of the mean difference a - b over the averaging window, from block averages of the
// paired difference series (same sample times: the runs share start state, seed and sampling
// grid, so their fluctuations are correlated as long as the trajectories stay close).
// NaN if the sample times do not match.
double paired_error(const Series& a, const Series& b, double t_eq, double Sample::*field,
                    std::size_t blocks) {
  std::vector<double> d;
  std::size_t ia = 0, ib = 0;
  const double tol = 1e-6;
  while (ia < a.samples.size() && a.samples[ia].time <= t_eq + tol)
    ++ia;
  while (ib < b.samples.size() && b.samples[ib].time <= t_eq + tol)
    ++ib;
  if (a.samples.size() - ia != b.samples.size() - ib)
    return kNaN;
  for (; ia < a.samples.size(); ++ia, ++ib) {
    if (std::abs(a.samples[ia].time - b.samples[ib].time) > tol * std::max(1.0, a.samples[ia].time))
      return kNaN;
    d.push_back(a.samples[ia].*field - b.samples[ib].*field);
  }
  if (d.size() < blocks)
    return kNaN;
  return block_average(d, blocks).error;
}

// ---- Lanes ----------------------------------------------------------------------------------

void LaneAccumulator::add(const State& state) {
  const std::size_t n = state.size();
  if (n == 0)
    return;
  if (s_sum_.empty()) {
    if (m_max_ <= 0) {
      const double l = std::min(state.box.ly, state.box.lz);
      m_max_ = std::clamp(static_cast<int>(std::ceil(l / 0.7)), 1, 32);
    }
    n_ = n;
    s_sum_.assign(std::size_t(2 * m_max_ + 1) * std::size_t(m_max_ + 1), 0.0);
  }
  const int m = m_max_;
  const std::size_t ny = std::size_t(2 * m + 1);
  std::vector<std::complex<double>> rho(s_sum_.size(), {0.0, 0.0});
  std::vector<std::complex<double>> py(ny);
  const double two_pi = 2.0 * std::numbers::pi;
  const double* sy = state.y();
  const double* sz = state.z();
  for (std::size_t j = 0; j < n; ++j) {
    const std::complex<double> ey = std::polar(1.0, two_pi * sy[j]);
    const std::complex<double> ez = std::polar(1.0, two_pi * sz[j]);
    // py[m + k] = ey^k for k in [-m, m]
    py[std::size_t(m)] = 1.0;
    for (int k = 1; k <= m; ++k) {
      py[std::size_t(m + k)] = py[std::size_t(m + k - 1)] * ey;
      py[std::size_t(m - k)] = std::conj(py[std::size_t(m + k)]);
    }
    std::complex<double> pz = 1.0;
    for (int mz = 0; mz <= m; ++mz) {
      std::complex<double>* row = rho.data() + std::size_t(mz) * ny;
      for (std::size_t k = 0; k < ny; ++k)
        row[k] += py[k] * pz;
      pz *= ez;
    }
  }
  for (std::size_t k = 0; k < rho.size(); ++k)
    s_sum_[k] += std::norm(rho[k]) / double(n);
  ++snapshots_;
}

std::size_t LaneAccumulator::peak_index() const {
  const int m = m_max_;
  const std::size_t ny = std::size_t(2 * m + 1);
  std::size_t best = 0;
  double best_v = -1.0;
  for (int mz = 0; mz <= m; ++mz) {
    for (int my = -m; my <= m; ++my) {
      if (mz == 0 && my <= 0)
        continue;  // k = 0 and the mirrored half line
      const std::size_t k = std::size_t(mz) * ny + std::size_t(my + m);
      if (s_sum_[k] > best_v) {
        best_v = s_sum_[k];
        best = k;
      }
    }
  }
  return best;
}

double LaneAccumulator::order() const {
  if (snapshots_ == 0 || n_ == 0)
    return 0.0;
  return s_sum_[peak_index()] / double(snapshots_) / double(n_);
}

int LaneAccumulator::peak_my() const {
  if (snapshots_ == 0)
    return 0;
  return static_cast<int>(peak_index() % std::size_t(2 * m_max_ + 1)) - m_max_;
}

int LaneAccumulator::peak_mz() const {
  if (snapshots_ == 0)
    return 0;
  return static_cast<int>(peak_index() / std::size_t(2 * m_max_ + 1));
}

void LaneAccumulator::add_velocity(const State& state, const std::vector<double>& force) {
  const std::size_t n = state.size();
  if (force.size() < 3 * n || n_bins_ < 1)
    return;
  if (v_sum_.empty()) {
    v_sum_.assign(std::size_t(n_bins_), 0.0);
    v_count_.assign(std::size_t(n_bins_), 0.0);
  }
  const double* sy = state.y();
  for (std::size_t j = 0; j < n; ++j) {
    const double s = sy[j] - std::floor(sy[j]);
    const auto b = std::min(std::size_t(n_bins_) - 1, static_cast<std::size_t>(s * n_bins_));
    v_sum_[b] += force[j] / kXiS;
    v_count_[b] += 1.0;
  }
  ly_sum_ += state.box.ly;
  ++v_snapshots_;
}

std::vector<double> LaneAccumulator::velocity_profile() const {
  std::vector<double> p(v_sum_.size(), kNaN);
  for (std::size_t b = 0; b < v_sum_.size(); ++b)
    if (v_count_[b] > 0.0)
      p[b] = v_sum_[b] / v_count_[b];
  return p;
}

double LaneAccumulator::velocity_amplitude(double gdot) const {
  if (v_snapshots_ == 0 || !(gdot > 0.0))
    return kNaN;
  const std::vector<double> p = velocity_profile();
  double s2 = 0.0;
  std::size_t k = 0;
  for (double v : p) {
    if (std::isfinite(v)) {
      s2 += v * v;
      ++k;
    }
  }
  if (k == 0)
    return kNaN;
  const double ly = ly_sum_ / double(v_snapshots_);
  return std::sqrt(s2 / double(k)) / (gdot * ly);
}

// ---- Window ---------------------------------------------------------------------------------

WindowResult diagnostic_window(const RunSpec& spec, const State& start,
                               const WindowOptions& options) {
  WindowResult w;
  ModelOptions mo = Simulation::model_options(spec);
  mo.threads = 1;
  Simulation sim(spec, spec.seed, start, mo);
  const Integrator& integ = sim.integrator();
  w.adaptive = !(integ.nominal_dt() > 0.0);
  w.step = !w.adaptive                   ? integ.nominal_dt()
           : options.adaptive_step > 0.0 ? options.adaptive_step
                                         : spec.sample_every / 16.0;
  StepCorrelation corr(3);
  LaneAccumulator lanes;
  lanes.add(start);
  const int snap_every = std::max(1, options.steps / std::max(1, options.lane_snapshots));
  const std::size_t n = start.size();
  std::vector<double> f(3 * n);
  // The window is the time loop with one sample per step (the nominal dt, or `step` for an
  // adaptive integrator): this observer records the forces and observables at each.
  struct Recorder final : LoopObserver {
    std::function<void(long long)> at;
    int steps = 0;
    bool proceed(Simulation&, long long k) override { return k <= steps; }
    void sampled(Simulation&, long long k, double) override { at(k); }
  } recorder;
  recorder.steps = options.steps;
  recorder.at = [&](long long k) {
    Model& model = sim.model();
    const Evaluation& ev = model.evaluate();
    const State& s = model.state();
    w.steps_done = static_cast<std::size_t>(k);
    for (std::size_t i = 0; i < n; ++i) {
      const auto id = static_cast<std::size_t>(s.id[i]);
      for (std::size_t c = 0; c < 3; ++c)
        f[3 * id + c] = ev.forces.force[c * n + i];
    }
    corr.add(f);
    w.sigma_xy.push_back(ev.sigma_xy);
    w.pressure.push_back(ev.pressure);
    w.dissipation.push_back(ev.dissipation);
    if (k > 0 && k % snap_every == 0) {
      lanes.add(s);
      lanes.add_velocity(s, ev.forces.force);
    }
  };
  try {
    recorder.at(0);
    sim.run(w.step, 1, {&recorder});
  } catch (const IntegrationError& e) {
    w.status = RunStatus::failed("at step " + std::to_string(w.steps_done) + ": " + e.what());
  }
  w.finite = corr.finite();
  for (const auto* series : {&w.sigma_xy, &w.pressure, &w.dissipation})
    for (double v : *series)
      if (!std::isfinite(v))
        w.finite = false;
  w.force_correlation = corr.correlation();
  w.alternating_share = corr.alternating_share();
  w.reversed_fraction = corr.reversed_fraction();
  w.dsigma_lag1 = lag1_autocorrelation(increments(w.sigma_xy));
  w.dpressure_lag1 = lag1_autocorrelation(increments(w.pressure));
  double d = 0.0;
  for (double v : w.dissipation)
    d += v;
  w.mean_dissipation = w.dissipation.empty() ? kNaN : d / double(w.dissipation.size());
  w.lane_order = lanes.order();
  w.lane_my = lanes.peak_my();
  w.lane_mz = lanes.peak_mz();
  w.velocity_amplitude = lanes.velocity_amplitude(spec.shear_rate);
  return w;
}

// ---- Classification -------------------------------------------------------------------------

std::string verdict_name(Verdict v) {
  switch (v) {
    case Verdict::kStable:
      return "stable";
    case Verdict::kOscillating:
      return "oscillating";
    case Verdict::kDiverged:
      return "diverged";
    case Verdict::kNotAvailable:
      return "not available";
    case Verdict::kIncomplete:
      return "incomplete";
    case Verdict::kNotSteady:
      return "not steady";
    case Verdict::kCorrelated:
      return "correlated";
  }
  return "?";
}

namespace {
std::string g3(double v) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}
}  // namespace

Classification classify(const ReplicaResult& result, const EnergyBalance& balance,
                        const WindowResult* window, const Thresholds& th) {
  Classification c;
  if (result.status.is_budget()) {
    c.verdict = Verdict::kIncomplete;
    c.reason = result.status.detail + ", the study's budget";
    return c;
  }
  // Stopped by a signal with its checkpoint kept: not finished yet, which says nothing about
  // stability (the same command again continues it).
  if (result.status.is_interrupted()) {
    c.verdict = Verdict::kIncomplete;
    c.reason = "not finished: " + result.status.text() + "; the same command again continues it";
    return c;
  }
  if (!result.status.is_complete()) {
    c.verdict = Verdict::kDiverged;
    c.reason = result.status.text();
    return c;
  }
  for (const Sample& s : result.series.samples) {
    for (double v : {s.volume, s.pressure, s.sigma_xy, s.energy, s.dissipation}) {
      if (!std::isfinite(v)) {
        c.verdict = Verdict::kDiverged;
        c.reason = "non-finite sample at t = " + g3(s.time);
        return c;
      }
    }
  }
  if (window) {
    if (!window->status.is_complete() || !window->finite) {
      c.verdict = Verdict::kDiverged;
      c.reason = "diagnostic window " + (!window->status.is_complete() ? window->status.text()
                                                                       : std::string("non-finite"));
      return c;
    }
    c.laned = window->lane_order >= th.lane_order_min;
  }
  std::vector<std::string> why;
  if (window && window->steps_done >= 2 && window->force_correlation < th.force_correlation_min) {
    why.push_back("period-2: force step correlation " + g3(window->force_correlation));
  }
  // Only a deficit (dissipation inflated beyond the work done) is the oscillation signature;
  // an excess is an accuracy error, reported by the studies, not an instability.
  // An adaptive integrator has no fixed step to alternate with: its energy-balance error is
  // an accuracy error (reported by the studies), not the oscillation signature.
  const bool adaptive = window && window->adaptive;
  // An undefined balance (no dissipation: a contact-free gas) is no evidence of oscillation.
  if (balance.valid && !adaptive) {
    const double allowed = std::max(th.balance_tolerance, th.balance_sigmas * balance.error);
    if (1.0 - balance.ratio > allowed)
      why.push_back("energy balance " + g3(balance.ratio) + " ± " + g3(balance.error));
  }
  if (!why.empty()) {
    c.verdict = Verdict::kOscillating;
    for (std::size_t k = 0; k < why.size(); ++k)
      c.reason += (k ? "; " : "") + why[k];
  } else {
    c.verdict = Verdict::kStable;
    c.reason = (balance.valid ? "energy balance " + g3(balance.ratio) + " ± " + g3(balance.error)
                              : std::string("energy balance undefined (no dissipation)")) +
               (window ? ", force step correlation " + g3(window->force_correlation) : "");
  }
  return c;
}

}  // namespace jamflow::diagnostics
