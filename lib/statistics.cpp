// Block averages and autocorrelation times.
#include "lib/statistics.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include <gsl/gsl_fft_halfcomplex.h>
#include <gsl/gsl_fft_real.h>

#include "lib/error.hpp"

namespace jamflow {

BlockAverage block_average(const std::vector<double>& x, std::size_t blocks) {
  if (blocks < 2)
    throw ConfigError("[run] blocks = " + std::to_string(blocks) + "; allowed >= 2");
  if (x.size() < blocks) {
    throw ConfigError("averaging window has " + std::to_string(x.size()) + " samples, fewer than " +
                      "[run] blocks = " + std::to_string(blocks) +
                      "; lengthen t_av or sample more often");
  }
  const std::size_t len = x.size() / blocks;
  const std::size_t offset = x.size() - len * blocks;
  BlockAverage out;
  out.blocks.resize(blocks);
  // Sums of deviations from a reference sample: a constant series (phi at constant volume)
  // then gives exactly equal block means and a zero error, not round-off scatter.
  const double ref = x[offset];
  std::vector<double> dev(blocks);
  for (std::size_t b = 0; b < blocks; ++b) {
    double s = 0.0;
    for (std::size_t k = 0; k < len; ++k)
      s += x[offset + b * len + k] - ref;
    dev[b] = s / double(len);
    out.blocks[b] = ref + dev[b];
  }
  double dm = 0.0;
  for (double v : dev)
    dm += v;
  dm /= double(blocks);
  const double m = ref + dm;
  double var = 0.0;
  for (double v : dev)
    var += (v - dm) * (v - dm);
  var /= double(blocks - 1);
  out.mean = m;
  out.block_std = std::sqrt(var);
  out.error = std::sqrt(var / double(blocks));
  return out;
}

double integrated_autocorrelation(const std::vector<double>& x) {
  const std::size_t n = x.size();
  if (n < 4)
    return 0.5;
  // A constant series (phi at constant volume) has no correlation time. Its deviations from
  // the computed mean are that mean's round-off, the same for every sample, so they would look
  // perfectly correlated (tau ~ n); and that round-off grows with n, so it cannot be told from
  // real variation by the variance. The spread of the values themselves can: variation at the
  // round-off level of the values is none. (NaN: also 0.5.)
  const auto [lo, hi] = std::minmax_element(x.begin(), x.end());
  if (!(*hi - *lo > 1e-13 * std::max(std::abs(*lo), std::abs(*hi))))
    return 0.5;
  double m = 0.0;
  for (double v : x)
    m += v;
  m /= double(n);
  // The autocovariance at every lag, c_k = (1/n) sum_i (x_i - m)(x_{i+k} - m), from the power
  // spectrum of the series padded with zeros to at least 2n (so that no lag wraps around): O(n
  // log n), where the sums lag by lag cost n per lag, and the window below can reach n/2 lags
  // for a long correlation time.
  std::size_t len = 1;
  while (len < 2 * n)
    len *= 2;
  std::vector<double> c(len, 0.0);
  for (std::size_t i = 0; i < n; ++i)
    c[i] = x[i] - m;
  gsl_fft_real_radix2_transform(c.data(), 1, len);
  // Half-complex layout: c[0] and c[len/2] are real, c[k] and c[len - k] are Re and Im of k.
  c[0] *= c[0];
  c[len / 2] *= c[len / 2];
  for (std::size_t k = 1; k < len / 2; ++k) {
    c[k] = c[k] * c[k] + c[len - k] * c[len - k];
    c[len - k] = 0.0;
  }
  gsl_fft_halfcomplex_radix2_inverse(c.data(), 1, len);
  const double c0 = c[0] / double(n);
  if (!(c0 > 0.0))
    return 0.5;
  double tau = 0.5;
  for (std::size_t k = 1; k < n / 2; ++k) {
    tau += c[k] / double(n) / c0;
    if (double(k) >= 6.0 * tau)
      break;
  }
  return tau < 0.5 ? 0.5 : tau;
}

// The variance of the mean of a stationary series over a length T with correlation exp(-t/tau)
// is (2 sigma^2 tau / T) (1 - (tau / T) (1 - exp(-T / tau))). Blocks of length B give means
// with that variance at T = B; taken as independent, they estimate the variance of the mean
// over M B as that over M, while its true value is 2 sigma^2 tau / (M B) for M B >> tau.
double block_error_ratio(double block, double tau) {
  if (!(block > 0.0) || !(tau >= 0.0))
    throw std::invalid_argument("block_error_ratio: block must be > 0 and tau >= 0");
  if (tau == 0.0)
    return 1.0;
  const double x = block / tau;
  return std::sqrt(1.0 - (1.0 - std::exp(-x)) / x);
}

ReplicaAverage replica_average(const std::vector<double>& means,
                               const std::vector<double>& errors) {
  if (means.empty() || means.size() != errors.size())
    throw std::invalid_argument("replica_average: need one error per mean and at least one mean");
  const double k = double(means.size());
  ReplicaAverage out;
  double e2 = 0.0;
  for (std::size_t r = 0; r < means.size(); ++r) {
    out.mean += means[r];
    e2 += errors[r] * errors[r];
  }
  out.mean /= k;
  out.block_error = std::sqrt(e2) / k;
  if (means.size() > 1) {
    double var = 0.0;
    for (double m : means)
      var += (m - out.mean) * (m - out.mean);
    out.replica_std = std::sqrt(var / (k - 1.0));
    out.replica_error = out.replica_std / std::sqrt(k);
  }
  return out;
}

std::size_t mser_truncation(const std::vector<double>& x, std::size_t batch) {
  if (batch == 0)
    batch = 1;
  const std::size_t m = x.size() / batch;
  if (m < 4)
    return 0;
  // Batch means of the newest m * batch samples (the oldest remainder counts as transient).
  const std::size_t skip = x.size() - m * batch;
  std::vector<double> y(m);
  for (std::size_t b = 0; b < m; ++b) {
    double s = 0.0;
    for (std::size_t k = 0; k < batch; ++k)
      s += x[skip + b * batch + k];
    y[b] = s / double(batch);
  }
  // Suffix sums of y and y^2 give each MSER(d) in O(1); the sum of squares about the mean is
  // computed about a shift (the last mean) to keep cancellation small.
  const double shift = y.back();
  std::vector<double> s1(m + 1, 0.0), s2(m + 1, 0.0);
  for (std::size_t b = m; b-- > 0;) {
    s1[b] = s1[b + 1] + (y[b] - shift);
    s2[b] = s2[b + 1] + (y[b] - shift) * (y[b] - shift);
  }
  std::size_t best = 0;
  double best_value = std::numeric_limits<double>::infinity();
  for (std::size_t d = 0; d <= m / 2; ++d) {
    const double left = double(m - d);
    const double ss = std::max(0.0, s2[d] - s1[d] * s1[d] / left);
    const double value = ss / (left * left);
    if (value < best_value) {
      best_value = value;
      best = d;
    }
  }
  return best == 0 ? 0 : skip + best * batch;
}

}  // namespace jamflow
