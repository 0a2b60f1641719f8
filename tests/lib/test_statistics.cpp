// Block averages, replica averages and autocorrelation times (lib/statistics).
#include "lib/statistics.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <cmath>
#include <random>
#include <stdexcept>
#include <utility>
#include <vector>

namespace jamflow {
namespace {

// Reference: the autocovariance summed lag by lag, with the same window as the library.
double direct_autocorrelation_time(const std::vector<double>& x) {
  const std::size_t n = x.size();
  double m = 0.0;
  for (const double v : x)
    m += v;
  m /= double(n);
  const auto cov = [&](std::size_t k) {
    double c = 0.0;
    for (std::size_t i = 0; i + k < n; ++i)
      c += (x[i] - m) * (x[i + k] - m);
    return c / double(n);
  };
  const double c0 = cov(0);
  double tau = 0.5;
  for (std::size_t k = 1; k < n / 2; ++k) {
    tau += cov(k) / c0;
    if (double(k) >= 6.0 * tau)
      break;
  }
  return tau < 0.5 ? 0.5 : tau;
}

// An AR(1) series x_i = a x_{i-1} + noise with a = exp(-1/tau): correlation a^k, integrated
// autocorrelation time (1 + a) / (2 (1 - a)), about tau samples.
std::vector<double> ar1(std::size_t n, double tau, unsigned seed) {
  std::mt19937_64 gen(seed);
  std::normal_distribution<double> z;
  const double a = std::exp(-1.0 / tau);
  std::vector<double> x(n);
  double v = z(gen);
  for (auto& e : x) {
    v = a * v + std::sqrt(1.0 - a * a) * z(gen);
    e = 0.6 + 1e-3 * v;
  }
  return x;
}

TEST(Statistics, ReplicaAverage) {
  const ReplicaAverage one = replica_average({2.0}, {0.3});
  EXPECT_DOUBLE_EQ(one.mean, 2.0);
  EXPECT_DOUBLE_EQ(one.block_error, 0.3);
  EXPECT_DOUBLE_EQ(one.replica_error, 0.0);
  const ReplicaAverage r = replica_average({1.0, 2.0, 3.0}, {0.3, 0.4, 1.2});
  EXPECT_DOUBLE_EQ(r.mean, 2.0);
  EXPECT_DOUBLE_EQ(r.block_error, 1.3 / 3.0);  // sqrt(0.09 + 0.16 + 1.44) = 1.3
  EXPECT_DOUBLE_EQ(r.replica_std, 1.0);
  EXPECT_DOUBLE_EQ(r.replica_error, 1.0 / std::sqrt(3.0));
  EXPECT_THROW(replica_average({1.0}, {}), std::invalid_argument);
}

// The point error of the tables and analyses: two replicas far apart do not change the block
// error (their scatter has one degree of freedom), three do; a scatter below the block error,
// or none (NaN), leaves the block error.
TEST(Statistics, ReplicaScatterOnlyFromThreeReplicas) {
  const ReplicaAverage two = replica_average({1.0, 3.0}, {0.01, 0.01});
  EXPECT_DOUBLE_EQ(replica_point_error(two.block_error, two.replica_error, 2.0), two.block_error);
  const ReplicaAverage three = replica_average({1.0, 3.0, 2.0}, {0.01, 0.01, 0.01});
  EXPECT_GT(three.replica_error, 10.0 * three.block_error);
  EXPECT_DOUBLE_EQ(replica_point_error(three.block_error, three.replica_error, 3.0),
                   three.replica_error);
  EXPECT_DOUBLE_EQ(replica_point_error(0.5, 0.1, 4.0), 0.5);
  EXPECT_DOUBLE_EQ(replica_point_error(0.5, std::nan(""), 3.0), 0.5);
  EXPECT_FALSE(replica_scatter_used(2.0));
  EXPECT_TRUE(replica_scatter_used(3.0));
}

TEST(Statistics, ConstantSeriesHasNoCorrelationTime) {
  // phi at constant volume: a constant whose mean carries round-off must not look correlated.
  const std::vector<double> phi(3000, 0.1 + 0.2 + 0.319439);
  EXPECT_DOUBLE_EQ(integrated_autocorrelation(phi), 0.5);
  // A long run's: the mean's round-off grows with the length (here well above 1e-13 of it).
  for (const std::size_t n : {10001, 20001, 200001})
    EXPECT_DOUBLE_EQ(integrated_autocorrelation(std::vector<double>(n, 0.62)), 0.5) << n;
  std::vector<double> alternating(3000);
  for (std::size_t k = 0; k < alternating.size(); ++k)
    alternating[k] = 0.6 + (k % 2 ? 1e-6 : -1e-6);  // anticorrelated: clamped at white noise
  EXPECT_DOUBLE_EQ(integrated_autocorrelation(alternating), 0.5);
  std::vector<double> ramp(3000);
  for (std::size_t k = 0; k < ramp.size(); ++k)
    ramp[k] = 0.6 + 1e-9 * double(k);  // tiny but real variation is still seen as correlated
  EXPECT_GT(integrated_autocorrelation(ramp), 100.0);
}

TEST(Statistics, AutocorrelationTimeFromSpectrumEqualsDirectSums) {
  // The spectral autocovariance against sums lag by lag: the same up to round-off, for white
  // noise, short and long correlations, and lengths that are and are not powers of two.
  for (const auto& [n, tau] : {std::pair<std::size_t, double>{4096, 0.0},
                               {5000, 3.0},
                               {20000, 30.0},
                               {6000, 400.0},
                               {7, 1.0}}) {
    std::vector<double> x = tau > 0.0 ? ar1(n, tau, 11) : ar1(n, 1e-3, 12);
    const double fast = integrated_autocorrelation(x), ref = direct_autocorrelation_time(x);
    EXPECT_NEAR(fast, ref, 1e-9 * ref) << "n = " << n << ", tau = " << tau;
  }
}

TEST(Statistics, AutocorrelationTimeOfAnAr1Series) {
  // 400000 samples with tau = 20: the estimator's relative standard error is about
  // sqrt(2 (2 W + 1) / n) = 3.5% for a window W = 6 tau; the tolerance of 15% is over 4 of them.
  // The window's truncation bias, exp(-6) of the sum, is 0.25%.
  const double a = std::exp(-1.0 / 20.0);
  const double exact = (1.0 + a) / (2.0 * (1.0 - a));
  EXPECT_NEAR(integrated_autocorrelation(ar1(400000, 20.0, 5)), exact, 0.15 * exact);
}

TEST(Statistics, BlockErrorRatioOfExponentialCorrelations) {
  // Against the exact discrete AR(1) result: the variance of a block mean of B samples is
  // (1/B) [1 + 2 sum_{k<B} (1 - k/B) a^k], against (1 + a) / (1 - a) / (M B) for the whole
  // run. The continuous formula differs by 4e-4 at worst here (tau = 20 samples, B = tau).
  for (const double tau : {20.0, 50.0}) {
    const double a = std::exp(-1.0 / tau), tau_int = (1.0 + a) / (2.0 * (1.0 - a));
    for (const double blocks_of_tau : {1.0, 2.0, 5.0, 20.0}) {
      const int b = int(blocks_of_tau * tau);
      double s = 1.0, ak = 1.0;
      for (int k = 1; k < b; ++k) {
        ak *= a;
        s += 2.0 * (1.0 - double(k) / b) * ak;
      }
      const double exact = std::sqrt(s / ((1.0 + a) / (1.0 - a)));
      EXPECT_NEAR(block_error_ratio(b, tau_int), exact, 2e-3 * exact) << tau << " " << b;
    }
  }
  EXPECT_DOUBLE_EQ(block_error_ratio(10.0, 0.0), 1.0);
  EXPECT_NEAR(block_error_ratio(2.0, 1.0), 0.754, 1e-3);
  EXPECT_THROW(block_error_ratio(0.0, 1.0), std::invalid_argument);
  EXPECT_THROW(block_error_ratio(1.0, -1.0), std::invalid_argument);
}

TEST(Statistics, BlockErrorsOfCorrelatedRunsAreAsSmallAsPredicted) {
  // 2000 runs of 20 blocks of 2 tau (tau = 20 samples): the mean squared block error over the
  // spread of the run means. The ratio's standard error from 2000 runs is about 1.6%; the
  // tolerance of 8% is 5 of them. Blocks of 2 tau are also where adjacent blocks still
  // correlate a little, which the formula ignores (1% here).
  const std::size_t runs = 2000, blocks = 20, length = 40;
  double err2 = 0.0, sum = 0.0, sum2 = 0.0;
  for (std::size_t r = 0; r < runs; ++r) {
    const BlockAverage b = block_average(ar1(blocks * length, 20.0, 100 + r), blocks);
    err2 += b.error * b.error;
    sum += b.mean;
    sum2 += b.mean * b.mean;
  }
  const double mean = sum / runs, var = (sum2 - runs * mean * mean) / (runs - 1);
  const double a = std::exp(-1.0 / 20.0), tau_int = (1.0 + a) / (2.0 * (1.0 - a));
  const double predicted = block_error_ratio(double(length), tau_int);
  EXPECT_NEAR(std::sqrt(err2 / runs / var), predicted, 0.08 * predicted);
}

}  // namespace
}  // namespace jamflow

namespace jamflow {
namespace {

// MSER-5: a decaying transient (amplitude 20 sigma, decay 50 samples) followed by noise is cut
// where the transient has fallen into the noise (about 150 samples: 20 e^-3 = 1 sigma); white
// noise alone is cut little (the rule's minimum falls in the first few batches).
TEST(Mser, CutsTheTransientAndLittleOfPlainNoise) {
  std::mt19937 rng(3);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<double> x(2000), noise(2000);
  for (std::size_t k = 0; k < x.size(); ++k) {
    x[k] = 20.0 * std::exp(-double(k) / 50.0) + g(rng);
    noise[k] = g(rng);
  }
  const std::size_t cut = mser_truncation(x);
  EXPECT_GT(cut, 80u);
  EXPECT_LT(cut, 400u);
  EXPECT_LT(mser_truncation(noise), 200u);
  EXPECT_EQ(mser_truncation({1.0, 2.0, 3.0}), 0u);  // too short to judge
}

}  // namespace
}  // namespace jamflow
