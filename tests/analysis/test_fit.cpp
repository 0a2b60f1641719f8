// Weighted nonlinear least squares: exact recovery, the covariance against
// the analytic linear-regression result, correlated data, and failures.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "analysis/errors.hpp"
#include "analysis/fit.hpp"

namespace jamflow::analysis {
namespace {

TEST(Fit, StraightLineMatchesAnalyticWeightedRegression) {
  FitData d;
  for (int i = 0; i < 8; ++i) {
    d.x.push_back(i);
    d.y.push_back(1.0 + 2.0 * i + (i % 3 - 1) * 0.1);
    d.sigma.push_back(0.1 + 0.02 * i);
  }
  ModelFunction line = [](double x, std::span<const double> p, std::span<double> g) {
    if (!g.empty()) {
      g[0] = 1.0;
      g[1] = x;
    }
    return p[0] + p[1] * x;
  };
  FitOptions o;
  o.label = "line";
  FitResult r = fit_least_squares(d, line, {0.0, 1.0}, {"a", "b"}, o);
  // Analytic weighted least squares.
  double s = 0, sx = 0, sxx = 0, sy = 0, sxy = 0;
  for (std::size_t i = 0; i < d.size(); ++i) {
    double w = 1 / (d.sigma[i] * d.sigma[i]);
    s += w;
    sx += w * d.x[i];
    sxx += w * d.x[i] * d.x[i];
    sy += w * d.y[i];
    sxy += w * d.x[i] * d.y[i];
  }
  double det = s * sxx - sx * sx;
  EXPECT_NEAR(r.params[0], (sxx * sy - sx * sxy) / det, 1e-9);
  EXPECT_NEAR(r.params[1], (s * sxy - sx * sy) / det, 1e-9);
  EXPECT_NEAR(r.cov(0, 0), sxx / det, 1e-9 * sxx / det);
  EXPECT_NEAR(r.cov(1, 1), s / det, 1e-9 * s / det);
  EXPECT_NEAR(r.cov(0, 1), -sx / det, 1e-9 * sx / det);
  EXPECT_EQ(r.dof, 6);
}

TEST(Fit, PowerLawWithOffsetRecoversNoiselessParameters) {
  // phi = phi_J - C_phi J^b_phi with Table 2's N -> infinity values.
  FitData d;
  for (double j = 1e-6; j < 0.2; j *= 3) {
    d.x.push_back(j);
    d.y.push_back(0.6474 - 0.0683 * std::pow(j, 0.391));
    d.sigma.push_back(1e-5);
  }
  FitOptions o;
  PowerLawForm form{-1.0, 1.0, 0.03, 1.5, "phi_J", "C_phi", "b_phi"};
  FitResult r = fit_power_law_offset(d, form, o);
  EXPECT_NEAR(r["phi_J"].value, 0.6474, 1e-10);
  EXPECT_NEAR(r["C_phi"].value, 0.0683, 1e-10);
  EXPECT_NEAR(r["b_phi"].value, 0.391, 1e-9);
  EXPECT_LT(r.chi2, 1e-12);
  // N-extrapolation form O = inf + A N^-alpha, exponent outside the grid start.
  FitData n;
  for (double size : {100.0, 300.0, 500.0, 1000.0, 3000.0, 10000.0}) {
    n.x.push_back(size);
    n.y.push_back(0.108 + 0.279 * std::pow(size, -0.626));
    n.sigma.push_back(1e-4);
  }
  FitResult e = fit_power_law_offset(n, PowerLawForm{1.0, -1.0, 0.05, 3.0, "inf", "A", "alpha"}, o);
  EXPECT_NEAR(e["inf"].value, 0.108, 1e-9);
  EXPECT_NEAR(e["A"].value, 0.279, 1e-7);
  EXPECT_NEAR(e["alpha"].value, 0.626, 1e-7);
}

TEST(Fit, FullCovarianceEqualsDiagonalWhenUncorrelatedAndCountsCorrelations) {
  FitData d;
  for (double p : {1e-5, 1e-4, 1e-3, 1e-2, 1e-1}) {
    d.x.push_back(p);
    d.y.push_back(0.647 + 0.3 * std::pow(p, 0.75) + 1e-5 * std::sin(1e3 * p));
    d.sigma.push_back(2e-5);
  }
  FitData c = d;
  c.covariance.assign(25, 0.0);
  for (int i = 0; i < 5; ++i)
    c.covariance[i * 5 + i] = 4e-10;
  PowerLawForm form{1.0, 1.0, 0.05, 3.0, "a", "c", "x"};
  FitOptions o;
  FitResult rd = fit_power_law_offset(d, form, o);
  FitResult rc = fit_power_law_offset(c, form, o);
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_NEAR(rd.params[k], rc.params[k], 1e-9 * std::fabs(rd.params[k]));
    EXPECT_NEAR(rd.cov(k, k), rc.cov(k, k), 1e-6 * rd.cov(k, k));
  }
  // A common offset error (fully correlated) only inflates the offset's error:
  // the same data shifted together cannot change c or x.
  for (int i = 0; i < 5; ++i) {
    for (int j = 0; j < 5; ++j)
      c.covariance[i * 5 + j] += 1e-8;
  }
  FitResult rs = fit_power_law_offset(c, form, o);
  EXPECT_NEAR(rs.cov(0, 0), rd.cov(0, 0) + 1e-8, 1e-3 * (rd.cov(0, 0) + 1e-8));
  EXPECT_NEAR(rs.cov(2, 2), rd.cov(2, 2), 1e-3 * rd.cov(2, 2));
}

TEST(Fit, TooFewPointsIsInsufficientData) {
  FitData d{{1e-4, 1e-3, 1e-2}, {0.64, 0.63, 0.61}, {1e-4, 1e-4, 1e-4}, {}};
  FitOptions o;
  o.label = "phi = phi_J - C_phi J^b_phi (N=1000)";
  try {
    fit_power_law_offset(d, PowerLawForm{-1.0, 1.0, 0.03, 1.5, "phi_J", "C_phi", "b_phi"}, o);
    FAIL() << "expected InsufficientDataError";
  } catch (const InsufficientDataError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("N=1000"), std::string::npos) << msg;
    EXPECT_NE(msg.find("at least 4 points"), std::string::npos) << msg;
  }
}

TEST(Fit, NonFiniteDataOrErrorsFailLoudly) {
  FitData d{{1e-4, 1e-3, 1e-2, 1e-1},
            {0.64, std::numeric_limits<double>::quiet_NaN(), 0.61, 0.6},
            {1e-4, 1e-4, 1e-4, 1e-4},
            {}};
  FitOptions o;
  PowerLawForm form{-1.0, 1.0, 0.03, 1.5};
  EXPECT_THROW(fit_power_law_offset(d, form, o), FitError);
  d.y[1] = 0.63;
  d.sigma[2] = 0.0;
  EXPECT_THROW(fit_power_law_offset(d, form, o), FitError);
  d.sigma[2] = 1e-4;
  d.x[0] = -1.0;  // a power law needs x > 0
  EXPECT_THROW(fit_power_law_offset(d, form, o), FitError);
}

TEST(Fit, UnconstrainedParameterIsAnErrorNotAZeroErrorBar) {
  // Constant data: C = 0, so the exponent b is not determined at all.
  FitData d;
  for (double j = 1e-5; j < 1; j *= 10) {
    d.x.push_back(j);
    d.y.push_back(0.6);
    d.sigma.push_back(1e-4);
  }
  FitOptions o;
  o.label = "flat";
  EXPECT_THROW(fit_power_law_offset(d, PowerLawForm{-1.0, 1.0, 0.03, 1.5}, o), FitError);
}

TEST(Propagate, MatchesAnalyticLinearPropagation) {
  // nu = b / (3 alpha), independent b and alpha.
  std::vector<double> p = {0.391, 0.852};
  std::vector<double> cov = {0.01 * 0.01, 0.0, 0.0, 0.05 * 0.05};
  Measured nu =
      propagate([](std::span<const double> q) { return q[0] / (3 * q[1]); }, p, cov, "nu");
  const double v = 0.391 / (3 * 0.852);
  EXPECT_NEAR(nu.value, v, 1e-15);
  EXPECT_NEAR(nu.error, v * std::hypot(0.01 / 0.391, 0.05 / 0.852), 1e-8);
  EXPECT_THROW(propagate([](std::span<const double>) { return std::nan(""); }, p, cov, "bad"),
               FitError);
}

}  // namespace
}  // namespace jamflow::analysis
