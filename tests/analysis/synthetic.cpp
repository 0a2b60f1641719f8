// Synthetic data from the paper's formulas (see synthetic.hpp).
#include "tests/analysis/synthetic.hpp"

#include <cmath>
#include <stdexcept>

#include "analysis/json.hpp"

namespace jamflow::analysis::testing {

namespace {

double finite_size(double inf, double a, double alpha, double n) {
  return inf + a * std::pow(n, -alpha);
}

std::vector<double> log_grid(double lo, double hi, int per_decade) {
  std::vector<double> out;
  const int steps = static_cast<int>(std::lround(std::log10(hi / lo) * per_decade));
  for (int k = 0; k <= steps; ++k)
    out.push_back(lo * std::pow(10.0, double(k) / per_decade));
  return out;
}

}  // namespace

RheologyParams table2_at(double n) {
  return {finite_size(0.6474, -0.323, 0.852, n), finite_size(0.391, 0.756, 0.505, n),
          finite_size(0.0683, -1.15, 1.17, n),   finite_size(0.108, 0.279, 0.626, n),
          finite_size(0.346, 2.93, 0.946, n),    finite_size(0.347, -1.44, 1.02, n)};
}

RheologyParams table2_infinite() {
  return {0.6474, 0.391, 0.0683, 0.108, 0.346, 0.347};
}

std::vector<GranularPoint> make_granular(const GranularSpec& spec) {
  std::mt19937_64 rng(spec.seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<GranularPoint> out;
  for (auto n : spec.sizes) {
    RheologyParams t = table2_at(static_cast<double>(n));
    if (spec.size_independent_shape) {
      const RheologyParams inf = table2_infinite();
      t.b_phi = inf.b_phi;
      t.c_phi = inf.c_phi;
      t.b_mu = inf.b_mu;
      t.c_mu = inf.c_mu;
    }
    for (double p : spec.pressures) {
      const double shift_phi =
          spec.soft ? spec.soft_truth.c_phi * std::pow(p, spec.soft_truth.x) : 0;
      const double shift_mu = spec.soft ? spec.soft_truth.c_mu * std::pow(p, spec.soft_truth.y) : 0;
      for (double g : log_grid(spec.gdot_min, spec.gdot_max, spec.points_per_decade)) {
        GranularPoint q;
        q.n = n;
        q.pressure = p;
        q.shear_rate = g;
        q.j = g / p;
        const double dphi = t.c_phi * std::pow(q.j, t.b_phi);
        const double dmu = t.c_mu * std::pow(q.j, t.b_mu);
        q.phi_err = spec.rel_noise * dphi;
        q.mu_err = spec.rel_noise * dmu;
        q.phi = t.phi_j + shift_phi - dphi + q.phi_err * normal(rng);
        q.mu = t.mu_j - shift_mu + dmu + q.mu_err * normal(rng);
        q.source = "synthetic";
        out.push_back(q);
      }
    }
  }
  return out;
}

double g_plus(double x, double q) {
  return 1.0 + std::pow(x, q);
}
double g_minus(double x, double q) {
  return x / (1.0 + std::pow(x, 1.0 - q));
}

std::vector<ShearPoint> make_two_branch(const TwoBranchSpec& spec) {
  std::mt19937_64 rng(spec.seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  const double q = spec.alpha / (spec.alpha + spec.beta);
  std::vector<ShearPoint> out;
  for (double phi : spec.phis) {
    const double d = std::fabs(phi - spec.phi_j);
    for (double g : log_grid(spec.gdot_min, spec.gdot_max, spec.points_per_decade)) {
      const double x = g / std::pow(d, spec.alpha + spec.beta);
      const double gx = phi > spec.phi_j ? g_plus(x, q) : g_minus(x, q);
      ShearPoint s;
      s.n = spec.n;
      s.phi = phi;
      s.shear_rate = g;
      const double sigma = std::pow(d, spec.alpha) * gx;
      s.sigma_err = spec.rel_noise * sigma;
      s.sigma = sigma * std::exp(spec.rel_noise * normal(rng));
      s.set = "N=" + std::to_string(spec.n) + ",phi=" + format_key(phi);
      s.source = "synthetic";
      out.push_back(s);
    }
  }
  return out;
}

std::vector<ShearPoint> make_soft_flow_curves(const TwoBranchSpec& spec, const SoftTruth& soft) {
  std::mt19937_64 rng(spec.seed);
  std::mt19937_64 rng_p(spec.seed + 1000);  // the pressures' noise, apart from sigma's
  std::normal_distribution<double> normal(0.0, 1.0);
  const RheologyParams t = table2_infinite();
  std::vector<ShearPoint> out;
  for (double phi : spec.phis) {
    for (double g : log_grid(spec.gdot_min, spec.gdot_max, spec.points_per_decade)) {
      // phi(P) at fixed gdot increases with P: bisection in ln P.
      auto f = [&](double lp) {
        const double p = std::exp(lp);
        return t.phi_j + soft.c_phi * std::pow(p, soft.x) - t.c_phi * std::pow(g / p, t.b_phi) -
               phi;
      };
      double lo = std::log(1e-16), hi = std::log(10.0);
      if (f(lo) > 0 || f(hi) < 0)
        throw std::runtime_error("soft flow curve: no pressure root");
      for (int it = 0; it < 200; ++it) {
        const double mid = 0.5 * (lo + hi);
        (f(mid) > 0 ? hi : lo) = mid;
      }
      const double p = std::exp(0.5 * (lo + hi));
      const double mu = t.mu_j - soft.c_mu * std::pow(p, soft.y) + t.c_mu * std::pow(g / p, t.b_mu);
      ShearPoint s;
      s.n = spec.n;
      s.phi = phi;
      s.shear_rate = g;
      const double sigma = p * mu;
      s.sigma_err = spec.rel_noise * sigma;
      s.sigma = sigma * std::exp(spec.rel_noise * normal(rng));
      s.pressure_err = spec.rel_noise * p;
      s.pressure = p * std::exp(spec.rel_noise * normal(rng_p));
      s.set = "N=" + std::to_string(spec.n) + ",phi=" + format_key(phi);
      s.source = "synthetic-soft";
      out.push_back(s);
    }
  }
  return out;
}

}  // namespace jamflow::analysis::testing
