// Soft granular rheology: per-pressure collapse, phi_J(P) and mu_J(P) power
// laws (x = 0.75, y = 0.56) and the yield-stress law, on synthetic data.
// Tolerances: 5 reported sigma for phi_J(P), mu_J(P) and the fitted
// exponents. The envelope's small bias (test_hard_sphere.cpp) enters through
// the hard-sphere shape and shifts all phi_J(P) together; over 30 seeds the
// worst pull was 4.0.
#include <gtest/gtest.h>

#include <cmath>

#include "analysis/errors.hpp"
#include "analysis/soft.hpp"
#include "tests/analysis/synthetic.hpp"

namespace jamflow::analysis {
namespace {

using testing::GranularSpec;
using testing::make_granular;
using testing::table2_at;

void expect_within(const Measured& m, double truth, double nsigma, const std::string& what) {
  EXPECT_LE(std::fabs(m.value - truth), nsigma * m.error)
      << what << ": " << m.value << " +- " << m.error << " vs truth " << truth;
}

HardSphereShape exact_shape(std::int64_t n) {
  const auto t = table2_at(static_cast<double>(n));
  HardSphereShape s;
  s.c_phi = t.c_phi;
  s.b_phi = t.b_phi;
  s.c_mu = t.c_mu;
  s.b_mu = t.b_mu;
  s.source = "exact";
  return s;
}

GranularSpec six_pressures() {
  GranularSpec spec;
  spec.pressures = {1e-7, 1e-6, 1e-5, 1e-4, 1e-3, 1e-2};
  return spec;
}

TEST(SoftCollapse, NoiselessDataCollapseExactly) {
  GranularSpec spec = six_pressures();
  spec.rel_noise = 1e-9;
  const testing::SoftTruth soft;
  const auto t = table2_at(1000);
  for (const auto& c : collapse_pressures(make_granular(spec), exact_shape(1000))) {
    EXPECT_NEAR(c.phi_j.value, t.phi_j + soft.c_phi * std::pow(c.pressure, soft.x), 1e-10);
    EXPECT_NEAR(c.mu_j.value, t.mu_j - soft.c_mu * std::pow(c.pressure, soft.y), 1e-10);
  }
}

TEST(Soft, RecoversPressureExponentsWithTheFittedHardSphereShape) {
  SoftResult r = analyze_soft(make_granular(six_pressures()), SoftOptions{});
  ASSERT_EQ(r.sizes.size(), 1u);
  const SoftSize& s = r.sizes[0];
  const auto t = table2_at(1000);
  const testing::SoftTruth soft;
  expect_within(s.phi_fit["phi_J0"], t.phi_j, 5, "phi_J(0)");
  expect_within(s.phi_fit["c_phi"], soft.c_phi, 5, "c_phi");
  expect_within(s.phi_fit["x"], soft.x, 5, "x");
  expect_within(s.mu_fit["mu_J0"], t.mu_j, 5, "mu_J(0)");
  expect_within(s.mu_fit["c_mu"], soft.c_mu, 5, "c_mu");
  expect_within(s.mu_fit["y"], soft.y, 5, "y");
  ASSERT_EQ(s.pressures.size(), 6u);
  for (const auto& c : s.pressures) {
    expect_within(c.phi_j, t.phi_j + soft.c_phi * std::pow(c.pressure, soft.x), 5, "phi_J(P)");
    expect_within(c.mu_j, t.mu_j - soft.c_mu * std::pow(c.pressure, soft.y), 5, "mu_J(P)");
  }
  // Yield stress: leading exponent 1/x (paper: 1.33), sub-dominant (1+y)/x.
  expect_within(s.yield.exponent_1, 1 / soft.x, 5, "1/x");
  expect_within(s.yield.exponent_2, (1 + soft.y) / soft.x, 5, "(1+y)/x");
}

TEST(Soft, FixedShapeOption) {
  SoftOptions o;
  o.fixed_shape = exact_shape(1000);
  SoftResult r = analyze_soft(make_granular(six_pressures()), o);
  expect_within(r.sizes[0].phi_fit["x"], 0.75, 4, "x");
  expect_within(r.sizes[0].mu_fit["y"], 0.56, 4, "y");
  EXPECT_EQ(r.sizes[0].shape.source, "exact");
}

TEST(Soft, YieldLawIsTheSumOfItsTwoPowerLaws) {
  SoftOptions o;
  o.fixed_shape = exact_shape(1000);
  const SoftSize s = analyze_soft(make_granular(six_pressures()), o).sizes[0];
  const double phi0 = s.phi_fit.params[0];
  for (double d : {1e-3, 1e-2, 3e-2}) {
    const double two = s.yield.amplitude_1.value * std::pow(d, s.yield.exponent_1.value) -
                       s.yield.amplitude_2.value * std::pow(d, s.yield.exponent_2.value);
    EXPECT_NEAR(s.yield.sigma_y(phi0 + d), two, 1e-12 * std::fabs(two));
  }
  EXPECT_EQ(s.yield.sigma_y(phi0 - 0.01), 0.0);  // no yield stress below jamming
}

TEST(Soft, TooFewPressuresOrSinglePoints) {
  SoftOptions o;
  o.fixed_shape = exact_shape(1000);
  GranularSpec spec;
  spec.pressures = {1e-6, 1e-5, 1e-4};
  try {
    analyze_soft(make_granular(spec), o);
    FAIL() << "expected InsufficientDataError";
  } catch (const InsufficientDataError& e) {
    EXPECT_NE(std::string(e.what()).find("at least 4"), std::string::npos) << e.what();
  }
  spec.pressures = {1e-6, 1e-5, 1e-4, 1e-3};
  auto pts = make_granular(spec);
  pts.push_back(pts.front());
  pts.back().pressure = 3e-3;  // a pressure with one point
  EXPECT_THROW(analyze_soft(pts, o), InsufficientDataError);
}

}  // namespace
}  // namespace jamflow::analysis
