// Houdayer–Hartmann collapse quality and its optimisation, on data built
// from a known two-branch scaling function (synthetic.hpp) and on flow curves
// of the soft granular rheology, which the paper says cannot be collapsed.
#include <gtest/gtest.h>

#include <cmath>

#include "analysis/errors.hpp"
#include "analysis/olsson_teitel.hpp"
#include "tests/analysis/synthetic.hpp"

namespace jamflow::analysis {
namespace {

using testing::TwoBranchSpec;

TEST(HoudayerHartmann, QualityIsAboutOneAtTheTruth) {
  TwoBranchSpec spec;
  HoudayerHartmann hh(testing::make_two_branch(spec));
  CollapseQuality q = hh.evaluate({spec.phi_j, spec.alpha, spec.beta});
  // ~196 of 208 points have neighbours. For independent Gaussian residuals S
  // would have mean 1 and sd sqrt(2/196) = 0.10; interpolation through the
  // neighbours adds curvature error and correlations, so we allow a
  // +-3 sd band around 1 widened to [0.7, 1.35].
  EXPECT_GT(q.used, 180u);
  EXPECT_GT(q.s, 0.7);
  EXPECT_LT(q.s, 1.35);
  EXPECT_TRUE(q.acceptable());
}

TEST(HoudayerHartmann, QualityIsLargeAwayFromTheTruth) {
  TwoBranchSpec spec;
  HoudayerHartmann hh(testing::make_two_branch(spec));
  EXPECT_GT(hh.evaluate({spec.phi_j, 1.6, spec.beta}).s, 10.0);
  EXPECT_GT(hh.evaluate({spec.phi_j, spec.alpha, 3.0}).s, 10.0);
  EXPECT_GT(hh.evaluate({0.645, spec.alpha, spec.beta}).s, 5.0);
  EXPECT_FALSE(hh.evaluate({0.645, spec.alpha, spec.beta}).acceptable());
}

TEST(HoudayerHartmann, NeverComparesAPointWithItsOwnCurve) {
  TwoBranchSpec spec;
  spec.phis = {0.62};
  HoudayerHartmann hh(testing::make_two_branch(spec));
  CollapseQuality q = hh.evaluate({spec.phi_j, spec.alpha, spec.beta});
  EXPECT_EQ(q.used, 0u);
  EXPECT_FALSE(std::isfinite(q.s));
}

TEST(OlssonTeitel, OptimiserRecoversTheScalingParameters) {
  TwoBranchSpec spec;
  HoudayerHartmann hh(testing::make_two_branch(spec));
  OlssonTeitelOptions o;
  o.bootstrap = 20;
  CollapseFit f = optimize_collapse(hh, {0.6455, 1.2, 2.3}, o, 11);
  // Within 4 bootstrap sigma (20 resamples estimate sigma to ~16 %), and in
  // absolute terms close enough to tell the paper's exponents apart.
  EXPECT_LE(std::fabs(f.phi_j.value - spec.phi_j), 4 * f.phi_j.error);
  EXPECT_LE(std::fabs(f.alpha.value - spec.alpha), 4 * f.alpha.error);
  EXPECT_LE(std::fabs(f.beta.value - spec.beta), 4 * f.beta.error);
  EXPECT_LT(std::fabs(f.phi_j.value - spec.phi_j), 1e-3);
  EXPECT_LT(std::fabs(f.alpha.value - spec.alpha), 0.05);
  EXPECT_LT(std::fabs(f.beta.value - spec.beta), 0.1);
  EXPECT_TRUE(f.quality.acceptable());
  EXPECT_EQ(f.bootstrap_used, 20);
}

TEST(OlssonTeitel, SoftGranularRheologyHasNoAcceptableCollapse) {
  // The paper's claim (Sec. V B, Fig. 9): data following the soft granular
  // rheology cannot be collapsed on two branches; optimising part of the data
  // worsens the rest.
  TwoBranchSpec spec;
  auto pts = testing::make_soft_flow_curves(spec, testing::SoftTruth{});
  OlssonTeitelOptions o;
  o.bootstrap = 10;
  OlssonTeitelResult r = analyze_olsson_teitel(pts, o);
  EXPECT_GT(r.at_quality.s, 50.0);
  EXPECT_GT(r.best.quality.s, 10.0);
  EXPECT_FALSE(r.best.quality.acceptable());
  EXPECT_LT(r.best.quality.s, r.at_quality.s);
  ASSERT_EQ(r.subsets.size(), 4u);
  int trade_offs = 0;
  for (const auto& s : r.subsets) {
    ASSERT_TRUE(s.fit.has_value()) << s.name << ": " << s.skipped;
    trade_offs += s.trade_off;
  }
  EXPECT_GE(trade_offs, 2);
  // The same points against the law they were drawn from: its quality is about one (a mean
  // of ~200 squared pulls has sd 0.1; ten fitted parameters lower it by ~5%), and the
  // exponents come back within 4 bootstrap sigma.
  ASSERT_TRUE(r.soft.has_value()) << r.soft_skipped;
  EXPECT_TRUE(r.soft->acceptable()) << r.soft->s;
  EXPECT_GT(r.soft->s, 0.6);
  EXPECT_EQ(r.soft->used, r.soft->total);
  EXPECT_GE(r.soft->bootstrap_used, 8);
  EXPECT_GT(r.soft->s_spread, 0.0);
  const testing::SoftTruth truth;
  EXPECT_LE(std::fabs(r.soft->fit.params[2].value - truth.x), 4 * r.soft->fit.params[2].error);
  EXPECT_LE(std::fabs(r.soft->fit.params[7].value - truth.y), 4 * r.soft->fit.params[7].error);
  EXPECT_GT(r.best.s_spread, 0.0);
}

TEST(OlssonTeitel, TwoBranchDataCollapseOverall) {
  TwoBranchSpec spec;
  OlssonTeitelOptions o;
  o.bootstrap = 10;
  OlssonTeitelResult r = analyze_olsson_teitel(testing::make_two_branch(spec), o);
  EXPECT_TRUE(r.at_quality.acceptable());
  EXPECT_TRUE(r.best.quality.acceptable());
  // No measured pressures in these data: the soft law is not fitted, and the result says why.
  EXPECT_FALSE(r.soft.has_value());
  EXPECT_NE(r.soft_skipped.find("pressure"), std::string::npos) << r.soft_skipped;
  for (const auto& s : r.subsets) {
    ASSERT_TRUE(s.fit.has_value()) << s.name;
    EXPECT_TRUE(s.fit->quality.acceptable()) << s.name;
  }
}

TEST(OlssonTeitel, EdgeCasesGiveClearErrors) {
  TwoBranchSpec spec;
  auto pts = testing::make_two_branch(spec);
  OlssonTeitelOptions o;
  o.bootstrap = 5;
  EXPECT_THROW(analyze_olsson_teitel(pts, o), InputError);
  o.bootstrap = 10;
  auto mixed = pts;
  mixed.front().n = 1000;
  try {
    analyze_olsson_teitel(mixed, o);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--size"), std::string::npos) << e.what();
  }
  spec.phis = {0.62};
  EXPECT_THROW(analyze_olsson_teitel(testing::make_two_branch(spec), o), InsufficientDataError);
  HoudayerHartmann hh(pts);
  EXPECT_THROW(optimize_collapse(hh, {0.6474, -1.0, 2.55}, o, 1), InputError);
  OlssonTeitelOptions strict;
  strict.min_overlap = 1.0;  // every point needs neighbours: not so at the start
  EXPECT_THROW(optimize_collapse(hh, {0.6474, 1.33, 2.55}, strict, 1), InputError);
}

}  // namespace
}  // namespace jamflow::analysis
