// The error model of the fits (analysis/error_model.hpp) on synthetic tables: chi2/dof scaling,
// the J-window and fit-form systematics, and the degeneracy flag.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "analysis/error_model.hpp"
#include "analysis/fit.hpp"

namespace jamflow::analysis {
namespace {

const PowerLawForm kPhiForm{-1.0, 1.0, 0.03, 1.5, "phi_J", "C_phi", "b_phi"};

// phi = 0.645 - 0.07 J^0.4 at 10 J values from 1 to 1e-3, with errors sigma and offsets
// `noise` (in units of sigma) added to y.
FitData phi_table(double sigma, const std::vector<double>& noise) {
  FitData d;
  for (int i = 0; i < 10; ++i) {
    const double j = std::pow(10.0, -3.0 * i / 9.0);
    d.x.push_back(j);
    d.y.push_back(0.645 - 0.07 * std::pow(j, 0.4) + sigma * noise[i]);
    d.sigma.push_back(sigma);
  }
  return d;
}

TEST(ErrorModel, ChiSquarePerDofOfFourDoublesTheError) {
  // A fixed pattern of residuals gives some chi2/dof = c; the same residuals with the errors
  // stated sqrt(c)/2 times smaller give chi2/dof = 4 exactly, and the scaled error must equal
  // twice the unscaled one (scale = sqrt(4)) to rounding (1e-9 relative).
  const std::vector<double> pattern = {1, -1, 0.5, -0.8, 1.2, -1.1, 0.3, 0.9, -0.7, -0.4};
  FitOptions unscaled;
  unscaled.scale_errors_by_chi2 = false;
  const FitResult probe = fit_power_law_offset(phi_table(1e-4, pattern), kPhiForm, unscaled);
  const double c = probe.reduced_chi2();
  ASSERT_GT(c, 0.0);
  // Residuals fixed in y; errors shrunk so that chi2/dof = 4.
  FitData d = phi_table(1e-4, pattern);
  for (double& s : d.sigma)
    s *= std::sqrt(c / 4.0);
  const FitResult raw = fit_power_law_offset(d, kPhiForm, unscaled);
  ASSERT_NEAR(raw.reduced_chi2(), 4.0, 1e-6);
  FitOptions scaled;  // the default
  const FitResult fit = fit_power_law_offset(d, kPhiForm, scaled);
  EXPECT_TRUE(fit.errors_scaled);
  for (std::size_t k = 0; k < 3; ++k)
    EXPECT_NEAR(fit.at(k).error, 2.0 * raw.at(k).error, 1e-6 * raw.at(k).error) << fit.names[k];
  const ErrorModel m = statistical_error_model(fit, {});
  EXPECT_TRUE(m.errors_scaled);
  EXPECT_NEAR(m.reduced_chi2, 4.0, 1e-6);
}

TEST(ErrorModel, ChiSquarePerDofBelowOneLeavesTheErrorAlone) {
  const std::vector<double> pattern = {0.1, -0.1, 0.05, -0.08, 0.1, -0.1, 0.03, 0.09, -0.07, -0.04};
  const FitData d = phi_table(1e-4, pattern);
  FitOptions unscaled;
  unscaled.scale_errors_by_chi2 = false;
  const FitResult raw = fit_power_law_offset(d, kPhiForm, unscaled);
  ASSERT_LT(raw.reduced_chi2(), 1.0);
  const FitResult fit = fit_power_law_offset(d, kPhiForm, FitOptions{});
  EXPECT_FALSE(fit.errors_scaled);
  EXPECT_DOUBLE_EQ(fit.at(0).error, raw.at(0).error);
}

TEST(ErrorModel, WindowSystematicVanishesOnTheExactLawAndNotOnCurvedData) {
  // Exact law: every refit recovers the same parameters (shift ~ 0: below 1e-6 of the
  // statistical error, the optimiser's tolerance).
  const FitData exact = phi_table(1e-4, std::vector<double>(10, 0.0));
  const FitResult base = fit_power_law_offset(exact, kPhiForm, FitOptions{});
  const ErrorModel m =
      power_law_error_model(exact, kPhiForm, base, FitOptions{}, std::nullopt, {}, "J");
  for (const auto& p : m.parameters)
    EXPECT_LT(p.window, 1e-3 * p.statistical) << p.name;
  // Curved data: a second power law the form does not have (0.02 J^1.5, as a finite-pressure
  // shift does at large J); dropping an end of the J window moves the fit by more than 0.1 of
  // its statistical error.
  FitData curved = exact;
  for (std::size_t i = 0; i < curved.size(); ++i)
    curved.y[i] -= 0.02 * std::pow(curved.x[i], 1.5);
  const FitResult cb = fit_power_law_offset(curved, kPhiForm, FitOptions{});
  const ErrorModel cm =
      power_law_error_model(curved, kPhiForm, cb, FitOptions{}, std::nullopt, {}, "J");
  EXPECT_GT(cm["phi_J"].window, 0.1 * cm["phi_J"].statistical);
  EXPECT_GT(cm["phi_J"].systematic(), 0.0);
}

TEST(ErrorModel, FormSystematicIsTheShiftWithTheExponentFixed) {
  const FitData exact = phi_table(1e-4, std::vector<double>(10, 0.0));
  const FitResult base = fit_power_law_offset(exact, kPhiForm, FitOptions{});
  // At the true exponent the fixed-b fit is the same law: no shift.
  const ErrorModel same = power_law_error_model(exact, kPhiForm, base, FitOptions{}, 0.4, {}, "J");
  EXPECT_LT(same["phi_J"].form, 1e-6);
  // At another exponent phi_J moves.
  const ErrorModel other = power_law_error_model(exact, kPhiForm, base, FitOptions{}, 0.3, {}, "J");
  EXPECT_GT(other["phi_J"].form, 1e-3);
  EXPECT_TRUE(std::isnan(other["b_phi"].form));  // b has no form systematic
}

TEST(ErrorModel, DegenerateFitsAreFlagged) {
  FitResult f;
  f.names = {"mu_J", "C_mu", "b_mu"};
  f.params = {-0.72, 1.12, 0.057};
  f.covariance = {2.4 * 2.4, 0, 0, 0, 2.4 * 2.4, 0, 0, 0, 0.14 * 0.14};
  f.dof = 1;
  const std::vector<ParameterBound> bounds = {{"mu_J", 0.0, std::nullopt}};
  const ErrorModel m = statistical_error_model(f, bounds);
  EXPECT_TRUE(m.degenerate);
  EXPECT_NE(m.degenerate_reason.find("mu_J"), std::string::npos);
  // A well-determined physical fit is not.
  f.params = {0.11, 0.35, 0.35};
  f.covariance = {1e-4, 0, 0, 0, 1e-4, 0, 0, 0, 1e-4};
  EXPECT_FALSE(statistical_error_model(f, bounds).degenerate);
}

TEST(ErrorModel, DropExtremeXDropsEveryPointAtTheEdge) {
  FitData d;
  d.x = {1, 1, 0.1, 0.01};
  d.y = {1, 2, 3, 4};
  d.sigma = {1, 1, 1, 1};
  EXPECT_EQ(drop_extreme_x(d, true).size(), 2u);
  EXPECT_EQ(drop_extreme_x(d, false).size(), 3u);
}

// Estimates that scatter twice their errors: chi2/dof = 4 (n - 1 dof), errors scaled by 2;
// estimates within their errors keep them.
TEST(ErrorModel, ScatterOfEstimatesScalesErrorsThatUnderstateIt) {
  const Scatter wide = scatter_of({-2.0, 2.0}, {1.0, 1.0});
  EXPECT_DOUBLE_EQ(wide.mean, 0.0);
  EXPECT_EQ(wide.dof, 1);
  EXPECT_DOUBLE_EQ(wide.reduced_chi2, 8.0);
  EXPECT_DOUBLE_EQ(wide.error_scale, std::sqrt(8.0));
  const Scatter four = scatter_of({-1.0, 1.0, -1.0, 1.0, -1.0, 1.0},
                                  std::vector<double>(6, 0.5 * std::sqrt(6.0 / 5.0)));
  EXPECT_NEAR(four.reduced_chi2, 4.0, 1e-12);
  EXPECT_NEAR(four.error_scale, 2.0, 1e-12);
  const Scatter narrow = scatter_of({0.9, 1.1}, {1.0, 1.0});
  EXPECT_DOUBLE_EQ(narrow.error_scale, 1.0);
  EXPECT_EQ(scatter_of({1.0}, {0.1}).dof, 0);
  EXPECT_DOUBLE_EQ(scatter_of({1.0}, {0.1}).error_scale, 1.0);
}

}  // namespace
}  // namespace jamflow::analysis
