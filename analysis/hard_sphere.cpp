// Hard-sphere envelope, per-size granular-rheology fits, large-N extrapolation,
// correlation-length exponent and viscosity law (see hard_sphere.hpp).
#include "analysis/hard_sphere.hpp"

#include <gsl/gsl_cdf.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <set>

#include "analysis/errors.hpp"
#include "analysis/format.hpp"
#include "analysis/json.hpp"
#include "analysis/report.hpp"
#include "analysis/seed.hpp"

namespace jamflow::analysis {

namespace {

std::string size_label(std::int64_t n) {
  return "N=" + std::to_string(n);
}

}  // namespace

bool in_envelope(EnvelopeStatus s) {
  return s == EnvelopeStatus::kAgrees || s == EnvelopeStatus::kAboveAgreement;
}

const char* to_string(EnvelopeStatus s) {
  switch (s) {
    case EnvelopeStatus::kAgrees:
      return "agrees";
    case EnvelopeStatus::kAboveAgreement:
      return "above_agreement";
    case EnvelopeStatus::kDisagrees:
      return "disagrees";
    case EnvelopeStatus::kBelowOnset:
      return "below_onset";
    case EnvelopeStatus::kUntestable:
      return "untestable";
    case EnvelopeStatus::kGuard:
      return "guard";
  }
  return "?";
}

std::map<std::int64_t, std::vector<GranularPoint>> group_by_size(
    const std::vector<GranularPoint>& points) {
  std::map<std::int64_t, std::vector<GranularPoint>> out;
  for (const auto& p : points)
    out[p.n].push_back(p);
  return out;
}

namespace {

struct Comparison {
  bool available = false;
  double pull_phi = 0.0, pull_mu = 0.0;
  double pressure = 0.0;
};

// Compares point e with the curve of one pressure (its points, ascending J)
// at the same J, interpolating linearly in ln J. Not available when the
// curve does not bracket J.
Comparison compare_with(const GranularPoint& e, const std::vector<const GranularPoint*>& curve) {
  constexpr double kRelTol = 1e-9;  // J values equal up to rounding
  Comparison c;
  if (curve.empty())
    return c;
  const double j = e.j;
  if (j < curve.front()->j * (1 - kRelTol) || j > curve.back()->j * (1 + kRelTol))
    return c;
  std::size_t ib = 0;
  while (ib + 1 < curve.size() && curve[ib]->j < j * (1 - kRelTol))
    ++ib;
  const GranularPoint& b = *curve[ib];
  const GranularPoint& a = ib > 0 ? *curve[ib - 1] : b;
  double t = 1.0;  // J coincides with b
  if (b.j > a.j && std::fabs(b.j - j) > kRelTol * j) {
    t = std::clamp(std::log(j / a.j) / std::log(b.j / a.j), 0.0, 1.0);
  }
  const double phi_ref = (1 - t) * a.phi + t * b.phi;
  const double mu_ref = (1 - t) * a.mu + t * b.mu;
  // Independent points: the interpolant's variance is (1-t)^2 va + t^2 vb.
  const double vphi = std::pow((1 - t) * a.phi_err, 2) + std::pow(t * b.phi_err, 2);
  const double vmu = std::pow((1 - t) * a.mu_err, 2) + std::pow(t * b.mu_err, 2);
  c.available = true;
  c.pull_phi = std::fabs(e.phi - phi_ref) / std::sqrt(e.phi_err * e.phi_err + vphi);
  c.pull_mu = std::fabs(e.mu - mu_ref) / std::sqrt(e.mu_err * e.mu_err + vmu);
  c.pressure = b.pressure;
  return c;
}

}  // namespace

std::vector<EnvelopePoint> select_envelope(const std::vector<GranularPoint>& points,
                                           const EnvelopeOptions& options) {
  if (!(options.z > 0.0) || !std::isfinite(options.z)) {
    throw InputError("envelope pull threshold z = " + fmt(options.z) + " (must be > 0)");
  }
  std::vector<EnvelopePoint> out;
  out.reserve(points.size());
  for (const auto& p : points)
    out.push_back({p, EnvelopeStatus::kUntestable, 0.0, 0.0, 0.0});
  std::sort(out.begin(), out.end(), [](const EnvelopePoint& a, const EnvelopePoint& b) {
    if (a.point.pressure != b.point.pressure)
      return a.point.pressure < b.point.pressure;
    return a.point.j < b.point.j;
  });
  // Curves: per pressure, indices into `out` by ascending J.
  std::vector<std::vector<std::size_t>> curves;
  std::vector<std::vector<const GranularPoint*>> curve_points;
  for (std::size_t i = 0; i < out.size(); ++i) {
    if (i == 0 || out[i].point.pressure != out[i - 1].point.pressure) {
      curves.emplace_back();
      curve_points.emplace_back();
    }
    curves.back().push_back(i);
    curve_points.back().push_back(&out[i].point);
  }
  const std::size_t np = curves.size();
  auto agree = [&](const Comparison& c) {
    return c.pull_phi <= options.z && c.pull_mu <= options.z;
  };
  for (std::size_t k = 0; k < np; ++k) {
    // Comparisons of every point of this pressure, from large to small J.
    std::vector<std::size_t> order(curves[k].rbegin(), curves[k].rend());
    std::vector<Comparison> lower(order.size()), higher(order.size());
    for (std::size_t i = 0; i < order.size(); ++i) {
      const GranularPoint& p = out[order[i]].point;
      for (std::size_t m = k; m-- > 0 && !lower[i].available;) {
        lower[i] = compare_with(p, curve_points[m]);
      }
      for (std::size_t m = k + 1; m < np && !higher[i].available; ++m) {
        higher[i] = compare_with(p, curve_points[m]);
      }
    }
    auto disagrees_with_lower = [&](std::size_t i) {
      return i >= order.size() || !lower[i].available || !agree(lower[i]);
    };
    bool stopped = false;
    double largest_accepted_j = -1.0;
    for (std::size_t i = 0; i < order.size(); ++i) {
      EnvelopePoint& e = out[order[i]];
      if (stopped) {
        e.status = EnvelopeStatus::kBelowOnset;
        continue;
      }
      const Comparison* judge = nullptr;
      if (lower[i].available) {
        judge = &lower[i];
        if (agree(lower[i])) {
          e.status = EnvelopeStatus::kAgrees;
        } else {
          // A real deviation persists at smaller J; a single disagreement
          // followed by agreement is a fluctuation: exclude only the point.
          e.status = EnvelopeStatus::kDisagrees;
          stopped = disagrees_with_lower(i + 1);
        }
      } else if (higher[i].available) {
        judge = &higher[i];
        e.status = agree(higher[i]) ? EnvelopeStatus::kAgrees : EnvelopeStatus::kUntestable;
      }
      if (judge) {
        e.pull_phi = judge->pull_phi;
        e.pull_mu = judge->pull_mu;
        e.reference_pressure = judge->pressure;
      }
      if (e.status == EnvelopeStatus::kAgrees) {
        largest_accepted_j = std::max(largest_accepted_j, e.point.j);
      }
    }
    if (stopped) {
      // Guard: drop the last accepted points before the onset.
      int dropped = 0;
      for (std::size_t i = 0; i < order.size() && dropped < options.guard; ++i) {
        const std::size_t idx = order[order.size() - 1 - i];  // from small J upwards
        if (out[idx].status == EnvelopeStatus::kAgrees) {
          out[idx].status = EnvelopeStatus::kGuard;
          ++dropped;
        }
      }
      largest_accepted_j = -1.0;
      for (std::size_t i : curves[k]) {
        if (out[i].status == EnvelopeStatus::kAgrees) {
          largest_accepted_j = std::max(largest_accepted_j, out[i].point.j);
        }
      }
    }
    for (std::size_t i : curves[k]) {
      if (out[i].status == EnvelopeStatus::kUntestable && largest_accepted_j > 0 &&
          out[i].point.j > largest_accepted_j) {
        out[i].status = EnvelopeStatus::kAboveAgreement;
      }
    }
  }
  return out;
}

const std::vector<std::string>& hard_sphere_parameters() {
  static const std::vector<std::string> names = {"phi_J", "b_phi", "C_phi", "mu_J", "b_mu", "C_mu"};
  return names;
}

SizeFit fit_size(std::int64_t n, const std::vector<GranularPoint>& points,
                 const HardSphereOptions& options) {
  SizeFit s;
  s.n = n;
  s.points = select_envelope(points, options.envelope);
  FitData phi_data, mu_data;
  std::size_t counts[6] = {0, 0, 0, 0, 0, 0};
  for (const auto& e : s.points) {
    ++counts[static_cast<int>(e.status)];
    if (!in_envelope(e.status))
      continue;
    phi_data.x.push_back(e.point.j);
    phi_data.y.push_back(e.point.phi);
    phi_data.sigma.push_back(e.point.phi_err);
    mu_data.x.push_back(e.point.j);
    mu_data.y.push_back(e.point.mu);
    mu_data.sigma.push_back(e.point.mu_err);
  }
  s.points_used = phi_data.size();
  const std::size_t outside = s.points.size() - s.points_used;
  if (s.points_used < 4) {
    std::string detail = std::to_string(outside) + " outside: " + std::to_string(counts[2]) +
                         " disagree with lower pressures, " + std::to_string(counts[3]) +
                         " below a deviation onset, " + std::to_string(counts[4]) +
                         " untestable, " + std::to_string(counts[5]) +
                         " guard points next to an onset";
    if (s.points_used == 0) {
      std::set<double> ps;
      for (const auto& e : s.points)
        ps.insert(e.point.pressure);
      detail += ps.size() < 2 ? "; all points are at a single pressure, and the envelope is "
                                "found by comparing pressures"
                              : "; no two pressures agree at any common J";
    }
    throw InsufficientDataError(size_label(n) + ": only " + std::to_string(s.points_used) + " of " +
                                std::to_string(s.points.size()) +
                                " points are in the hard-sphere envelope (" + detail +
                                "); the fits of phi(J) and mu(J) need at least 4");
  }
  s.j_min = *std::min_element(phi_data.x.begin(), phi_data.x.end());
  s.j_max = *std::max_element(phi_data.x.begin(), phi_data.x.end());

  FitOptions fo;
  fo.scale_errors_by_chi2 = options.scale_errors;
  PowerLawForm phi_form{-1.0, 1.0, 0.03, 1.5, "phi_J", "C_phi", "b_phi"};
  fo.label = "phi = phi_J - C_phi J^b_phi (" + size_label(n) + ")";
  s.phi = fit_power_law_offset(phi_data, phi_form, fo);
  PowerLawForm mu_form{1.0, 1.0, 0.03, 1.5, "mu_J", "C_mu", "b_mu"};
  FitOptions fo_mu = fo;
  fo_mu.label = "mu = mu_J + C_mu J^b_mu (" + size_label(n) + ")";
  s.mu = fit_power_law_offset(mu_data, mu_form, fo_mu);

  // Physical ranges: a packing fraction, a positive amplitude and exponent, a friction
  // coefficient mu_J >= 0 (a negative one is a fit that has traded mu_J against C_mu, b_mu).
  const double nn = static_cast<double>(n);
  auto ref_b = [&](const char* b) {
    return options.form_systematic ? std::optional<double>(seed::table2(b).at(nn)) : std::nullopt;
  };
  s.phi_errors = power_law_error_model(
      phi_data, phi_form, s.phi, fo, ref_b("b_phi"),
      {{"phi_J", 0.0, 1.0}, {"C_phi", 0.0, std::nullopt}, {"b_phi", 0.0, std::nullopt}}, "J");
  s.mu_errors = power_law_error_model(
      mu_data, mu_form, s.mu, fo_mu, ref_b("b_mu"),
      {{"mu_J", 0.0, std::nullopt}, {"C_mu", 0.0, std::nullopt}, {"b_mu", 0.0, std::nullopt}}, "J");
  return s;
}

namespace {

Measured parameter_of(const SizeFit& s, const std::string& name) {
  if (name == "phi_J" || name == "b_phi" || name == "C_phi")
    return s.phi[name];
  return s.mu[name];
}

// Parameters (Table 2 order) and covariance of one size's fits.
void size_parameters(const SizeFit& s, std::vector<double>& params, std::vector<double>& cov) {
  // Fit order is (a, c, b); Table 2 order is (a, b, c).
  const std::size_t order[3] = {0, 2, 1};
  params.clear();
  std::vector<double> blocks[2];
  const FitResult* fits[2] = {&s.phi, &s.mu};
  for (int f = 0; f < 2; ++f) {
    blocks[f].resize(9);
    for (std::size_t i = 0; i < 3; ++i) {
      params.push_back(fits[f]->params[order[i]]);
      for (std::size_t j = 0; j < 3; ++j) {
        blocks[f][i * 3 + j] = fits[f]->cov(order[i], order[j]);
      }
    }
  }
  cov = block_diagonal({blocks[0], blocks[1]}, {3, 3});
}

}  // namespace

double ViscosityLaw::eta(double phi) const {
  const double phi_j = params[0], b_phi = params[1], c_phi = params[2];
  const double mu_j = params[3], b_mu = params[4], c_mu = params[5];
  const double r = c_phi / (phi_j - phi);
  return mu_j * std::pow(r, 1.0 / b_phi) + c_mu * std::pow(r, (1.0 - b_mu) / b_phi);
}

ViscosityLaw viscosity_law(std::vector<double> params, std::vector<double> covariance,
                           std::string source, double window_min, double window_max,
                           const std::vector<double>& systematic) {
  ViscosityLaw law;
  law.params = std::move(params);
  law.covariance = std::move(covariance);
  law.source = std::move(source);
  const double phi_j = law.params[0];
  if (!(window_min < window_max) || !(window_max < phi_j)) {
    throw InputError("viscosity window " + fmt(window_min) + ":" + fmt(window_max) +
                     " must satisfy phimin < phimax < phi_J = " + fmt(phi_j));
  }
  law.window_min = window_min;
  law.window_max = window_max;
  const auto& cov = law.covariance;
  using P = std::span<const double>;
  law.amplitude_1 = propagate([](P p) { return p[3] * std::pow(p[2], 1.0 / p[1]); }, law.params,
                              cov, "viscosity amplitude mu_J C_phi^(1/b_phi)");
  law.exponent_1 =
      propagate([](P p) { return 1.0 / p[1]; }, law.params, cov, "viscosity exponent 1/b_phi");
  law.amplitude_2 = propagate([](P p) { return p[5] * std::pow(p[2], (1.0 - p[4]) / p[1]); },
                              law.params, cov, "viscosity amplitude C_mu C_phi^((1-b_mu)/b_phi)");
  law.exponent_2 = propagate([](P p) { return (1.0 - p[4]) / p[1]; }, law.params, cov,
                             "viscosity exponent (1-b_mu)/b_phi");
  // Both parts equal where mu_J/J = C_mu J^(b_mu-1): J_x = (mu_J/C_mu)^(1/b_mu).
  law.crossover_delta_phi =
      propagate([](P p) { return p[2] * std::pow(std::pow(p[3] / p[5], 1.0 / p[4]), p[1]); },
                law.params, cov, "viscosity crossover phi_J - phi");
  auto eta_of = [](P p, double phi) {
    const double r = p[2] / (p[0] - phi);
    return p[3] * std::pow(r, 1.0 / p[1]) + p[5] * std::pow(r, (1.0 - p[4]) / p[1]);
  };
  law.effective_exponent = propagate(
      [&](P p) {
        return std::log(eta_of(p, window_max) / eta_of(p, window_min)) /
               std::log((p[0] - window_min) / (p[0] - window_max));
      },
      law.params, cov, "effective viscosity exponent over the window");
  // Local exponent -d ln eta / d ln(phi_J - phi) with J(phi) inverted.
  auto local = [](P p, double phi) {
    const double j = std::pow((p[0] - phi) / p[2], 1.0 / p[1]);
    const double t1 = p[3] / j, t2 = p[5] * std::pow(j, p[4] - 1.0);
    return (t1 + (1.0 - p[4]) * t2) / (t1 + t2) / p[1];
  };
  law.local_exponent_at_min = propagate([&](P p) { return local(p, window_min); }, law.params, cov,
                                        "local viscosity exponent at phimin");
  law.local_exponent_at_max = propagate([&](P p) { return local(p, window_max); }, law.params, cov,
                                        "local viscosity exponent at phimax");
  // The systematic errors, propagated as independent (a diagonal covariance of their squares).
  if (!systematic.empty()) {
    std::vector<double> sys_cov(law.params.size() * law.params.size(), 0.0);
    for (std::size_t k = 0; k < law.params.size() && k < systematic.size(); ++k)
      sys_cov[k * (law.params.size() + 1)] =
          std::isfinite(systematic[k]) ? systematic[k] * systematic[k] : 0.0;
    law.exponent_1_systematic =
        propagate([](P p) { return 1.0 / p[1]; }, law.params, sys_cov, "1/b_phi").error;
    law.exponent_2_systematic =
        propagate([](P p) { return (1.0 - p[4]) / p[1]; }, law.params, sys_cov, "(1-b_mu)/b_phi")
            .error;
    law.effective_exponent_systematic =
        propagate(
            [&](P p) {
              return std::log(eta_of(p, window_max) / eta_of(p, window_min)) /
                     std::log((p[0] - window_min) / (p[0] - window_max));
            },
            law.params, sys_cov, "effective viscosity exponent")
            .error;
  }
  return law;
}

SizeSensitivity size_sensitivity(double a, double alpha, const std::vector<double>& sizes,
                                 const std::vector<double>& errors, double threshold_sigma) {
  SizeSensitivity s;
  s.a = a;
  s.alpha = alpha;
  // F = J^T W J for the parameters (O_inf, A, alpha): dO/dO_inf = 1, dO/dA = N^-alpha,
  // dO/dalpha = -A ln N N^-alpha.
  double f[3][3] = {{0.0}};
  for (std::size_t i = 0; i < sizes.size() && i < errors.size(); ++i) {
    const double u = std::pow(sizes[i], -alpha);
    const double g[3] = {1.0, u, -a * std::log(sizes[i]) * u};
    const double w = 1.0 / (errors[i] * errors[i]);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c)
        f[r][c] += w * g[r] * g[c];
  }
  // The diagonal of F^-1 from its cofactors.
  const double det = f[0][0] * (f[1][1] * f[2][2] - f[1][2] * f[2][1]) -
                     f[0][1] * (f[1][0] * f[2][2] - f[1][2] * f[2][0]) +
                     f[0][2] * (f[1][0] * f[2][1] - f[1][1] * f[2][0]);
  const double var_a = (f[0][0] * f[2][2] - f[0][2] * f[2][0]) / det;
  const double var_alpha = (f[0][0] * f[1][1] - f[0][1] * f[1][0]) / det;
  if (!(std::isfinite(det) && det > 0.0 && var_a > 0.0 && var_alpha > 0.0))
    return s;
  s.sigma_a = std::sqrt(var_a);
  s.sigma_alpha = std::sqrt(var_alpha);
  s.z = std::fabs(a) / s.sigma_a;
  s.power =
      gsl_cdf_ugaussian_P(s.z - threshold_sigma) + gsl_cdf_ugaussian_P(-s.z - threshold_sigma);
  // The far tail (an A of the wrong sign beyond the threshold) is left out: at the target power
  // it is below 1e-3.
  s.error_scale = s.z / (threshold_sigma + gsl_cdf_ugaussian_Pinv(SizeSensitivity::kTargetPower));
  return s;
}

std::optional<UnitFreeReading> unit_free_reading(const Extrapolation& e) {
  if (!std::isfinite(e.chi2_constant) || !std::isfinite(e.chi2_power_law))
    return std::nullopt;
  UnitFreeReading u;
  u.delta_chi2 = std::max(0.0, e.chi2_constant - e.chi2_power_law);
  u.p_constant = gsl_cdf_chisq_Q(u.delta_chi2, 2.0);
  if (e.status == Extrapolation::Status::kFit && e.fit)
    u.alpha_relative_error = e.fit->at(2).error / std::fabs(e.fit->at(2).value);
  return u;
}

Extrapolation extrapolate_in_size(const std::string& parameter, const std::vector<double>& sizes,
                                  const std::vector<double>& values,
                                  const std::vector<double>& errors, const FitOptions& options) {
  Extrapolation ex;
  ex.parameter = parameter;
  const std::size_t n = sizes.size();
  ex.dof = static_cast<int>(n) - 3;
  if (n < 4) {
    ex.message = options.label + ": needs at least 4 sizes, got " + std::to_string(n);
    return ex;
  }
  const double n_min = *std::min_element(sizes.begin(), sizes.end());
  // Profile over alpha with the correction normalised at the smallest size,
  // D (N/N_min)^-alpha (D = A N_min^-alpha), which has a finite limit as
  // alpha -> infinity: an indicator of the smallest size.
  struct Slice {
    double alpha, chi2, inf, inf_sd;
  };
  std::vector<Slice> profile;
  auto slice = [&](double alpha) {
    double s11 = 0, s12 = 0, s22 = 0, t1 = 0, t2 = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const double w = 1.0 / (errors[i] * errors[i]);
      const double u =
          std::isinf(alpha) ? (sizes[i] == n_min ? 1.0 : 0.0) : std::pow(sizes[i] / n_min, -alpha);
      s11 += w;
      s12 += w * u;
      s22 += w * u * u;
      t1 += w * values[i];
      t2 += w * u * values[i];
    }
    const double det = s11 * s22 - s12 * s12;
    const double inf = (s22 * t1 - s12 * t2) / det, d = (s11 * t2 - s12 * t1) / det;
    double chi2 = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      const double u =
          std::isinf(alpha) ? (sizes[i] == n_min ? 1.0 : 0.0) : std::pow(sizes[i] / n_min, -alpha);
      chi2 += std::pow((values[i] - inf - d * u) / errors[i], 2);
    }
    profile.push_back({alpha, chi2, inf, std::sqrt(s22 / det)});
  };
  const double a_lo = 0.02, a_hi = 5.0;
  const int grid = 300;
  for (int k = 0; k <= grid; ++k)
    slice(a_lo * std::pow(a_hi / a_lo, double(k) / grid));
  slice(std::numeric_limits<double>::infinity());
  std::size_t best = 0;
  for (std::size_t k = 1; k < profile.size(); ++k) {
    if (profile[k].chi2 < profile[best].chi2)
      best = k;
  }
  const double chi2_min = profile[best].chi2;
  ex.chi2 = chi2_min;
  ex.chi2_power_law = chi2_min;
  // A constant first: if it describes the data and the power law is no
  // significant improvement (Delta chi2 < 5.99, the 95 % point for its two
  // extra parameters), there is no resolved N-dependence.
  {
    double sw = 0.0, swy = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      sw += 1.0 / (errors[i] * errors[i]);
      swy += values[i] / (errors[i] * errors[i]);
    }
    const double mean = swy / sw;
    double chi2_const = 0.0;
    for (std::size_t i = 0; i < n; ++i)
      chi2_const += std::pow((values[i] - mean) / errors[i], 2);
    ex.chi2_constant = chi2_const;
    ex.dof_constant = static_cast<int>(n) - 1;
    if (gsl_cdf_chisq_Q(chi2_const, static_cast<double>(n - 1)) >= 0.05 &&
        chi2_const - chi2_min < 5.99) {
      ex.status = Extrapolation::Status::kConstant;
      ex.inf = {mean, 1.0 / std::sqrt(sw)};
      ex.chi2 = chi2_const;
      ex.dof = static_cast<int>(n) - 1;
      ex.message = parameter +
                   "(N): no significant N-dependence (a constant fits, chi2 = " + fmt(chi2_const) +
                   " for " + std::to_string(n - 1) + " dof); reporting the weighted mean " +
                   fmt(mean) + " +- " + fmt(ex.inf.error) + " as " + parameter + "_inf";
      return ex;
    }
  }
  const bool at_lower_edge = best <= 1;
  const bool at_upper_edge = best + 3 >= profile.size();  // last finite points or infinity
  if (at_lower_edge) {
    ex.status = Extrapolation::Status::kNotResolved;
    ex.message = options.label +
                 ": no convergence with N resolved (the best exponent is "
                 "alpha <= " +
                 fmt(profile[1].alpha) + ", where O_inf is not determined); values: " + [&] {
                   std::string v;
                   for (std::size_t i = 0; i < n; ++i) {
                     v += (i ? ", " : "") + fmt(values[i]) + " +- " + fmt(errors[i]);
                   }
                   return v;
                 }();
    return ex;
  }
  if (!at_upper_edge) {
    try {
      FitResult fit =
          fit_power_law_offset(FitData{sizes, values, errors, {}},
                               PowerLawForm{1.0, -1.0, a_lo, a_hi, "inf", "A", "alpha"}, options);
      ex.status = Extrapolation::Status::kFit;
      ex.inf = fit.at(0);
      ex.chi2 = fit.chi2;
      ex.fit = std::move(fit);
      return ex;
    } catch (const AnalysisError& e) {
      ex.message = e.what();
      return ex;
    }
  }
  // alpha unbounded above: profile likelihood of O_inf over all alpha,
  // P(v) = min_alpha [chi2(alpha) + (v - inf(alpha))^2 / sd(alpha)^2].
  auto excess = [&](double v) {
    double pv = std::numeric_limits<double>::infinity();
    for (const auto& p : profile)
      pv = std::min(pv, p.chi2 + std::pow((v - p.inf) / p.inf_sd, 2));
    return pv - (chi2_min + 1.0);
  };
  const double v_best = profile[best].inf;
  // Bracket and bisect each end of {v: P(v) <= chi2_min + 1}.
  auto edge = [&](double direction) {
    double step = profile[best].inf_sd;
    double inside = v_best, outside = v_best + direction * step;
    for (int k = 0; k < 200 && excess(outside) <= 0.0; ++k) {
      inside = outside;
      step *= 2.0;
      outside = v_best + direction * step;
    }
    for (int k = 0; k < 200; ++k) {
      const double mid = 0.5 * (inside + outside);
      (excess(mid) <= 0.0 ? inside : outside) = mid;
    }
    return inside;
  };
  const double v_lo = edge(-1.0), v_hi = edge(1.0);
  ex.status = Extrapolation::Status::kExponentUnbounded;
  ex.inf = {v_best, 0.5 * (v_hi - v_lo)};
  ex.alpha_lower_bound = a_hi;
  for (const auto& p : profile) {
    if (p.chi2 <= chi2_min + 1.0)
      ex.alpha_lower_bound = std::min(ex.alpha_lower_bound, p.alpha);
  }
  ex.message = parameter +
               "(N): the exponent alpha is not resolved (chi2 keeps decreasing as "
               "alpha grows: only the smallest size deviates); reporting " +
               parameter + "_inf = " + fmt(ex.inf.value) + " +- " + fmt(ex.inf.error) +
               " from the profile likelihood and alpha > " + fmt(ex.alpha_lower_bound);
  if (!(ex.inf.error > 0.0) || !std::isfinite(ex.inf.error)) {
    ex.status = Extrapolation::Status::kFailed;
    ex.message = options.label + ": profile-likelihood error of O_inf is not finite";
  }
  return ex;
}

HardSphereResult analyze_hard_sphere(const std::vector<GranularPoint>& points,
                                     const HardSphereOptions& options) {
  if (options.window_min.has_value() != options.window_max.has_value()) {
    throw InputError("viscosity window: give both phimin and phimax");
  }
  HardSphereResult r;
  r.point_errors = point_errors_of(points);
  auto groups = group_by_size(points);
  if (groups.empty())
    throw InsufficientDataError("no data points");
  for (const auto& [n, pts] : groups) {
    try {
      r.sizes.push_back(fit_size(n, pts, options));
    } catch (const InsufficientDataError& e) {
      r.unfitted.push_back({n, select_envelope(pts, options.envelope), e.what()});
      r.failures.push_back(e.what());
      ++r.sizes_without_enough_data;
    } catch (const FitError& e) {
      r.unfitted.push_back({n, select_envelope(pts, options.envelope), e.what()});
      r.failures.push_back(e.what());
    }
  }
  if (r.sizes.empty()) {
    r.extrapolation_skipped = "no size could be fitted";
    r.collapse_phi = {"phi", 0, 0, 0, 0, {}, {}, "no size could be fitted"};
    r.collapse_mu = {"mu", 0, 0, 0, 0, {}, {}, "no size could be fitted"};
    return r;
  }

  const auto& names = hard_sphere_parameters();
  const int n_sizes = static_cast<int>(r.sizes.size());
  if (n_sizes < options.min_sizes_for_extrapolation) {
    r.extrapolation_skipped = "O(N) = O_inf + A N^-alpha has 3 parameters and needs at least " +
                              std::to_string(options.min_sizes_for_extrapolation) +
                              " system sizes; the data have " + std::to_string(n_sizes);
    r.warnings.push_back("large-N extrapolation skipped: " + r.extrapolation_skipped);
  } else {
    for (const auto& name : names) {
      std::vector<double> ns, vs, es;
      for (const auto& s : r.sizes) {
        Measured m = parameter_of(s, name);
        ns.push_back(static_cast<double>(s.n));
        vs.push_back(m.value);
        es.push_back(m.error);
      }
      FitOptions fo;
      fo.scale_errors_by_chi2 = options.scale_errors;
      fo.label = name + "(N) = " + name + "_inf + A N^-alpha";
      Extrapolation ex = extrapolate_in_size(name, ns, vs, es, fo);
      const seed::SizeLaw& law = seed::table2(name);
      ex.sensitivity = size_sensitivity(law.a, law.alpha, ns, es, options.resolved_amplitude_sigma);
      for (const auto& s : r.sizes) {
        const ErrorModel& em = name.find("phi") != std::string::npos ? s.phi_errors : s.mu_errors;
        for (const auto& pe : em.parameters) {
          const double sys = pe.systematic();
          if (pe.name == name && std::isfinite(sys) &&
              !(std::isfinite(ex.systematic) && ex.systematic >= sys))
            ex.systematic = sys;
        }
      }
      if (ex.status == Extrapolation::Status::kFit) {
        const Measured a = ex.fit->at(1);
        const double z = std::fabs(a.value) / a.error;
        ex.resolved = z > options.resolved_amplitude_sigma;
        ex.resolution = "A = " + format_measured(a) + " (" + fmt(z, "%.1f") +
                        " sigma from 0) over " + std::to_string(n_sizes) + " sizes" +
                        (ex.resolved ? ": resolved"
                                     : ": not resolved (needs |A| > " +
                                           fmt(options.resolved_amplitude_sigma) + " sigma)");
      } else {
        // Why, without a value: an O_inf from a non-resolved extrapolation is no N -> infinity
        // result (the JSON keeps it under `inf` with its status).
        const char* why = ex.status == Extrapolation::Status::kConstant
                              ? "a constant fits the sizes (no N-dependence resolved)"
                          : ex.status == Extrapolation::Status::kExponentUnbounded
                              ? "only the smallest size deviates (alpha_O bounded below only)"
                          : ex.status == Extrapolation::Status::kNotResolved
                              ? "no convergence with N"
                              : "the fit failed";
        ex.resolution =
            std::string("not resolved: ") + why + ", over " + std::to_string(n_sizes) + " sizes";
      }
      if (ex.status == Extrapolation::Status::kFailed)
        r.failures.push_back(ex.message);
      if (ex.status == Extrapolation::Status::kExponentUnbounded ||
          ex.status == Extrapolation::Status::kConstant ||
          ex.status == Extrapolation::Status::kNotResolved) {
        r.warnings.push_back(ex.message);
      }
      r.extrapolations.push_back(std::move(ex));
    }
  }

  auto find = [&](const std::string& name) -> const Extrapolation* {
    for (const auto& ex : r.extrapolations) {
      // Only a resolved extrapolation gives N -> infinity values (nu, the collapse, eta).
      if (ex.parameter == name && ex.resolved)
        return &ex;
    }
    return nullptr;
  };
  auto find_b = [&](const std::string& name) -> const Extrapolation* {
    if (const Extrapolation* e = find(name))
      return e;
    for (const auto& ex : r.extrapolations) {
      // An exponent needs its N -> infinity value, not a resolved approach: a power law with an
      // amplitude consistent with 0, a size-independent b (constant) or one whose approach
      // exponent is only bounded below (alpha_unbounded) all have a determined O_inf.
      if (ex.parameter == name && (ex.status == Extrapolation::Status::kFit ||
                                   ex.status == Extrapolation::Status::kConstant ||
                                   ex.status == Extrapolation::Status::kExponentUnbounded))
        return &ex;
    }
    return nullptr;
  };
  // nu = b / (alpha_O d) with b the N -> infinity exponent (paper Eq. nu). alpha_O needs a
  // resolved extrapolation of O_J; b a resolved one, or else a size-independent b (status
  // constant: its weighted mean, stated in a warning).
  auto nu_from = [&](const std::string& b_name, const std::string& o_name,
                     std::optional<Measured>& out, double& out_systematic) {
    const Extrapolation* o = find(o_name);
    if (!o) {
      r.warnings.push_back("nu from " + o_name + " not determined: the extrapolation of " + o_name +
                           "(N) is not resolved");
      return;
    }
    const Extrapolation* b = find_b(b_name);
    if (!b) {
      {
        r.warnings.push_back("nu from " + o_name + " not determined: " + b_name +
                             "(N -> infinity) is not resolved");
        return;
      }
    }
    if (b->status == Extrapolation::Status::kConstant)
      r.warnings.push_back("nu from " + o_name + ": " + b_name +
                           " shows no significant N-dependence; its weighted mean over the "
                           "sizes is used as " +
                           b_name + "(N -> infinity)");
    const double d = options.dimension;
    const std::vector<double> p = {b->inf.value, o->fit->params[2]};
    const std::vector<double> cov = {b->inf.error * b->inf.error, 0.0, 0.0, o->fit->cov(2, 2)};
    try {
      out = propagate([d](std::span<const double> q) { return q[0] / (q[1] * d); }, p, cov,
                      "nu = " + b_name + " / (alpha_" + o_name + " d)");
      out_systematic = std::fabs(out->value) * b->systematic / std::fabs(b->inf.value);
    } catch (const AnalysisError& e) {
      r.failures.push_back(e.what());
    }
  };
  nu_from("b_phi", "phi_J", r.nu_phi, r.nu_phi_systematic);
  nu_from("b_mu", "mu_J", r.nu_mu, r.nu_mu_systematic);

  // The finite-size collapse (Fig. 6), from the N -> infinity fits of O_J and b.
  auto collapse = [&](const std::string& o_name, const std::string& b_name,
                      const std::string& label) {
    FiniteSizeCollapse c;
    c.parameter = label;
    const Extrapolation* o = find(o_name);
    const Extrapolation* b = find_b(b_name);
    if (!o || o->status != Extrapolation::Status::kFit) {
      c.unavailable = o_name + "(N) = " + o_name +
                      "_inf + A N^-alpha is not fitted (A and alpha are needed to scale)";
      return c;
    }
    if (!b || !(b->inf.value > 0.0)) {
      c.unavailable = b_name + "(N -> infinity) is not determined";
      return c;
    }
    c.inf = o->fit->params[0];
    c.a = o->fit->params[1];
    c.alpha = o->fit->params[2];
    c.b = b->inf.value;
    for (std::size_t k = 0; k < r.sizes.size(); ++k) {
      const SizeFit& s = r.sizes[k];
      const double nn = static_cast<double>(s.n);
      const double shift = c.a * std::pow(nn, -c.alpha);
      if (!(std::fabs(shift) > 0.0))
        continue;
      for (const auto& e : s.points) {
        if (!in_envelope(e.status))
          continue;
        const double v = label == "phi" ? e.point.phi : e.point.mu;
        const double err = label == "phi" ? e.point.phi_err : e.point.mu_err;
        if (!(err > 0.0))
          continue;
        c.scaled.push_back({e.point.j * std::pow(nn, c.alpha / c.b), (v - c.inf) / shift,
                            err / std::fabs(shift), k, 0});
      }
    }
    // The quality in the coordinates of the paper's log-log plot, where the
    // master curve 1 + |C/A| x^b is straight in both limits: ln x, ln y and
    // d(ln y) = dy / y. Points with y <= 0 (noise larger than the finite-size
    // shift) cannot be placed there and do not count.
    std::vector<CollapsePoint> logs;
    for (const auto& q : c.scaled) {
      if (q.y > 0.0)
        logs.push_back({std::log(q.x), std::log(q.y), q.dy / q.y, q.curve, 0});
    }
    c.quality = houdayer_hartmann(logs);
    c.quality.total = c.scaled.size();
    if (c.quality.used == 0)
      c.unavailable = "no two sizes overlap in x = J N^(alpha/b)";
    return c;
  };
  r.collapse_phi = collapse("phi_J", "b_phi", "phi");
  r.collapse_mu = collapse("mu_J", "b_mu", "mu");

  // Viscosity law: N -> infinity parameters when all six extrapolated, else
  // the largest size (stated in the output).
  std::vector<double> params, cov, systematic;
  std::string source;
  bool all = !r.extrapolations.empty();
  for (const auto& name : names)
    all = all && find(name) != nullptr;
  if (all) {
    std::vector<std::vector<double>> blocks;
    for (const auto& name : names) {
      const Extrapolation* ex = find(name);
      params.push_back(ex->inf.value);
      blocks.push_back({ex->inf.error * ex->inf.error});
      systematic.push_back(ex->systematic);
    }
    cov = block_diagonal(blocks, {1, 1, 1, 1, 1, 1});
    source = "N -> infinity";
  } else {
    size_parameters(r.sizes.back(), params, cov);
    for (const auto& name : names) {  // Table 2 order: phi_J, b_phi, C_phi, mu_J, b_mu, C_mu
      const bool phi = name.find("phi") != std::string::npos;
      const ErrorModel& em = phi ? r.sizes.back().phi_errors : r.sizes.back().mu_errors;
      double sys = 0.0;
      for (const auto& pe : em.parameters)
        if (pe.name == name)
          sys = pe.systematic();
      systematic.push_back(sys);
    }
    source = "N = " + std::to_string(r.sizes.back().n);
    r.warnings.push_back("viscosity law uses the largest size (" + source +
                         ") because the N -> infinity extrapolation is not available");
  }
  const double phi_j = params[0];
  const double wmin = options.window_min.value_or(phi_j - 0.1);
  const double wmax = options.window_max.value_or(phi_j - 0.01);
  // An explicit window outside the law's domain is a usage error (InputError
  // propagates); a numerical failure is recorded and the rest still written.
  try {
    r.viscosity = viscosity_law(params, cov, source, wmin, wmax, systematic);
  } catch (const FitError& e) {
    r.failures.push_back(e.what());
  }
  return r;
}

}  // namespace jamflow::analysis
