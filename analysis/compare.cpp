// Methodology comparison: paired differences against a reference, floor, cost, spreads, tau and
// the recommendation (analysis/compare.hpp).
#include "analysis/compare.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>

#include "analysis/error_model.hpp"

namespace jamflow::analysis {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// Mean and standard deviation (K - 1 in the denominator; 0 for one value).
struct MeanStd {
  double mean = kNaN, std = 0.0;
};
MeanStd mean_std(const std::vector<double>& x) {
  MeanStd m;
  if (x.empty())
    return m;
  m.mean = std::accumulate(x.begin(), x.end(), 0.0) / double(x.size());
  if (x.size() < 2)
    return m;
  double ss = 0.0;
  for (double v : x)
    ss += (v - m.mean) * (v - m.mean);
  m.std = std::sqrt(ss / double(x.size() - 1));
  return m;
}

// The error of a mean over replicas: their scatter from 3 replicas on, else the block errors
// propagated to the mean.
Estimate replica_mean(const std::vector<double>& means, const std::vector<double>& block_errors,
                      ErrorSource* source) {
  const MeanStd ms = mean_std(means);
  Estimate e{ms.mean, 0.0};
  if (means.size() >= std::size_t(kMinReplicasForScatter)) {
    e.error = ms.std / std::sqrt(double(means.size()));
    if (source)
      *source = ErrorSource::kReplicaScatter;
  } else {
    double ss = 0.0;
    for (double b : block_errors)
      ss += b * b;
    e.error = std::sqrt(ss) / double(block_errors.size());
    if (source)
      *source = ErrorSource::kBlocks;
  }
  return e;
}

Estimate ratio(const Estimate& a, const Estimate& b) {
  if (!(b.value != 0.0) || !std::isfinite(a.value) || !std::isfinite(b.value))
    return {kNaN, kNaN};
  const double r = a.value / b.value;
  const double ra = a.value != 0.0 ? a.error / a.value : 0.0;
  const double rb = b.error / b.value;
  return {r, std::abs(r) * std::hypot(ra, rb)};
}

// |x| / scale, 0 when x is 0 (also at scale 0), infinite when only the scale is 0.
double in_units(double x, double scale) {
  if (x == 0.0)
    return 0.0;
  return scale > 0.0 ? std::abs(x) / scale : kInf;
}

}  // namespace

const char* error_source_name(ErrorSource s) {
  switch (s) {
    case ErrorSource::kReplicaScatter:
      return "replica scatter";
    case ErrorSource::kBlocks:
      return "block errors";
    case ErrorSource::kNone:
      return "none";
  }
  return "?";
}

CompareResult compare(const CompareInput& in) {
  if (in.reference >= in.settings.size())
    throw std::invalid_argument("compare: the reference is not among the settings");
  const std::size_t n_obs = in.observables.size();
  for (const auto& s : in.settings) {
    if (!s.cpu_per_tau.empty() && s.observables.size() != n_obs)
      throw std::invalid_argument("compare: setting '" + s.label + "' lacks observables");
    for (const auto& o : s.observables)
      if (!s.cpu_per_tau.empty() && o.size() != s.cpu_per_tau.size())
        throw std::invalid_argument("compare: setting '" + s.label +
                                    "' has observables for another replica count");
  }
  const SettingInput& ref = in.settings[in.reference];
  const bool ref_ran = !ref.cpu_per_tau.empty();
  const std::size_t blocks = std::max<std::size_t>(in.blocks, 2);

  // Per observable: the reference's means, block errors, floor and spreads.
  struct RefObs {
    std::vector<double> means, errors;
    Estimate mean, block_std, replica_std;
  };
  auto spreads = [&](const std::vector<ReplicaObservable>& reps, Estimate& block_std,
                     Estimate& replica_std) {
    std::vector<double> bs, ms;
    for (const auto& r : reps) {
      bs.push_back(r.block_std);
      ms.push_back(r.mean);
    }
    const MeanStd b = mean_std(bs);
    block_std = {b.mean, reps.size() >= 2 ? b.std / std::sqrt(double(reps.size()))
                                          : b.mean / std::sqrt(2.0 * double(blocks - 1))};
    if (reps.size() >= 2) {
      const MeanStd m = mean_std(ms);
      replica_std = {m.std, m.std / std::sqrt(2.0 * double(reps.size() - 1))};
    } else {
      replica_std = {kNaN, kNaN};
    }
  };
  std::vector<RefObs> refs(n_obs);
  if (ref_ran) {
    for (std::size_t o = 0; o < n_obs; ++o) {
      for (const auto& r : ref.observables[o]) {
        refs[o].means.push_back(r.mean);
        refs[o].errors.push_back(r.block_error);
      }
      refs[o].mean = replica_mean(refs[o].means, refs[o].errors, nullptr);
      spreads(ref.observables[o], refs[o].block_std, refs[o].replica_std);
    }
  }

  CompareResult out;
  for (std::size_t si = 0; si < in.settings.size(); ++si) {
    const SettingInput& s = in.settings[si];
    SettingResult r;
    r.label = s.label;
    r.ensemble = s.ensemble;
    r.ran = !s.cpu_per_tau.empty() && !s.over_budget;
    r.over_budget = s.over_budget;
    r.stable = s.stable && r.ran;
    r.why_unstable = s.why_unstable;
    if (!r.ran && r.why_unstable.empty())
      r.why_unstable = "no finished run";
    if (s.over_budget)
      out.over_budget.push_back(si);
    else if (!r.stable)
      out.unstable.push_back(si);
    if (!r.ran || !ref_ran) {
      r.cpu_per_tau = r.cpu_per_particle_tau = {kNaN, kNaN};
      r.worst_error_in_floors = kNaN;
      out.settings.push_back(std::move(r));
      continue;
    }
    const std::size_t k = s.cpu_per_tau.size();
    const MeanStd cpu = mean_std(s.cpu_per_tau);
    r.cpu_per_tau = {cpu.mean, cpu.std / std::sqrt(double(k))};
    const double n = s.particles > 0.0 ? s.particles : kNaN;
    r.cpu_per_particle_tau = {r.cpu_per_tau.value / n, r.cpu_per_tau.error / n};
    r.steady = s.steady;
    for (std::size_t o = 0; o < n_obs; ++o) {
      const auto& reps = s.observables[o];
      ObservableResult res;
      std::vector<double> means, errors, taus;
      for (const auto& rep : reps) {
        means.push_back(rep.mean);
        errors.push_back(rep.block_error);
        taus.push_back(rep.tau);
      }
      res.mean = replica_mean(means, errors, nullptr);
      res.floor = refs[o].mean.error;
      // Paired differences, replica by replica (replica k of both started from state k).
      const std::size_t pairs = std::min(k, refs[o].means.size());
      if (si == in.reference) {
        res.difference = {0.0, 0.0};
        res.source = ErrorSource::kNone;
      } else {
        std::vector<double> d, e;
        for (std::size_t q = 0; q < pairs; ++q) {
          d.push_back(means[q] - refs[o].means[q]);
          const double pe = reps[q].paired_error;
          e.push_back(std::isfinite(pe) ? pe : std::hypot(errors[q], refs[o].errors[q]));
        }
        res.difference = replica_mean(d, e, &res.source);
      }
      spreads(reps, res.block_std, res.replica_std);
      res.block_std_ratio = ratio(res.block_std, refs[o].block_std);
      res.replica_std_ratio = ratio(res.replica_std, refs[o].replica_std);
      const MeanStd t = mean_std(taus);
      res.tau = {t.mean, t.std / std::sqrt(double(taus.size()))};
      r.observables.push_back(res);
    }
    out.settings.push_back(std::move(r));
  }

  // The converged settings' scatter, per observable: where their means scatter more than their
  // errors allow, every error of the observable grows by sqrt(chi2/dof).
  out.converged_scatter.assign(n_obs, {});
  for (std::size_t o = 0; o < n_obs; ++o) {
    std::vector<double> x, e;
    for (std::size_t si = 0; si < out.settings.size(); ++si) {
      const SettingResult& r = out.settings[si];
      if ((in.settings[si].converged || si == in.reference) && r.stable &&
          o < r.observables.size() && std::isfinite(r.observables[o].mean.value) &&
          r.observables[o].mean.error > 0.0) {
        x.push_back(r.observables[o].mean.value);
        e.push_back(r.observables[o].mean.error);
      }
    }
    auto& cs = out.converged_scatter[o];
    cs.settings = static_cast<int>(x.size());
    if (x.size() < 2)
      continue;
    const Scatter sc = scatter_of(x, e);
    cs.reduced_chi2 = sc.reduced_chi2;
    cs.error_scale = std::max(1.0, sc.error_scale);
    for (auto& r : out.settings) {
      if (o >= r.observables.size())
        continue;
      ObservableResult& res = r.observables[o];
      res.mean.error *= cs.error_scale;
      res.difference.error *= cs.error_scale;
      res.floor *= cs.error_scale;
    }
  }

  // Significance, tolerance and the worst error in floors, from the (scaled) errors.
  for (std::size_t si = 0; si < out.settings.size(); ++si) {
    SettingResult& r = out.settings[si];
    if (!r.ran || !ref_ran)
      continue;
    r.within = r.stable && r.steady;
    for (std::size_t o = 0; o < r.observables.size(); ++o) {
      ObservableResult& res = r.observables[o];
      res.z = in_units(res.difference.value, res.difference.error);
      res.error_in_floors = in_units(res.difference.value, res.floor);
      const double rel = o < in.relative_tolerance.size() ? in.relative_tolerance[o] : 0.0;
      res.within =
          std::isfinite(res.difference.value) &&
          (res.z <= in.tolerance_sigma ||
           (rel > 0.0 && std::abs(res.difference.value) <= rel * std::abs(refs[o].mean.value)));
      r.within = r.within && res.within;
      r.worst_error_in_floors = std::max(r.worst_error_in_floors, res.error_in_floors);
    }
  }

  // Ranking by the paired errors: the worst observable in units of the floor; settings without
  // an error (not run) come last, in input order.
  std::vector<std::size_t> order(out.settings.size());
  std::iota(order.begin(), order.end(), 0);
  auto key = [&](std::size_t i) {
    const double w = out.settings[i].worst_error_in_floors;
    return std::isnan(w) ? kInf : w;
  };
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    const bool ra = !std::isnan(out.settings[a].worst_error_in_floors);
    const bool rb = !std::isnan(out.settings[b].worst_error_in_floors);
    if (ra != rb)
      return ra;
    return key(a) < key(b);
  });
  for (std::size_t pos = 0; pos < order.size(); ++pos)
    out.settings[order[pos]].rank = pos + 1;

  double best = kInf;
  for (std::size_t i = 0; i < out.settings.size(); ++i) {
    const SettingResult& r = out.settings[i];
    if (r.within && r.cpu_per_particle_tau.value < best) {
      best = r.cpu_per_particle_tau.value;
      out.recommended = static_cast<int>(i);
    }
  }
  return out;
}

}  // namespace jamflow::analysis
