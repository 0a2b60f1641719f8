// Houdayer–Hartmann collapse quality for the Olsson–Teitel scaling form,
// its optimisation and the sub-range study (see olsson_teitel.hpp).
#include "analysis/olsson_teitel.hpp"

#include <gsl/gsl_errno.h>
#include <gsl/gsl_multimin.h>
#include <gsl/gsl_vector.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <exception>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <set>

#include "analysis/errors.hpp"
#include "analysis/format.hpp"

namespace jamflow::analysis {

namespace {

constexpr double kPenalty = 1e30;       // objective outside the allowed domain
constexpr double kMinAbsDelta = 1e-12;  // a curve at phi = phi_J cannot be scaled

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

}  // namespace

HoudayerHartmann::HoudayerHartmann(std::vector<ShearPoint> points) : points_(std::move(points)) {
  std::map<std::string, std::size_t> ids;
  for (const auto& p : points_) {
    if (!(p.sigma > 0.0) || !(p.sigma_err > 0.0) || !(p.shear_rate > 0.0) ||
        !std::isfinite(p.phi)) {
      throw InputError(p.source +
                       ": the collapse needs sigma_xy > 0, sigma_xy_err > 0, gdot > 0 "
                       "and a finite phi");
    }
    auto [it, inserted] = ids.emplace(p.set, set_names_.size());
    if (inserted)
      set_names_.push_back(p.set);
    set_of_.push_back(it->second);
    log_gdot_.push_back(std::log(p.shear_rate));
    log_sigma_.push_back(std::log(p.sigma));
    dy_.push_back(p.sigma_err / p.sigma);
  }
}

std::vector<HoudayerHartmann::Scaled> HoudayerHartmann::scaled(const CollapseParams& p) const {
  std::vector<Scaled> out;
  for (std::size_t i = 0; i < points_.size(); ++i) {
    const double d = points_[i].phi - p.phi_j;
    if (std::fabs(d) < kMinAbsDelta)
      continue;
    const double ld = std::log(std::fabs(d));
    out.push_back({std::exp(log_gdot_[i] - (p.alpha + p.beta) * ld),
                   std::exp(log_sigma_[i] - p.alpha * ld), dy_[i], d > 0 ? 1 : -1, set_of_[i]});
  }
  return out;
}

CollapseQuality HoudayerHartmann::evaluate(const CollapseParams& p,
                                           const std::vector<double>* sigma_override) const {
  return houdayer_hartmann(log_scaled(p, sigma_override));
}

CollapseQuality HoudayerHartmann::evaluate_pairwise(const CollapseParams& p) const {
  return pairwise_interpolation(log_scaled(p, nullptr));
}

std::vector<CollapsePoint> HoudayerHartmann::log_scaled(
    const CollapseParams& p, const std::vector<double>* sigma_override) const {
  std::vector<CollapsePoint> scaled;
  scaled.reserve(points_.size());
  for (std::size_t i = 0; i < points_.size(); ++i) {
    const double d = points_[i].phi - p.phi_j;
    if (std::fabs(d) < kMinAbsDelta)
      continue;
    const double ld = std::log(std::fabs(d));
    const double ls = sigma_override ? std::log((*sigma_override)[i]) : log_sigma_[i];
    scaled.push_back({log_gdot_[i] - (p.alpha + p.beta) * ld, ls - p.alpha * ld, dy_[i], set_of_[i],
                      d > 0 ? 1 : 0});
  }
  return scaled;
}

namespace {

struct Domain {
  double phi_lo, phi_hi;
};

Domain domain_of(const HoudayerHartmann& hh) {
  double lo = 1.0, hi = 0.0;
  for (const auto& p : hh.points()) {
    lo = std::min(lo, p.phi);
    hi = std::max(hi, p.phi);
  }
  return {std::max(lo - 0.3, 1e-6), std::min(hi + 0.3, 1.0)};
}

// Objective for the optimiser: S, or a large constant outside the domain or
// when too few points have neighbours (a collapse that hides most of the
// data by pushing curves apart must not win).
double objective(const HoudayerHartmann& hh, const Domain& dom, const CollapseParams& p,
                 double min_overlap, const std::vector<double>* sigma) {
  if (!(p.alpha > 0.01 && p.alpha < 10.0 && p.beta >= 0.0 && p.beta < 20.0 &&
        p.phi_j > dom.phi_lo && p.phi_j < dom.phi_hi)) {
    return kPenalty;
  }
  CollapseQuality q = hh.evaluate(p, sigma);
  if (q.used == 0 || static_cast<double>(q.used) < min_overlap * static_cast<double>(q.total) ||
      !std::isfinite(q.s)) {
    return kPenalty;
  }
  return q.s;
}

struct MinimizerDeleter {
  void operator()(gsl_multimin_fminimizer* m) const { gsl_multimin_fminimizer_free(m); }
};
struct VectorDeleter {
  void operator()(gsl_vector* v) const { gsl_vector_free(v); }
};

struct NmContext {
  const std::function<double(const CollapseParams&)>* f;
  std::exception_ptr error;
};

double nm_callback(const gsl_vector* v, void* params) {
  auto* ctx = static_cast<NmContext*>(params);
  try {
    return (*ctx->f)({gsl_vector_get(v, 0), gsl_vector_get(v, 1), gsl_vector_get(v, 2)});
  } catch (...) {
    ctx->error = std::current_exception();  // never throw through GSL
    return kPenalty;
  }
}

// Nelder–Mead from `start`, restarted from its own optimum with a fresh
// simplex (the standard guard against a collapsed simplex).
CollapseParams nelder_mead(const std::function<double(const CollapseParams&)>& f,
                           const CollapseParams& start, int restarts, double& best_value) {
  gsl_set_error_handler_off();
  NmContext ctx{&f, nullptr};
  gsl_multimin_function func{nm_callback, 3, &ctx};
  CollapseParams current = start;
  double steps[3] = {0.004, 0.15, 0.3};
  for (int round = 0; round <= restarts; ++round) {
    std::unique_ptr<gsl_multimin_fminimizer, MinimizerDeleter> m(
        gsl_multimin_fminimizer_alloc(gsl_multimin_fminimizer_nmsimplex2, 3));
    std::unique_ptr<gsl_vector, VectorDeleter> x(gsl_vector_alloc(3)), step(gsl_vector_alloc(3));
    gsl_vector_set(x.get(), 0, current.phi_j);
    gsl_vector_set(x.get(), 1, current.alpha);
    gsl_vector_set(x.get(), 2, current.beta);
    for (int k = 0; k < 3; ++k)
      gsl_vector_set(step.get(), k, steps[k]);
    if (gsl_multimin_fminimizer_set(m.get(), &func, x.get(), step.get()) != GSL_SUCCESS) {
      if (ctx.error)
        std::rethrow_exception(ctx.error);
      throw FitError("Nelder–Mead could not start at phi_J = " + fmt(current.phi_j) +
                     ", alpha = " + fmt(current.alpha) + ", beta = " + fmt(current.beta));
    }
    for (int iter = 0; iter < 3000; ++iter) {
      int status = gsl_multimin_fminimizer_iterate(m.get());
      if (ctx.error)
        std::rethrow_exception(ctx.error);
      if (status != GSL_SUCCESS)
        break;  // no further progress possible
      if (gsl_multimin_test_size(gsl_multimin_fminimizer_size(m.get()), 1e-7) == GSL_SUCCESS) {
        break;
      }
    }
    const gsl_vector* xm = gsl_multimin_fminimizer_x(m.get());
    current = {gsl_vector_get(xm, 0), gsl_vector_get(xm, 1), gsl_vector_get(xm, 2)};
    best_value = gsl_multimin_fminimizer_minimum(m.get());
    for (double& s : steps)
      s *= 0.5;
  }
  return current;
}

}  // namespace

CollapseFit optimize_collapse(const HoudayerHartmann& hh, const CollapseParams& start,
                              const OlssonTeitelOptions& options, std::uint64_t seed) {
  const Domain dom = domain_of(hh);
  const double min_overlap = options.min_overlap;
  std::function<double(const CollapseParams&)> f = [&](const CollapseParams& p) {
    return objective(hh, dom, p, min_overlap, nullptr);
  };
  if (f(start) >= kPenalty) {
    CollapseQuality q = hh.evaluate(start);
    throw InputError("collapse optimiser start phi_J = " + fmt(start.phi_j) +
                     ", alpha = " + fmt(start.alpha) + ", beta = " + fmt(start.beta) +
                     " is not usable: " + std::to_string(q.used) + " of " +
                     std::to_string(q.total) + " points have neighbours on another curve (need " +
                     fmt(100 * min_overlap) +
                     "%), or the parameters are outside 0.01 < alpha < 10, 0 <= beta < 20; "
                     "choose --start or lower --min-overlap");
  }
  CollapseFit fit;
  double value = 0.0;
  fit.best = nelder_mead(f, start, 2, value);
  if (!(value < kPenalty))
    throw FitError("collapse optimisation did not find a usable minimum");
  fit.quality = hh.evaluate(fit.best);

  // Parametric bootstrap: redraw each stress within its (log-normal) error
  // and re-optimise from the optimum.
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  const auto& pts = hh.points();
  std::vector<double> sigma(pts.size());
  std::vector<std::array<double, 3>> samples;
  std::vector<double> s_values;
  for (int b = 0; b < options.bootstrap; ++b) {
    for (std::size_t i = 0; i < pts.size(); ++i) {
      sigma[i] = pts[i].sigma * std::exp(pts[i].sigma_err / pts[i].sigma * normal(rng));
    }
    std::function<double(const CollapseParams&)> fb = [&](const CollapseParams& p) {
      return objective(hh, dom, p, min_overlap, &sigma);
    };
    if (fb(fit.best) >= kPenalty)
      continue;
    double vb = 0.0;
    CollapseParams pb = nelder_mead(fb, fit.best, 1, vb);
    if (vb < kPenalty) {
      samples.push_back({pb.phi_j, pb.alpha, pb.beta});
      s_values.push_back(vb);
    }
  }
  fit.bootstrap_used = static_cast<int>(samples.size());
  if (samples.size() < 10 || 5 * samples.size() < 4 * static_cast<std::size_t>(options.bootstrap)) {
    throw FitError("collapse bootstrap: only " + std::to_string(samples.size()) + " of " +
                   std::to_string(options.bootstrap) + " resamples gave a usable optimum");
  }
  double sd[3];
  for (int k = 0; k < 3; ++k) {
    double mean = 0.0, var = 0.0;
    for (const auto& s : samples)
      mean += s[k];
    mean /= static_cast<double>(samples.size());
    for (const auto& s : samples)
      var += (s[k] - mean) * (s[k] - mean);
    sd[k] = std::sqrt(var / static_cast<double>(samples.size() - 1));
  }
  {
    double mean = 0.0, var = 0.0;
    for (double v : s_values)
      mean += v;
    mean /= static_cast<double>(s_values.size());
    for (double v : s_values)
      var += (v - mean) * (v - mean);
    fit.s_spread = std::sqrt(var / static_cast<double>(s_values.size() - 1));
  }
  fit.phi_j = {fit.best.phi_j, sd[0]};
  fit.alpha = {fit.best.alpha, sd[1]};
  fit.beta = {fit.best.beta, sd[2]};
  return fit;
}

OlssonTeitelResult analyze_olsson_teitel(const std::vector<ShearPoint>& points,
                                         const OlssonTeitelOptions& options) {
  if (options.bootstrap < 10) {
    throw InputError("--bootstrap " + std::to_string(options.bootstrap) +
                     " (need at least 10 resamples for an error estimate)");
  }
  if (!(options.min_overlap > 0.0 && options.min_overlap <= 1.0)) {
    throw InputError("--min-overlap " + fmt(options.min_overlap) + " (allowed: 0 < f <= 1)");
  }
  if (points.empty())
    throw InsufficientDataError("no data points");
  std::set<std::int64_t> sizes;
  for (const auto& p : points)
    sizes.insert(p.n);
  if (sizes.size() > 1) {
    std::string list;
    for (auto n : sizes)
      list += (list.empty() ? "" : ", ") + std::to_string(n);
    throw InputError("the data contain several system sizes (N = " + list +
                     "); the collapse is done at one N: choose it with --size");
  }
  HoudayerHartmann hh(points);
  if (hh.set_names().size() < 2) {
    throw InsufficientDataError("the collapse compares different curves, but all " +
                                std::to_string(points.size()) + " points are on one curve (" +
                                hh.set_names().front() + ")");
  }
  OlssonTeitelResult r;
  r.point_errors = point_errors_of(points);
  r.n = *sizes.begin();
  r.points = points.size();
  r.sets = hh.set_names().size();
  r.at = options.at;
  r.at_quality = hh.evaluate(options.at);
  if (r.at_quality.used == 0) {
    throw InsufficientDataError("at phi_J = " + fmt(options.at.phi_j) + ", alpha = " +
                                fmt(options.at.alpha) + ", beta = " + fmt(options.at.beta) +
                                " no point has a neighbour on another curve: the curves do not "
                                "overlap in scaled variables");
  }
  r.best = optimize_collapse(hh, options.start.value_or(options.at), options, options.seed);
  {
    // The pairwise measure's own optimum, by the same optimiser and overlap constraint, from
    // the Houdayer–Hartmann optimum.
    const Domain dom = domain_of(hh);
    std::function<double(const CollapseParams&)> f = [&](const CollapseParams& p) {
      if (objective(hh, dom, p, options.min_overlap, nullptr) >= kPenalty)
        return kPenalty;
      const CollapseQuality q = hh.evaluate_pairwise(p);
      if (q.used == 0 ||
          static_cast<double>(q.used) < options.min_overlap * static_cast<double>(q.total) ||
          !std::isfinite(q.s))
        return kPenalty;
      return q.s;
    };
    double value = 0.0;
    const CollapseParams pair_best = nelder_mead(f, r.best.best, 2, value);
    auto compare = [&](const std::string& label, const CollapseParams& p) {
      r.measures.push_back({label, p, hh.evaluate(p), hh.evaluate_pairwise(p)});
    };
    compare("paper's parameters", options.at);
    compare("Houdayer-Hartmann optimum", r.best.best);
    compare("pairwise-interpolation optimum", pair_best);
  }
  if (options.soft) {
    try {
      r.soft = compare_soft(points, options);
      for (const auto& note : r.soft->fit.resolution_notes)
        r.warnings.push_back("soft rheology on these points: " + note);
    } catch (const AnalysisError& e) {
      r.soft_skipped = e.what();
      r.warnings.push_back("soft granular rheology not fitted to these points: " + r.soft_skipped);
    }
  }

  // Sub-ranges, fixed once from the global optimum.
  std::vector<double> deltas, log_rates;
  for (const auto& p : points) {
    deltas.push_back(std::fabs(p.phi - r.best.best.phi_j));
    log_rates.push_back(std::log(p.shear_rate));
  }
  r.split_delta = options.split_delta.value_or(median(deltas));
  r.split_gdot = options.split_gdot.value_or(std::exp(median(log_rates)));
  struct Def {
    const char* name;
    std::string description;
    std::function<bool(const ShearPoint&)> in;
  };
  const double sd = r.split_delta, sg = r.split_gdot, pj = r.best.best.phi_j;
  const std::vector<Def> defs = {
      {"near", "|phi - phi_J| <= " + fmt(sd) + " (phi_J of the global optimum)",
       [=](const ShearPoint& p) { return std::fabs(p.phi - pj) <= sd; }},
      {"far", "|phi - phi_J| > " + fmt(sd),
       [=](const ShearPoint& p) { return std::fabs(p.phi - pj) > sd; }},
      {"slow", "gdot <= " + fmt(sg), [=](const ShearPoint& p) { return p.shear_rate <= sg; }},
      {"fast", "gdot > " + fmt(sg), [=](const ShearPoint& p) { return p.shear_rate > sg; }},
  };
  std::uint64_t seed = options.seed;
  for (const auto& def : defs) {
    CollapseSubset sub;
    sub.name = def.name;
    sub.description = def.description;
    std::vector<ShearPoint> in, out;
    for (std::size_t i = 0; i < points.size(); ++i) {
      if (def.in(points[i])) {
        sub.indices.push_back(i);
        in.push_back(points[i]);
      } else {
        out.push_back(points[i]);
      }
    }
    std::set<std::string> in_sets;
    for (const auto& p : in)
      in_sets.insert(p.set);
    if (in.size() < options.min_subset_points || in_sets.size() < 2 || out.empty()) {
      sub.skipped = std::to_string(in.size()) + " points on " + std::to_string(in_sets.size()) +
                    " curves (need at least " + std::to_string(options.min_subset_points) +
                    " points on 2 curves, and data outside the subset)";
      r.warnings.push_back("subset '" + sub.name + "' skipped: " + sub.skipped);
      r.subsets.push_back(std::move(sub));
      continue;
    }
    HoudayerHartmann hin(in), hout(out);
    sub.at_global_best = hin.evaluate(r.best.best);
    sub.complement_at_global_best = hout.evaluate(r.best.best);
    try {
      sub.fit = optimize_collapse(hin, r.best.best, options, ++seed);
      sub.complement_at_own_best = hout.evaluate(sub.fit->best);
      sub.trade_off = sub.fit->quality.s < sub.at_global_best.s &&
                      sub.complement_at_own_best.s > sub.complement_at_global_best.s &&
                      !sub.complement_at_own_best.acceptable();
    } catch (const AnalysisError& e) {
      sub.fit.reset();
      sub.skipped = e.what();
      r.warnings.push_back("subset '" + sub.name + "' not optimised: " + sub.skipped);
    }
    r.subsets.push_back(std::move(sub));
  }
  return r;
}

bool SoftComparison::acceptable() const {
  return used > 0 && s <= 1.0 + 3.0 * std::sqrt(2.0 / static_cast<double>(used));
}

namespace {

std::vector<GranularPoint> as_granular(const std::vector<ShearPoint>& points,
                                       const std::vector<double>& sigma,
                                       const std::vector<double>& pressure, const SoftLaw& slope) {
  std::vector<GranularPoint> out;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const ShearPoint& s = points[i];
    GranularPoint g;
    g.n = s.n;
    g.pressure = pressure[i];
    g.shear_rate = s.shear_rate;
    g.j = s.shear_rate / pressure[i];
    g.phi = s.phi;
    const double rel_p = s.pressure_err / s.pressure;
    g.phi_err = std::max(std::fabs(slope.dphi_dlnp(pressure[i], s.shear_rate)) * rel_p, 1e-7);
    g.mu = sigma[i] / pressure[i];
    g.mu_err = g.mu * std::hypot(s.sigma_err / s.sigma, rel_p);
    g.source = s.source;
    out.push_back(g);
  }
  return out;
}

// Mean squared pull in ln sigma of the law at the points; the law's stress per point.
double soft_quality(const SoftLaw& law, const std::vector<ShearPoint>& points,
                    const std::vector<double>& sigma, std::size_t& used,
                    std::vector<double>* per_point) {
  double sum = 0.0;
  used = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const double s = law.sigma_at(points[i].phi, points[i].shear_rate);
    if (per_point)
      per_point->push_back(s);
    if (!(s > 0.0))
      continue;
    sum +=
        std::pow((std::log(sigma[i]) - std::log(s)) / (points[i].sigma_err / points[i].sigma), 2);
    ++used;
  }
  return used > 0 ? sum / static_cast<double>(used) : std::numeric_limits<double>::infinity();
}

}  // namespace

SoftComparison compare_soft(const std::vector<ShearPoint>& points, const OlssonTeitelOptions& o) {
  for (const auto& p : points) {
    if (!(p.pressure > 0.0) || !(p.pressure_err > 0.0)) {
      throw InsufficientDataError(p.source +
                                  ": no measured pressure (columns pressure, pressure_err); "
                                  "the soft granular rheology needs P at every point");
    }
  }
  std::vector<double> sigma, pressure;
  for (const auto& p : points) {
    sigma.push_back(p.sigma);
    pressure.push_back(p.pressure);
  }
  JointSoftOptions jo;
  jo.bootstrap = 0;
  SoftComparison c;
  // Two rounds: the phi errors depend on the law's slope.
  c.fit = fit_soft_joint(as_granular(points, sigma, pressure, SoftLaw{}), jo);
  c.fit = fit_soft_joint(as_granular(points, sigma, pressure, c.fit.law), jo, c.fit.law);
  c.total = points.size();
  c.s = soft_quality(c.fit.law, points, sigma, c.used, &c.sigma_law);
  if (c.used == 0)
    throw FitError("the fitted soft granular rheology has no pressure root at any point");

  std::mt19937_64 rng(o.seed + 1);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<double> s_values;
  std::vector<double> sb(points.size()), pb(points.size());
  for (int b = 0; b < o.bootstrap; ++b) {
    for (std::size_t i = 0; i < points.size(); ++i) {
      sb[i] = points[i].sigma * std::exp(points[i].sigma_err / points[i].sigma * normal(rng));
      pb[i] =
          points[i].pressure * std::exp(points[i].pressure_err / points[i].pressure * normal(rng));
    }
    try {
      const JointSoftFit f = fit_soft_joint(as_granular(points, sb, pb, c.fit.law), jo, c.fit.law);
      std::size_t used = 0;
      const double s = soft_quality(f.law, points, sb, used, nullptr);
      if (used == 0)
        continue;
      c.fit.samples.push_back(f.law.values());
      s_values.push_back(s);
    } catch (const AnalysisError&) {
      // a resample without a converged fit is left out and counted
    }
  }
  c.bootstrap_used = static_cast<int>(s_values.size());
  c.fit.bootstrap_requested = o.bootstrap;
  if (s_values.size() >= 10) {
    double mean = 0.0, var = 0.0;
    for (double v : s_values)
      mean += v;
    mean /= static_cast<double>(s_values.size());
    for (double v : s_values)
      var += (v - mean) * (v - mean);
    c.s_spread = std::sqrt(var / static_cast<double>(s_values.size() - 1));
    for (std::size_t k = 0; k < 10; ++k)
      c.fit.params[k].error = c.fit.spread([k](const SoftLaw& l) { return l.values()[k]; });
    c.fit.alpha.error = c.fit.spread([](const SoftLaw& l) { return 1.0 / l.x; });
    c.fit.resolution_notes = explain_resolution(
        c.fit, as_granular(points, sigma, pressure, c.fit.law), JointSoftOptions{}.y_target);
  } else {
    c.fit.samples.clear();
  }
  return c;
}

}  // namespace jamflow::analysis
