// The comparison's numbers (analysis/compare.hpp) on synthetic tables whose answers are known by
// construction: paired differences and their errors, the floor, ranking, recommendation,
// spreads and their ratios.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>

#include "analysis/compare.hpp"

namespace jamflow::analysis {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// A setting with one observable: replica means, block errors, block stds, and CPU s per tau_0.
SettingInput setting(const std::string& label, std::vector<double> means, double block_error,
                     double cpu, double block_std = 1.0, double paired = kNaN) {
  SettingInput s;
  s.label = label;
  s.ensemble = "constant_volume";
  s.particles = 100.0;
  s.observables.resize(1);
  for (double m : means) {
    ReplicaObservable r;
    r.mean = m;
    r.block_error = block_error;
    r.block_std = block_std;
    r.tau = 2.0;
    r.paired_error = paired;
    s.observables[0].push_back(r);
    s.cpu_per_tau.push_back(cpu);
  }
  return s;
}

CompareInput input(std::vector<SettingInput> settings) {
  CompareInput in;
  in.observables = {"sigma_xy"};
  in.settings = std::move(settings);
  in.reference = 0;
  return in;
}

TEST(Compare, PairedDifferenceFromReplicaScatterWithThreeReplicasOrMore) {
  // Differences 0.1, 0.3, 0.2, 0.4 replica by replica (mean 0.25, std 0.1291): the shared
  // offsets 1, 5, -3, 7 of each replica cancel, as they do for runs from one prepared state.
  const auto in = input(
      {setting("ref", {1, 5, -3, 7}, 0.5, 10.0), setting("a", {1.1, 5.3, -2.8, 7.4}, 0.5, 5.0)});
  const CompareResult r = compare(in);
  const ObservableResult& a = r.settings[1].observables[0];
  EXPECT_NEAR(a.difference.value, 0.25, 1e-12);
  EXPECT_NEAR(a.difference.error, std::sqrt(0.05 / 3.0) / 2.0, 1e-12);
  EXPECT_EQ(a.source, ErrorSource::kReplicaScatter);
  // The floor is the reference's own error: the scatter of 1, 5, -3, 7 over sqrt(4).
  EXPECT_NEAR(a.floor,
              std::sqrt(((1 - 2.5) * (1 - 2.5) + 2.5 * 2.5 + 5.5 * 5.5 + 4.5 * 4.5) / 3) / 2,
              1e-12);
  EXPECT_EQ(r.settings[0].observables[0].source, ErrorSource::kNone);
  EXPECT_EQ(r.settings[0].observables[0].difference.value, 0.0);
}

TEST(Compare, PairedDifferenceFromBlocksBelowThreeReplicas) {
  // One replica: the paired series' block error when known, else the two block errors in
  // quadrature.
  auto in = input({setting("ref", {2.0}, 0.3, 10.0), setting("paired", {2.5}, 0.3, 5.0, 1.0, 0.1),
                   setting("unpaired", {2.5}, 0.4, 5.0)});
  const CompareResult r = compare(in);
  EXPECT_EQ(r.settings[1].observables[0].source, ErrorSource::kBlocks);
  EXPECT_NEAR(r.settings[1].observables[0].difference.error, 0.1, 1e-12);
  EXPECT_NEAR(r.settings[2].observables[0].difference.error, 0.5, 1e-12);
  EXPECT_NEAR(r.settings[1].observables[0].z, 5.0, 1e-12);
  EXPECT_FALSE(r.settings[1].within);  // 5 sigma
  EXPECT_TRUE(r.settings[2].within);   // 1 sigma
  // Two replicas: block errors propagated to the mean, sqrt(0.1^2 + 0.1^2) / 2.
  in = input({setting("ref", {2.0, 3.0}, 0.3, 10.0), setting("b", {2.1, 3.1}, 0.3, 5.0, 1.0, 0.1)});
  EXPECT_NEAR(compare(in).settings[1].observables[0].difference.error, std::sqrt(0.02) / 2, 1e-12);
}

TEST(Compare, RankingFollowsThePairedErrorsAndTheCheapestWithinToleranceIsRecommended) {
  // Paired errors 0.05, 0.4, 0.2 (error 0.1 each, from one replica's paired series); floor 0.1.
  CompareInput in =
      input({setting("ref", {1.0}, 0.1, 40.0), setting("close", {1.05}, 0.1, 20.0, 1, 0.1),
             setting("far", {1.4}, 0.1, 1.0, 1, 0.1), setting("mid", {1.2}, 0.1, 10.0, 1, 0.1)});
  CompareResult r = compare(in);
  EXPECT_EQ(r.settings[0].rank, 1u);
  EXPECT_EQ(r.settings[1].rank, 2u);
  EXPECT_EQ(r.settings[3].rank, 3u);
  EXPECT_EQ(r.settings[2].rank, 4u);
  EXPECT_NEAR(r.settings[2].worst_error_in_floors, 4.0, 1e-12);
  // "far" is the cheapest but 4 sigma off; "mid" (2 sigma) is within and cheaper than "close".
  EXPECT_FALSE(r.settings[2].within);
  EXPECT_TRUE(r.settings[3].within);
  EXPECT_EQ(r.recommended, 3);
  EXPECT_NEAR(r.settings[3].cpu_per_particle_tau.value, 0.1, 1e-12);  // 10 s / 100 particles
  // A relative tolerance of 50% of the reference admits "far", now the cheapest.
  in.relative_tolerance = {0.5};
  EXPECT_EQ(compare(in).recommended, 2);
  // Unstable or drifting settings are never recommended, and the unstable ones are listed.
  in.settings[2].stable = false;
  in.settings[2].why_unstable = "energy balance 0.02";
  in.settings[3].steady = false;
  r = compare(in);
  EXPECT_EQ(r.recommended, 1);
  ASSERT_EQ(r.unstable.size(), 1u);
  EXPECT_EQ(r.unstable[0], 2u);
  // A setting that did not run ranks last and is unstable.
  in.settings[1].cpu_per_tau.clear();
  in.settings[1].observables.clear();
  r = compare(in);
  EXPECT_EQ(r.settings[1].rank, 4u);
  EXPECT_FALSE(r.settings[1].ran);
  EXPECT_EQ(r.unstable.size(), 2u);
  EXPECT_EQ(r.recommended, 0);  // only the reference is left
}

TEST(Compare, SpreadRatiosAgainstTheReferenceWithErrors) {
  // Block std 2 against the reference's 4 in every replica: ratio 0.5, error 0 (no scatter);
  // replica std of means {0, 2, 4} = 2 against {0, 4, 8} = 4: ratio 0.5 with the relative errors
  // 1/sqrt(2 (K - 1)) = 0.5 of each in quadrature.
  auto ref = setting("nv", {0, 4, 8}, 0.1, 1.0, 4.0);
  auto np = setting("np", {0, 2, 4}, 0.1, 1.0, 2.0);
  np.ensemble = "constant_pressure";
  const CompareResult r = compare(input({ref, np}));
  const ObservableResult& x = r.settings[1].observables[0];
  EXPECT_NEAR(x.block_std_ratio.value, 0.5, 1e-12);
  EXPECT_NEAR(x.block_std_ratio.error, 0.0, 1e-12);
  EXPECT_NEAR(x.replica_std.value, 2.0, 1e-12);
  EXPECT_NEAR(x.replica_std_ratio.value, 0.5, 1e-12);
  EXPECT_NEAR(x.replica_std_ratio.error, 0.5 * std::hypot(0.5, 0.5), 1e-12);
  EXPECT_NEAR(x.tau.value, 2.0, 1e-12);
  // One replica: the block std's error from the chi-square of 20 blocks, std / sqrt(2 x 19).
  const CompareResult one =
      compare(input({setting("a", {1.0}, 0.1, 1.0, 4.0), setting("b", {1.0}, 0.1, 1.0)}));
  EXPECT_NEAR(one.settings[0].observables[0].block_std.error, 4.0 / std::sqrt(38.0), 1e-12);
  EXPECT_TRUE(std::isnan(one.settings[0].observables[0].replica_std.value));
}

TEST(Compare, ConvergedSettingsThatScatterMoreThanTheirErrorsScaleEveryError) {
  // The reference (1.0) and two converged settings (1.4, 0.6), each with error 0.2: about their
  // weighted mean 1.0, chi2 = 0 + 4 + 4 over 2 degrees of freedom = 4, so every error doubles.
  SettingInput c1 = setting("c1", {1.4}, 0.2, 1.0), c2 = setting("c2", {0.6}, 0.2, 1.0);
  c1.converged = c2.converged = true;
  // An unstable converged setting does not enter the scatter (its mean would double it again).
  SettingInput bad = setting("bad", {9.0}, 0.2, 1.0);
  bad.converged = true;
  bad.stable = false;
  // x differs by 0.7 with error hypot(0.2, 0.2) = 0.283: 2.47 sigma before the scaling (outside
  // 2 sigma), 1.24 after it (inside).
  const SettingInput x = setting("x", {1.7}, 0.2, 0.5);
  SettingInput slow = setting("slow", {}, 0.2, 1.0);
  slow.over_budget = true;
  CompareInput in = input({setting("ref", {1.0}, 0.2, 2.0), c1, c2, bad, x, slow});
  const CompareResult r = compare(in);
  ASSERT_EQ(r.converged_scatter.size(), 1u);
  EXPECT_EQ(r.converged_scatter[0].settings, 3);
  EXPECT_NEAR(r.converged_scatter[0].reduced_chi2, 4.0, 1e-12);
  EXPECT_NEAR(r.converged_scatter[0].error_scale, 2.0, 1e-12);
  const ObservableResult& ox = r.settings[4].observables[0];
  EXPECT_NEAR(ox.difference.error, 2.0 * std::hypot(0.2, 0.2), 1e-12);
  EXPECT_NEAR(ox.floor, 0.4, 1e-12);
  EXPECT_NEAR(ox.mean.error, 0.4, 1e-12);
  EXPECT_NEAR(ox.z, 0.7 / (2.0 * std::hypot(0.2, 0.2)), 1e-12);
  EXPECT_TRUE(ox.within);
  EXPECT_EQ(r.recommended, 4);  // the cheapest within tolerance
  // Over budget is not unstable: listed apart, and not analysed.
  EXPECT_EQ(r.unstable, std::vector<std::size_t>({3}));
  EXPECT_EQ(r.over_budget, std::vector<std::size_t>({5}));
  EXPECT_FALSE(r.settings[5].ran);

  // Unmarked, the same numbers keep their errors, and x is outside 2 sigma.
  in.settings[1].converged = in.settings[2].converged = in.settings[3].converged = false;
  const CompareResult u = compare(in);
  EXPECT_EQ(u.converged_scatter[0].settings, 1);
  EXPECT_EQ(u.converged_scatter[0].error_scale, 1.0);
  EXPECT_NEAR(u.settings[4].observables[0].z, 0.7 / std::hypot(0.2, 0.2), 1e-12);
  EXPECT_FALSE(u.settings[4].observables[0].within);
  // Converged settings that agree within their errors (chi2/dof < 1) keep them: never shrunk.
  in.settings[1].observables[0][0].mean = 1.1;
  in.settings[2].observables[0][0].mean = 0.9;
  in.settings[1].converged = in.settings[2].converged = true;
  const CompareResult k = compare(in);
  EXPECT_NEAR(k.converged_scatter[0].reduced_chi2, 0.25, 1e-12);
  EXPECT_EQ(k.converged_scatter[0].error_scale, 1.0);
  EXPECT_NEAR(k.settings[4].observables[0].floor, 0.2, 1e-12);
}

TEST(Compare, RejectsAReferenceOutOfRangeAndMissingObservables) {
  CompareInput in = input({setting("ref", {1.0}, 0.1, 1.0), setting("a", {1.0}, 0.1, 1.0)});
  in.reference = 2;
  EXPECT_THROW(compare(in), std::invalid_argument);
  in.reference = 0;
  in.observables.push_back("phi");
  EXPECT_THROW(compare(in), std::invalid_argument);
}

}  // namespace
}  // namespace jamflow::analysis
