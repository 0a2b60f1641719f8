// Hard-sphere envelope, per-size fits, large-N extrapolation, nu and the
// viscosity law, on synthetic data from the paper's formulas (Table 2 plus
// soft-rheology finite-pressure shifts; see synthetic.hpp).
//
// Tolerances: parameters are checked against the truth within 4 reported
// sigma (5 after the large-N extrapolation). The envelope keeps points that
// agree with another pressure within z = 2 combined sigma (and drops one
// guard point above each deviation onset), so accepted points can still
// carry part of a finite-pressure shift; over 100 seeds this biased the
// per-size parameters by <= 0.4 sigma with rms pulls <= 1.15 (worst of 180
// pulls over 30 seeds: 2.9), so a 4-sigma band is safe yet still catches a
// wrong envelope (keeping the deviating points moves b_phi by > 10 sigma).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "analysis/collapse.hpp"
#include "analysis/errors.hpp"
#include "analysis/hard_sphere.hpp"
#include "analysis/json.hpp"
#include "analysis/report.hpp"
#include "analysis/seed.hpp"
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

TEST(Envelope, HardSphereDataAreAcceptedWhereverTheyCanBeTested) {
  GranularSpec spec;
  spec.soft = false;  // no finite-pressure effect at all
  auto pts = make_granular(spec);
  auto env = select_envelope(pts, EnvelopeOptions{});
  std::size_t accepted = 0;
  double jmin = 1, jmax = 0;
  for (const auto& e : env) {
    if (!in_envelope(e.status))
      continue;
    ++accepted;
    jmin = std::min(jmin, e.point.j);
    jmax = std::max(jmax, e.point.j);
  }
  // 52 points; the 3 of P = 1e-4 below J = 1e-8 cannot be compared with
  // anything. With z = 2 a pull test fails by chance for ~9 % of the points,
  // but an isolated failure excludes only that point.
  EXPECT_GE(accepted, 40u);
  EXPECT_LE(jmin, 1.01e-8);  // the envelope reaches the smallest testable J
  EXPECT_GE(jmax, 0.99e-2);
}

TEST(Envelope, FinitePressureDeviationsAtSmallJAreRejected) {
  GranularSpec spec;
  spec.sizes = {300, 1000, 3000};
  auto pts = make_granular(spec);
  const testing::SoftTruth soft;
  std::size_t accepted = 0, accepted_off = 0, rejected_off = 0, accepted_far = 0;
  for (std::int64_t n : spec.sizes) {
    std::vector<GranularPoint> one;
    for (const auto& p : pts) {
      if (p.n == n)
        one.push_back(p);
    }
    for (const auto& e : select_envelope(one, EnvelopeOptions{})) {
      // True deviation from the P -> 0 value, in units of the point's error.
      const double dev = std::max(soft.c_phi * std::pow(e.point.pressure, soft.x) / e.point.phi_err,
                                  soft.c_mu * std::pow(e.point.pressure, soft.y) / e.point.mu_err);
      const bool in = in_envelope(e.status);
      accepted += in;
      accepted_off += in && dev > 4;
      accepted_far += in && dev > 10;
      rejected_off += !in && dev > 4;
    }
  }
  EXPECT_GT(accepted, 50u);
  EXPECT_GT(rejected_off, 60u);  // the test data really deviate at small J
  // Accepted points may carry up to ~4 sigma of shift (see the header), rarely more.
  EXPECT_LE(accepted_off, accepted / 20) << accepted_off << " of " << accepted;
  EXPECT_EQ(accepted_far, 0u);
}

TEST(Envelope, SinglePressureCannotBeTested) {
  GranularSpec spec;
  spec.pressures = {1e-5};
  try {
    fit_size(1000, make_granular(spec), HardSphereOptions{});
    FAIL() << "expected InsufficientDataError";
  } catch (const InsufficientDataError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("N=1000"), std::string::npos) << msg;
    EXPECT_NE(msg.find("only 0 of 13"), std::string::npos) << msg;
    EXPECT_NE(msg.find("single pressure"), std::string::npos) << msg;
  }
}

TEST(Envelope, AllPointsOutsideWhenNoTwoPressuresAgree) {
  GranularSpec spec;
  spec.pressures = {1e-3, 1e-2};  // shifts of tens of sigma everywhere
  try {
    fit_size(1000, make_granular(spec), HardSphereOptions{});
    FAIL() << "expected InsufficientDataError";
  } catch (const InsufficientDataError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("only 0 of 26"), std::string::npos) << msg;
    EXPECT_NE(msg.find("no two pressures agree"), std::string::npos) << msg;
  }
}

TEST(Envelope, TooFewPointsForTheFit) {
  GranularSpec spec;
  spec.soft = false;
  spec.pressures = {1e-6, 1e-5};
  spec.gdot_min = 1e-12;
  spec.gdot_max = 1e-11;  // J = {1e-6, 1e-5} and {1e-7, 1e-6}: one common J
  spec.points_per_decade = 1;
  try {
    fit_size(1000, make_granular(spec), HardSphereOptions{});
    FAIL() << "expected InsufficientDataError";
  } catch (const InsufficientDataError& e) {
    EXPECT_NE(std::string(e.what()).find("need at least 4"), std::string::npos) << e.what();
  }
}

TEST(HardSphere, RecoversOneSizeFromDataWithFinitePressureDeviations) {
  GranularSpec spec;
  auto pts = make_granular(spec);
  SizeFit s = fit_size(1000, pts, HardSphereOptions{});
  const auto t = table2_at(1000);
  expect_within(s.phi["phi_J"], t.phi_j, 4, "phi_J");
  expect_within(s.phi["C_phi"], t.c_phi, 4, "C_phi");
  expect_within(s.phi["b_phi"], t.b_phi, 4, "b_phi");
  expect_within(s.mu["mu_J"], t.mu_j, 4, "mu_J");
  expect_within(s.mu["C_mu"], t.c_mu, 4, "C_mu");
  expect_within(s.mu["b_mu"], t.b_mu, 4, "b_mu");
  EXPECT_LT(s.phi.reduced_chi2(), 2.5);
  EXPECT_LT(s.mu.reduced_chi2(), 2.5);
  // Without the envelope (all points), the deviations bias the fit grossly.
  FitData all;
  for (const auto& p : pts) {
    all.x.push_back(p.j);
    all.y.push_back(p.phi);
    all.sigma.push_back(p.phi_err);
  }
  // Bias against the stated errors: unscaled (scaling by chi2/dof would absorb the bias into
  // the error bar, which is what the default does for real data).
  FitOptions unscaled;
  unscaled.scale_errors_by_chi2 = false;
  FitResult naive = fit_power_law_offset(all, PowerLawForm{-1.0, 1.0, 0.03, 1.5}, unscaled);
  EXPECT_GT(std::fabs(naive.params[2] - t.b_phi), 10 * naive.at(2).error);
}

// The viscosity range of the envelope: its J ends are those of the accepted points, and on
// hard-sphere data from Table 2's law the decades it reaches are the decades the seed's law
// spans over the same J (2% noise on mu's J-dependent part moves each end by < 0.005 decades;
// tolerance 0.02).
TEST(HardSphere, EnvelopeViscosityRangeMatchesTheSeedsLawOverTheSameJ) {
  GranularSpec spec;
  spec.soft = false;
  const HardSphereResult r = analyze_hard_sphere(make_granular(spec), HardSphereOptions{});
  ASSERT_EQ(r.sizes.size(), 1u);
  double j_lo = 1e300, j_hi = 0.0;
  for (const auto& e : r.sizes[0].points) {
    if (!in_envelope(e.status))
      continue;
    j_lo = std::min(j_lo, e.point.j);
    j_hi = std::max(j_hi, e.point.j);
  }
  const Json ee =
      hard_sphere_json(r, HardSphereOptions{}, {}).at("sizes").at("1000").at("envelope_eta");
  EXPECT_DOUBLE_EQ(ee.at("J_min").as_number(), j_lo);
  EXPECT_DOUBLE_EQ(ee.at("J_max").as_number(), j_hi);
  EXPECT_GT(ee.at("decades").as_number(), 5.0);  // J from about 1e-8 to 1e-2
  EXPECT_NEAR(ee.at("seed_decades").as_number(), ee.at("decades").as_number(), 0.02);
}

TEST(HardSphere, FullAnalysisRecoversTable2AndNu) {
  GranularSpec spec;
  spec.sizes = {100, 300, 500, 1000, 3000, 10000};
  HardSphereResult r = analyze_hard_sphere(make_granular(spec), HardSphereOptions{});
  ASSERT_TRUE(r.extrapolation_skipped.empty());
  ASSERT_TRUE(r.failures.empty()) << r.failures.front();
  const auto inf = testing::table2_infinite();
  const double truth[6] = {inf.phi_j, inf.b_phi, inf.c_phi, inf.mu_j, inf.b_mu, inf.c_mu};
  ASSERT_EQ(r.extrapolations.size(), 6u);
  using Status = Extrapolation::Status;
  for (std::size_t k = 0; k < 6; ++k) {
    const Extrapolation& e = r.extrapolations[k];
    // phi_J, b_phi, mu_J vary strongly with N (Table 2's A N^-alpha is many
    // sigma between N = 100 and 1e4): their power law must be resolved. The
    // others vary by ~1-4 sigma only and may come out unresolved/constant.
    if (k == 0 || k == 1 || k == 3) {
      ASSERT_EQ(e.status, Status::kFit) << e.parameter << ": " << e.message;
    }
    ASSERT_NE(e.status, Status::kFailed) << e.message;
    if (e.status == Status::kNotResolved)
      continue;
    // 5 sigma: the envelope's bias (<= 0.4 sigma per size, rms pull <= 1.2)
    // accumulates in the extrapolation; over 30 seeds the worst pull was 3.8.
    expect_within(e.inf, truth[k], 5, e.parameter);
  }
  // alpha of the phi_J and mu_J extrapolations (well determined: large A).
  expect_within(r.extrapolations[0].fit->at(2), 0.852, 5, "alpha_phi_J");
  // Each extrapolation says what the sizes could resolve at the seed's law of its parameter.
  for (const Extrapolation& e : r.extrapolations) {
    ASSERT_TRUE(e.sensitivity.has_value()) << e.parameter;
    EXPECT_EQ(e.sensitivity->a, seed::table2(e.parameter).a) << e.parameter;
    EXPECT_TRUE(std::isfinite(e.sensitivity->power)) << e.parameter;
  }
  expect_within(r.extrapolations[3].fit->at(2), 0.626, 5, "alpha_mu_J");
  ASSERT_TRUE(r.nu_phi && r.nu_mu) << [&] {
    std::string w;
    for (const auto& x : r.warnings)
      w += x + "\n";
    return w;
  }();
  expect_within(*r.nu_phi, 0.391 / (0.852 * 3), 5, "nu from phi");
  expect_within(*r.nu_mu, 0.346 / (0.626 * 3), 5, "nu from mu");
  // The systematic error of each O_inf is the largest of the sizes' (J window, fit form), and
  // nu's is b_inf's relative one.
  for (const Extrapolation& e : r.extrapolations) {
    double largest = 0.0;
    for (const SizeFit& s : r.sizes) {
      const ErrorModel& em =
          e.parameter.find("phi") != std::string::npos ? s.phi_errors : s.mu_errors;
      const double sys = em[e.parameter].systematic();
      if (std::isfinite(sys))
        largest = std::max(largest, sys);
    }
    EXPECT_GT(largest, 0.0) << e.parameter;
    EXPECT_DOUBLE_EQ(e.systematic, largest) << e.parameter;
  }
  const Extrapolation& b_phi = r.extrapolations[1];
  EXPECT_NEAR(r.nu_phi_systematic, r.nu_phi->value * b_phi.systematic / b_phi.inf.value,
              1e-12 * r.nu_phi->value);
  ASSERT_TRUE(r.viscosity.has_value());
  // N -> infinity parameters only when all six extrapolations are resolved, else the largest N.
  bool all_resolved = true;
  for (const auto& e : r.extrapolations)
    all_resolved = all_resolved && e.resolved;
  EXPECT_EQ(r.viscosity->source, all_resolved ? "N -> infinity" : "N = 10000");
  expect_within(r.viscosity->exponent_1, 1 / 0.391, 5, "1/b_phi");
  expect_within(r.viscosity->exponent_2, (1 - 0.346) / 0.391, 5, "(1-b_mu)/b_phi");
}

// The collapse measure on curves that share one master curve y = 1 + x^0.4 with
// Gaussian noise of the stated errors: S is a mean of ~chi2(1) terms, so it
// lies within 1 +- 4 sqrt(2/N_used) (4 sigma; neighbouring interpolations are
// correlated, which this neglects, so the band is generous). Shifting one curve
// by 5 of its errors must give S far outside that band.
TEST(Collapse, SharedMasterCurveGivesSNearOneAndAShiftedCurveDoesNot) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<CollapsePoint> pts;
  for (std::size_t curve = 0; curve < 5; ++curve) {
    for (int i = 0; i < 30; ++i) {
      const double x = std::pow(10.0, -2.0 + 0.1 * i + 0.4 * double(curve));
      const double dy = 0.002 * (1.0 + double(curve));
      pts.push_back({x, 1.0 + std::pow(x, 0.4) + dy * normal(rng), dy, curve, 0});
    }
  }
  const CollapseQuality good = houdayer_hartmann(pts);
  ASSERT_GT(good.used, 80u);
  EXPECT_EQ(good.total, pts.size());
  EXPECT_NEAR(good.s, 1.0, 4.0 * std::sqrt(2.0 / double(good.used)));
  EXPECT_TRUE(good.acceptable());
  for (auto& p : pts) {
    if (p.curve == 2)
      p.y += 5.0 * p.dy;
  }
  const CollapseQuality bad = houdayer_hartmann(pts);
  EXPECT_GT(bad.s, 3.0);
  EXPECT_FALSE(bad.acceptable());
}

// Data that obey the paper's finite-size scaling form (only phi_J and mu_J
// depend on N) at hard-sphere pressures collapse in the Fig. 6 variables. S
// counts only the points' errors, not those of O_inf, A, alpha and b, which
// shift whole sizes together: over seeds 1-15, S was 0.88-1.52 (mean 1.08), so
// the bound is 1.6, not acceptable()'s 1 + 3 sqrt(2/N_used) = 1.27. Moving one
// size by 5 of its errors must break the collapse: S > 3 (it gives 6.0; the
// N -> infinity fits absorb part of the move). Table 2's own
// data, whose b and C also depend on N, only get a finite, measured S.
TEST(HardSphere, FiniteSizeCollapseHoldsForDataThatObeyTheScalingForm) {
  GranularSpec spec;
  spec.sizes = {100, 300, 500, 1000, 3000, 10000};
  spec.size_independent_shape = true;
  spec.soft = false;
  auto data = make_granular(spec);
  HardSphereResult r = analyze_hard_sphere(data, HardSphereOptions{});
  ASSERT_TRUE(r.failures.empty()) << r.failures.front();
  for (const FiniteSizeCollapse* c : {&r.collapse_phi, &r.collapse_mu}) {
    ASSERT_TRUE(c->unavailable.empty()) << c->parameter << ": " << c->unavailable;
    EXPECT_GT(c->quality.used, 200u) << c->parameter;
    EXPECT_LT(c->quality.s, 1.6) << c->parameter << " over " << c->quality.used;
  }
  for (auto& p : data) {
    if (p.n == 1000)
      p.phi += 5.0 * p.phi_err;
  }
  HardSphereResult moved = analyze_hard_sphere(data, HardSphereOptions{});
  ASSERT_TRUE(moved.collapse_phi.unavailable.empty()) << moved.collapse_phi.unavailable;
  EXPECT_GT(moved.collapse_phi.quality.s, 3.0);
  EXPECT_FALSE(moved.collapse_phi.quality.acceptable());

  spec.size_independent_shape = false;
  spec.soft = true;
  HardSphereResult t2 = analyze_hard_sphere(make_granular(spec), HardSphereOptions{});
  ASSERT_TRUE(t2.collapse_phi.unavailable.empty()) << t2.collapse_phi.unavailable;
  EXPECT_TRUE(std::isfinite(t2.collapse_phi.quality.s));
}

TEST(HardSphere, SizesThatCannotBeFittedAreReportedNotThrown) {
  GranularSpec spec;
  spec.sizes = {500, 1000};
  auto pts = make_granular(spec);
  std::vector<GranularPoint> data;
  for (const auto& p : pts) {  // N = 500 at a single pressure: untestable
    if (p.n == 1000 || p.pressure == 1e-5)
      data.push_back(p);
  }
  HardSphereResult r = analyze_hard_sphere(data, HardSphereOptions{});
  ASSERT_EQ(r.sizes.size(), 1u);
  EXPECT_EQ(r.sizes[0].n, 1000);
  ASSERT_EQ(r.unfitted.size(), 1u);
  EXPECT_EQ(r.unfitted[0].n, 500);
  EXPECT_NE(r.unfitted[0].reason.find("single pressure"), std::string::npos)
      << r.unfitted[0].reason;
  EXPECT_FALSE(r.unfitted[0].points.empty());
  ASSERT_EQ(r.failures.size(), 1u);
  EXPECT_TRUE(r.viscosity.has_value());  // from the size that was fitted
  // No size at all: nothing throws, the reason is stated.
  std::vector<GranularPoint> single;
  for (const auto& p : pts) {
    if (p.pressure == 1e-5)
      single.push_back(p);
  }
  HardSphereResult none = analyze_hard_sphere(single, HardSphereOptions{});
  EXPECT_TRUE(none.sizes.empty());
  EXPECT_EQ(none.unfitted.size(), 2u);
  EXPECT_EQ(none.failures.size(), 2u);
  EXPECT_FALSE(none.viscosity.has_value());
  EXPECT_FALSE(none.collapse_phi.unavailable.empty());
}

// The plots draw a size fit as an N -> infinity result only when the analysis resolved it: the
// plot data carry each parameter's verdict, and it follows the result, not the fit's status.
TEST(HardSphere, PlotDataSayWhichExtrapolationsAreResolved) {
  GranularSpec spec;
  spec.sizes = {100, 300, 500, 1000, 3000, 10000};
  HardSphereResult r = analyze_hard_sphere(make_granular(spec), HardSphereOptions{});
  ASSERT_EQ(r.extrapolations.size(), 6u);
  ASSERT_EQ(r.extrapolations[0].parameter, "phi_J");
  ASSERT_TRUE(r.extrapolations[0].resolved) << r.extrapolations[0].resolution;
  const Json resolved = hard_sphere_plot_data(r).at("extrapolation_resolved");
  for (const auto& e : r.extrapolations)
    EXPECT_EQ(resolved.at(e.parameter).as_bool(), e.resolved) << e.parameter;
  // The same fit judged not resolved (as when A_O is within the rule's sigmas of 0).
  r.extrapolations[0].resolved = false;
  EXPECT_FALSE(hard_sphere_plot_data(r).at("extrapolation_resolved").at("phi_J").as_bool());
  EXPECT_TRUE(hard_sphere_plot_data(r).at("extrapolated").contains("phi_J"));  // still drawn
}

TEST(Extrapolation, StatusFollowsWhatTheDataResolve) {
  const std::vector<double> sizes = {100, 300, 500, 1000, 3000, 10000};
  const std::vector<double> err(6, 1e-4);
  FitOptions o;
  o.label = "O(N)";
  using Status = Extrapolation::Status;
  // A clean power law: fitted, with Table 2's mu_J values.
  std::vector<double> clean;
  for (double n : sizes)
    clean.push_back(0.108 + 0.279 * std::pow(n, -0.626));
  Extrapolation fit = extrapolate_in_size("mu_J", sizes, clean, err, o);
  ASSERT_EQ(fit.status, Status::kFit) << fit.message;
  EXPECT_NEAR(fit.fit->params[2], 0.626, 1e-6);
  // Only the smallest size deviates: alpha unbounded above, O_inf = the rest.
  std::vector<double> step = {0.110, 0.1, 0.1, 0.1, 0.1, 0.1};
  Extrapolation up = extrapolate_in_size("b_mu", sizes, step, err, o);
  ASSERT_EQ(up.status, Status::kExponentUnbounded) << up.message;
  EXPECT_NEAR(up.inf.value, 0.1, 1e-9);
  EXPECT_GT(up.inf.error, 1e-4 / std::sqrt(5.0) * 0.99);  // at least the mean's error
  EXPECT_GT(up.alpha_lower_bound, 1.0);
  // Pure noise around a constant: no significant N-dependence.
  std::vector<double> flat = {0.1001, 0.0999, 0.1000, 0.1001, 0.0999, 0.1000};
  Extrapolation c = extrapolate_in_size("C_mu", sizes, flat, err, o);
  ASSERT_EQ(c.status, Status::kConstant) << c.message;
  EXPECT_NEAR(c.inf.value, 0.1, 1e-4);
  // Steady logarithmic growth: no convergence, O_inf undetermined.
  std::vector<double> growth;
  for (double n : sizes)
    growth.push_back(0.1 + 0.01 * std::log(n));
  Extrapolation nr = extrapolate_in_size("C_phi", sizes, growth, err, o);
  EXPECT_EQ(nr.status, Status::kNotResolved) << nr.message;
  // Too few sizes.
  Extrapolation few =
      extrapolate_in_size("phi_J", {100, 300, 1000}, {0.64, 0.645, 0.646}, {1e-4, 1e-4, 1e-4}, o);
  EXPECT_EQ(few.status, Status::kFailed);
  EXPECT_NE(few.message.find("at least 4"), std::string::npos) << few.message;
}

// The two readings written beside the resolution rule do not depend on the unit N is counted in
// (the rule's z of A_O does): the same noisy values with N in hundredths of a particle give the
// same chi2 of a constant, the same minimum of the power law's and the same sigma_alpha / alpha,
// while A_O and its z change. On exact data the power law's chi2 is 0 and the constant's is the
// weighted scatter about the mean.
TEST(Extrapolation, UnitFreeReadingsDoNotDependOnTheUnitOfN) {
  const std::vector<double> sizes = {100, 250, 500, 1000, 2000};
  const std::vector<double> err = {6e-4, 5e-4, 4e-4, 3e-4, 3e-4};
  FitOptions o;
  o.label = "O(N)";
  std::mt19937_64 rng(11);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::vector<double> v, exact;
  for (std::size_t i = 0; i < sizes.size(); ++i) {
    exact.push_back(0.6474 - 0.6 * std::pow(sizes[i], -0.7));
    v.push_back(exact.back() + err[i] * gauss(rng));
  }
  std::vector<double> hundredths;
  for (double n : sizes)
    hundredths.push_back(100.0 * n);
  const Extrapolation a = extrapolate_in_size("phi_J", sizes, v, err, o);
  const Extrapolation b = extrapolate_in_size("phi_J", hundredths, v, err, o);
  ASSERT_EQ(a.status, Extrapolation::Status::kFit) << a.message;
  ASSERT_EQ(b.status, Extrapolation::Status::kFit) << b.message;
  EXPECT_DOUBLE_EQ(a.chi2_constant, b.chi2_constant);
  EXPECT_EQ(a.dof_constant, 4);
  // The profile is on a grid of alpha normalised at the smallest size, the same in both units.
  EXPECT_NEAR(a.chi2_power_law, b.chi2_power_law, 1e-9 * a.chi2_constant);
  EXPECT_GT(a.chi2_constant - a.chi2_power_law, 5.99);  // a clear N-dependence
  const double rel_a = a.fit->at(2).error / a.fit->at(2).value;
  const double rel_b = b.fit->at(2).error / b.fit->at(2).value;
  EXPECT_NEAR(rel_a, rel_b, 1e-3 * rel_a);
  const double z_a = std::fabs(a.fit->at(1).value) / a.fit->at(1).error;
  const double z_b = std::fabs(b.fit->at(1).value) / b.fit->at(1).error;
  EXPECT_GT(std::fabs(z_a - z_b), 0.1 * z_a) << z_a << " " << z_b;
  // The JSON carries them with the chi2 p-value of the likelihood ratio.
  HardSphereResult r;
  r.extrapolations.push_back(a);
  const Json u =
      hard_sphere_json(r, HardSphereOptions{}, {}).at("extrapolated").at("phi_J").at("unit_free");
  const double delta = a.chi2_constant - a.chi2_power_law;
  EXPECT_DOUBLE_EQ(u.at("delta_chi2").as_number(), delta);
  EXPECT_NEAR(u.at("p_constant").as_number(), std::exp(-delta / 2.0), 1e-12);  // chi2, 2 dof
  EXPECT_NEAR(u.at("alpha_relative_error").as_number(), rel_a, 1e-12);
  // Exact data.
  const Extrapolation c = extrapolate_in_size("phi_J", sizes, exact, err, o);
  double sw = 0.0, swy = 0.0;
  for (std::size_t i = 0; i < sizes.size(); ++i) {
    sw += 1.0 / (err[i] * err[i]);
    swy += exact[i] / (err[i] * err[i]);
  }
  double scatter = 0.0;
  for (std::size_t i = 0; i < sizes.size(); ++i)
    scatter += std::pow((exact[i] - swy / sw) / err[i], 2);
  EXPECT_NEAR(c.chi2_constant, scatter, 1e-9 * scatter);
  // The grid of alpha passes within half a step of 0.7: chi2 well below one.
  EXPECT_LT(c.chi2_power_law, 0.05);
}

// The sensitivity's Fisher errors are those of the fit itself: on data that follow the law
// exactly, the fit's covariance (Gauss-Newton at zero residuals) is the inverse Fisher matrix;
// they scale with the data's errors; and the error scale it names gives the target chance.
TEST(SizeSensitivity, FisherErrorsAreTheFitsAndScaleWithTheData) {
  const std::vector<double> sizes = {100, 300, 500, 1000, 3000, 10000};
  const std::vector<double> err = {2e-3, 1e-3, 8e-4, 5e-4, 4e-4, 3e-4};
  const double a = -0.323, alpha = 0.852;
  std::vector<double> exact;
  for (double n : sizes)
    exact.push_back(0.6474 + a * std::pow(n, -alpha));
  FitOptions o;
  o.label = "phi_J(N)";
  const Extrapolation ex = extrapolate_in_size("phi_J", sizes, exact, err, o);
  ASSERT_EQ(ex.status, Extrapolation::Status::kFit) << ex.message;
  const SizeSensitivity s = size_sensitivity(a, alpha, sizes, err, 2.0);
  EXPECT_NEAR(s.sigma_a, std::sqrt(ex.fit->cov(1, 1)), 1e-6 * s.sigma_a);
  EXPECT_NEAR(s.sigma_alpha, std::sqrt(ex.fit->cov(2, 2)), 1e-6 * s.sigma_alpha);
  EXPECT_NEAR(s.z, std::fabs(a) / s.sigma_a, 1e-12);
  // Half the errors, half the Fisher errors.
  std::vector<double> half;
  for (double e : err)
    half.push_back(0.5 * e);
  const SizeSensitivity h = size_sensitivity(a, alpha, sizes, half, 2.0);
  EXPECT_NEAR(h.sigma_a, 0.5 * s.sigma_a, 1e-9 * s.sigma_a);
  EXPECT_NEAR(h.sigma_alpha, 0.5 * s.sigma_alpha, 1e-9 * s.sigma_alpha);
  EXPECT_GT(h.power, s.power);
  // The named error scale gives the target chance (the far tail left out is below 1e-3).
  std::vector<double> scaled;
  for (double e : err)
    scaled.push_back(s.error_scale * e);
  EXPECT_NEAR(size_sensitivity(a, alpha, sizes, scaled, 2.0).power, SizeSensitivity::kTargetPower,
              1e-3);
  // No amplitude: only the chance of a false resolution, 2 Phi(-2) = 0.0455.
  const SizeSensitivity zero = size_sensitivity(0.0, alpha, sizes, err, 2.0);
  EXPECT_FALSE(std::isfinite(zero.sigma_a));  // dO/dalpha vanishes: singular
  const SizeSensitivity tiny = size_sensitivity(1e-9, alpha, sizes, err, 2.0);
  EXPECT_NEAR(tiny.power, 0.0455, 1e-3);
}

// The forecast is the scatter the fit shows: over 300 noisy draws of the law (errors not scaled
// by chi2, small enough for the linear regime), the standard deviation of the fitted A and alpha
// is the Fisher error within 15% (the relative error of a standard deviation from 300 draws is
// 1/sqrt(600) = 4%, so 15% is about 3.5 of its sigma).
TEST(SizeSensitivity, ForecastIsTheScatterOfRepeatedFits) {
  const std::vector<double> sizes = {100, 300, 500, 1000, 3000, 10000};
  const std::vector<double> err = {1e-4, 5e-5, 4e-5, 2.5e-5, 2e-5, 1.5e-5};
  const double a = -0.323, alpha = 0.852;
  const SizeSensitivity s = size_sensitivity(a, alpha, sizes, err, 2.0);
  ASSERT_GT(s.z, 5.0);  // the linear regime
  FitOptions o;
  o.label = "phi_J(N)";
  o.scale_errors_by_chi2 = false;
  std::mt19937_64 rng(11);
  std::normal_distribution<double> noise(0.0, 1.0);
  double sa = 0.0, saa = 0.0, sl = 0.0, sll = 0.0;
  int fits = 0;
  for (int k = 0; k < 300; ++k) {
    std::vector<double> v;
    for (std::size_t i = 0; i < sizes.size(); ++i)
      v.push_back(0.6474 + a * std::pow(sizes[i], -alpha) + err[i] * noise(rng));
    const Extrapolation ex = extrapolate_in_size("phi_J", sizes, v, err, o);
    if (ex.status != Extrapolation::Status::kFit)
      continue;
    const double fa = ex.fit->params[1], fl = ex.fit->params[2];
    sa += fa;
    saa += fa * fa;
    sl += fl;
    sll += fl * fl;
    ++fits;
  }
  ASSERT_GE(fits, 290);
  const double sd_a = std::sqrt(saa / fits - std::pow(sa / fits, 2));
  const double sd_alpha = std::sqrt(sll / fits - std::pow(sl / fits, 2));
  EXPECT_NEAR(sd_a / s.sigma_a, 1.0, 0.15);
  EXPECT_NEAR(sd_alpha / s.sigma_alpha, 1.0, 0.15);
}

TEST(HardSphere, FewerThanFourSizesSkipTheExtrapolationExplicitly) {
  GranularSpec spec;
  spec.sizes = {1000, 3000};
  HardSphereResult r = analyze_hard_sphere(make_granular(spec), HardSphereOptions{});
  EXPECT_NE(r.extrapolation_skipped.find("at least 4 system sizes"), std::string::npos);
  EXPECT_FALSE(r.warnings.empty());
  EXPECT_TRUE(r.failures.empty());
  EXPECT_FALSE(r.nu_phi.has_value());
  ASSERT_TRUE(r.viscosity.has_value());
  EXPECT_EQ(r.viscosity->source, "N = 3000");
}

TEST(ViscosityLaw, ReproducesThePapersExponentsAndCrossover) {
  const auto t = testing::table2_infinite();
  std::vector<double> params = {t.phi_j, t.b_phi, t.c_phi, t.mu_j, t.b_mu, t.c_mu};
  std::vector<double> cov(36, 0.0);
  for (int k = 0; k < 6; ++k)
    cov[k * 7] = std::pow(1e-3 * params[k], 2);
  ViscosityLaw v = viscosity_law(params, cov, "Table 2", t.phi_j - 0.1, t.phi_j - 0.01);
  EXPECT_NEAR(v.exponent_1.value, 2.5575, 1e-4);           // paper: 2.55
  EXPECT_NEAR(v.exponent_2.value, 1.6726, 1e-4);           // paper: 1.67
  EXPECT_NEAR(v.crossover_delta_phi.value, 0.0183, 2e-4);  // paper: "about 0.02"
  EXPECT_GT(v.effective_exponent.value, v.exponent_2.value);
  EXPECT_LT(v.effective_exponent.value, v.exponent_1.value);
  // Far from phi_J the sub-dominant part dominates: local exponent near e2.
  EXPECT_LT(v.local_exponent_at_min.value, v.local_exponent_at_max.value);
  EXPECT_GT(v.exponent_1.error, 0.0);
  // The law is the sum of its two power laws.
  const double phi = 0.62, d = t.phi_j - phi;
  EXPECT_NEAR(v.eta(phi),
              v.amplitude_1.value * std::pow(d, -v.exponent_1.value) +
                  v.amplitude_2.value * std::pow(d, -v.exponent_2.value),
              1e-10 * v.eta(phi));
  // eta/eta_0 = mu(J)/J at the J with phi(J) = phi.
  const double j = std::pow(d / t.c_phi, 1 / t.b_phi);
  EXPECT_NEAR(v.eta(phi), (t.mu_j + t.c_mu * std::pow(j, t.b_mu)) / j, 1e-10 * v.eta(phi));
}

TEST(ViscosityLaw, ParametersSystematicErrorsPropagateToTheExponents) {
  const auto t = testing::table2_infinite();
  std::vector<double> params = {t.phi_j, t.b_phi, t.c_phi, t.mu_j, t.b_mu, t.c_mu};
  std::vector<double> cov(36, 0.0);
  for (int k = 0; k < 6; ++k)
    cov[k * 7] = std::pow(1e-3 * params[k], 2);
  // Without systematics the exponents carry none; their statistical errors do not change with
  // them.
  const ViscosityLaw none = viscosity_law(params, cov, "x", t.phi_j - 0.1, t.phi_j - 0.01);
  EXPECT_EQ(none.exponent_1_systematic, 0.0);
  EXPECT_EQ(none.effective_exponent_systematic, 0.0);
  // A systematic of 0.04 in b_phi and 0.09 in b_mu (the size of the J-window shifts of a fit at
  // N = 1000): d(1/b)/db = -1/b^2, and (1 - b_mu)/b_phi moves with both, in quadrature.
  const std::vector<double> sys = {0.0, 0.04, 0.0, 0.0, 0.09, 0.0};
  const ViscosityLaw v = viscosity_law(params, cov, "x", t.phi_j - 0.1, t.phi_j - 0.01, sys);
  EXPECT_NEAR(v.exponent_1_systematic, 0.04 / (t.b_phi * t.b_phi), 1e-3 * v.exponent_1_systematic);
  EXPECT_NEAR(v.exponent_2_systematic,
              std::hypot(0.04 * (1 - t.b_mu) / (t.b_phi * t.b_phi), 0.09 / t.b_phi),
              1e-3 * v.exponent_2_systematic);
  EXPECT_GT(v.effective_exponent_systematic, 0.0);
  EXPECT_DOUBLE_EQ(v.exponent_1.error, none.exponent_1.error);
}

TEST(ViscosityLaw, WindowOutsideTheDomainIsAUsageError) {
  const auto t = testing::table2_infinite();
  std::vector<double> params = {t.phi_j, t.b_phi, t.c_phi, t.mu_j, t.b_mu, t.c_mu};
  std::vector<double> cov(36, 0.0);
  EXPECT_THROW(viscosity_law(params, cov, "x", 0.60, 0.65), InputError);
  EXPECT_THROW(viscosity_law(params, cov, "x", 0.62, 0.60), InputError);
}

}  // namespace
}  // namespace jamflow::analysis
