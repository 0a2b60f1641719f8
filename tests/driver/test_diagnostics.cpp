// The stability diagnostics of a run (driver/diagnostics.hpp) on synthetic data: the period-2
// oscillation detector, the lane order parameter, the energy-balance residual, and the stable /
// oscillating / diverged classification.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "driver/diagnostics.hpp"
#include "lib/init.hpp"

using namespace jamflow;
using namespace jamflow::diagnostics;

namespace {

// A smooth drift plus noise (stable dynamics resolved by the step) and the same with a
// period-2 component added.
std::vector<double> smooth_series(std::size_t n, double alternating) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0.0, 1e-4);
  std::vector<double> x(n);
  for (std::size_t k = 0; k < n; ++k) {
    x[k] = std::sin(0.02 * double(k)) + noise(rng) + alternating * ((k % 2) ? 1.0 : -1.0);
  }
  return x;
}

}  // namespace

TEST(Diagnostics, Lag1OfIncrementsSeparatesSmoothFromPeriodTwo) {
  const double smooth = lag1_autocorrelation(increments(smooth_series(400, 0.0)));
  const double osc = lag1_autocorrelation(increments(smooth_series(400, 0.05)));
  EXPECT_GT(smooth, 0.8);
  EXPECT_LT(osc, -0.9);
  // White noise: increments have lag-1 correlation -1/2.
  std::mt19937_64 rng(3);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<double> w(20000);
  for (auto& v : w)
    v = g(rng);
  EXPECT_NEAR(lag1_autocorrelation(increments(w)), -0.5, 0.03);
  EXPECT_EQ(lag1_autocorrelation({1.0, 2.0}), 0.0);
}

TEST(Diagnostics, StepCorrelationMeasuresAlternatingShare) {
  // Two particles, F_n = a + (-1)^n b with a = (1,1,1 | 0,0,0), b = (0,0,0 | 1,-1,0):
  // c = (|a|^2 - |b|^2) / (|a|^2 + |b|^2) = (3 - 2) / 5, and the second particle reverses.
  StepCorrelation corr(3);
  for (int n = 0; n < 50; ++n) {
    const double s = (n % 2) ? 1.0 : -1.0;
    corr.add({1.0, 1.0, 1.0, s, -s, 0.0});
  }
  EXPECT_NEAR(corr.correlation(), 0.2, 1e-12);
  EXPECT_NEAR(corr.alternating_share(), 0.4, 1e-12);
  EXPECT_NEAR(corr.reversed_fraction(), 0.5, 1e-12);
  EXPECT_EQ(corr.pairs(), 49u);

  StepCorrelation smooth(3);
  for (int n = 0; n < 50; ++n)
    smooth.add({1.0 + 0.01 * n, 0.5, -0.2});
  EXPECT_GT(smooth.correlation(), 0.999);
  EXPECT_EQ(smooth.reversed_fraction(), 0.0);

  StepCorrelation bad(3);
  bad.add({1.0, std::nan(""), 0.0});
  EXPECT_FALSE(bad.finite());
}

TEST(Diagnostics, LaneOrderSeparatesLayersFromRandom) {
  const std::size_t n = 400;
  State homogeneous = random_state(n, 0.6, 11);
  LaneAccumulator random_acc;
  random_acc.add(homogeneous);
  EXPECT_LT(random_acc.order(), 0.05);

  // Strings along x on a square lattice in the (y, z) plane: 5 x 5 lanes of 16 particles.
  State laned = homogeneous;
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> jitter(0.0, 0.01);
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t lane = i % 25;
    laned.x()[i] = u(rng);
    laned.y()[i] = (double(lane % 5) + 0.5) / 5.0 + jitter(rng);
    laned.z()[i] = (double(lane / 5) + 0.5) / 5.0 + jitter(rng);
  }
  LaneAccumulator lane_acc;
  lane_acc.add(laned);
  lane_acc.add(laned);
  EXPECT_GT(lane_acc.order(), 0.8);
  EXPECT_EQ(lane_acc.snapshots(), 2u);
  const int my = std::abs(lane_acc.peak_my()), mz = lane_acc.peak_mz();
  EXPECT_TRUE((my == 5 && mz == 0) || (my == 0 && mz == 5) || (my == 5 && mz == 5))
      << my << " " << mz;

  // Layers normal to y only (sliding planes): peak on the y axis.
  State layers = homogeneous;
  for (std::size_t i = 0; i < n; ++i)
    layers.y()[i] = (double(i % 4) + 0.5) / 4.0 + jitter(rng);
  LaneAccumulator layer_acc;
  layer_acc.add(layers);
  EXPECT_GT(layer_acc.order(), 0.8);
  EXPECT_EQ(std::abs(layer_acc.peak_my()), 4);
  EXPECT_EQ(layer_acc.peak_mz(), 0);
}

TEST(Diagnostics, VelocityProfileAmplitude) {
  State s = random_state(200, 0.5, 2);
  const std::size_t n = s.size();
  // Homogeneous: zero non-affine velocity.
  std::vector<double> f(3 * n, 0.0);
  LaneAccumulator flat;
  flat.add_velocity(s, f);
  EXPECT_NEAR(flat.velocity_amplitude(1e-3), 0.0, 1e-15);
  // Plug flow in two slabs: v_x = +-0.5 gdot L_y / 2 -> amplitude 0.25.
  const double gdot = 1e-3;
  for (std::size_t i = 0; i < n; ++i) {
    const double sy = s.y()[i] - std::floor(s.y()[i]);
    f[i] = (sy < 0.5 ? -0.25 : 0.25) * gdot * s.box.ly;
  }
  LaneAccumulator plug(0, 2);
  plug.add_velocity(s, f);
  EXPECT_NEAR(plug.velocity_amplitude(gdot), 0.25, 1e-12);
  EXPECT_TRUE(std::isnan(plug.velocity_amplitude(0.0)));
}

namespace {

// Steady-state samples with work W and dissipation D (constant pressure ignored).
std::vector<Sample> balance_series(double work, double loss, double noise, double du_dt) {
  std::vector<Sample> s;
  std::mt19937_64 rng(9);
  std::normal_distribution<double> g(0.0, noise);
  const double gdot = 1e-3, volume = 100.0;
  for (int k = 0; k <= 400; ++k) {
    Sample x{};
    x.time = double(k);
    x.volume = volume;
    x.sigma_xy = (work + g(rng)) / (gdot * volume);
    x.dissipation = loss + g(rng);
    x.piston_dissipation = 0.0;
    x.energy = 1.0 + du_dt * x.time;
    s.push_back(x);
  }
  return s;
}

}  // namespace

TEST(Diagnostics, EnergyBalanceResidualAndDrift) {
  const auto good = energy_balance(balance_series(2.0, 2.0, 0.01, 0.0), 100.0, 1e-3, {}, 20);
  ASSERT_TRUE(good.valid);
  EXPECT_NEAR(good.ratio, 1.0, 0.01);
  EXPECT_LT(good.error, 0.01);
  EXPECT_GT(good.error, 0.0);

  // Inflated dissipation (period-2 modes): ratio 0.2.
  const auto bad = energy_balance(balance_series(2.0, 10.0, 0.01, 0.0), 100.0, 1e-3, {}, 20);
  EXPECT_NEAR(bad.ratio, 0.2, 0.01);
  EXPECT_NEAR(bad.residual, 0.8, 0.01);

  // A relaxing (non-stationary) window: W = D + dU/dt; the drift term restores the balance.
  const auto relax = energy_balance(balance_series(1.5, 2.0, 0.0, -0.5), 100.0, 1e-3, {}, 20);
  EXPECT_NEAR(relax.raw_ratio, 0.75, 1e-9);
  EXPECT_NEAR(relax.ratio, 1.0, 1e-9);
  EXPECT_NEAR(relax.drift, -0.5, 1e-9);

  // Too few samples: invalid, no exception.
  const auto none = energy_balance(balance_series(1.0, 1.0, 0.0, 0.0), 399.0, 1e-3, {}, 20);
  EXPECT_FALSE(none.valid);
}

TEST(Diagnostics, Classification) {
  ReplicaResult r;
  r.series.samples = balance_series(2.0, 2.0, 0.01, 0.0);
  EnergyBalance eb = energy_balance(r.series.samples, 100.0, 1e-3, {}, 20);
  WindowResult w;
  w.steps_done = 100;
  w.force_correlation = 0.999;
  EXPECT_EQ(classify(r, eb, &w, {}).verdict, diagnostics::Verdict::kStable);
  w.force_correlation = 0.5;  // period-2 share 25 %
  EXPECT_EQ(classify(r, eb, &w, {}).verdict, diagnostics::Verdict::kOscillating);
  w.force_correlation = 0.999;
  w.lane_order = 0.6;
  const Classification laned = classify(r, eb, &w, {});
  EXPECT_EQ(laned.verdict, diagnostics::Verdict::kStable);
  EXPECT_TRUE(laned.laned);

  ReplicaResult bad;
  bad.series.samples = balance_series(2.0, 10.0, 0.01, 0.0);
  EnergyBalance eb_bad = energy_balance(bad.series.samples, 100.0, 1e-3, {}, 20);
  const Classification osc = classify(bad, eb_bad, nullptr, {});
  EXPECT_EQ(osc.verdict, diagnostics::Verdict::kOscillating);
  EXPECT_NE(osc.reason.find("energy balance"), std::string::npos);

  ReplicaResult failed = r;
  failed.status = RunStatus::parse("failed at t = 12: forces became non-finite");
  EXPECT_EQ(classify(failed, eb, &w, {}).verdict, diagnostics::Verdict::kDiverged);
  // Stopped by a signal with its checkpoint kept: unfinished, not diverged.
  ReplicaResult interrupted = r;
  interrupted.status = RunStatus::parse("interrupted at t = 2285.46 by SIGTERM");
  const Classification unfinished = classify(interrupted, eb, &w, {});
  EXPECT_EQ(unfinished.verdict, diagnostics::Verdict::kIncomplete);
  EXPECT_NE(unfinished.reason.find("not finished"), std::string::npos);
  w.status = RunStatus::parse("failed at step 3: cell volume became -1");
  EXPECT_EQ(classify(r, eb, &w, {}).verdict, diagnostics::Verdict::kDiverged);
}
