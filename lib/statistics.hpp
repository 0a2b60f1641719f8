// Time-series statistics: block averages with standard errors and the integrated
// autocorrelation time, and the combination of independent replicas.
#pragma once
#include <cstddef>
#include <vector>

namespace jamflow {

struct BlockAverage {
  double mean = 0.0;
  double error = 0.0;      // standard error of the mean from the block scatter
  double block_std = 0.0;  // standard deviation of the block means
  std::vector<double> blocks;
};

// Splits the series into `blocks` contiguous blocks of equal length (a remainder at the start
// is dropped so the newest samples are kept). Requires at least `blocks` samples.
BlockAverage block_average(const std::vector<double>& x, std::size_t blocks);

// Integrated autocorrelation time in units of samples, tau = 1/2 + sum_k rho(k), with Sokal's
// self-consistent window (stop at the first k >= c tau, c = 6). Returns 0.5 for white noise and
// for a constant series (values that vary at round-off level only).
double integrated_autocorrelation(const std::vector<double>& x);

// The end of the initial transient of a series, by the marginal standard error rule on batch
// means of `batch` samples (MSER-5 for batch = 5; White 1997, Franklin & White 2008): the
// truncation d that minimises the squared standard error of the mean of what is left,
//   MSER(d) = sum_{i >= d} (y_i - mean_d)^2 / (m - d)^2   over the m batch means y,
// searched over the first half of the batches only (later minima are the rule's known
// artefact at the end of a series). Returns the number of samples to drop.
std::size_t mser_truncation(const std::vector<double>& x, std::size_t batch = 5);

// For correlations that decay as exp(-t / tau), the expected ratio of the error of a mean from
// many blocks of length `block` (in the units of tau) to its true error:
// sqrt(1 - (tau / block) (1 - exp(-block / tau))). 1 for tau = 0; 0.75 at block = 2 tau, 0.9 at
// 5.3 tau. Correlations with a slower tail make the block error smaller still.
double block_error_ratio(double block, double tau);

// K independent replicas of one observable, each with its own mean and block error.
struct ReplicaAverage {
  double mean = 0.0;           // mean over replicas
  double block_error = 0.0;    // sqrt(sum_k err_k^2) / K: the block errors propagated to the mean
  double replica_std = 0.0;    // standard deviation of the replica means (K - 1 in the denominator)
  double replica_error = 0.0;  // replica_std / sqrt(K): the error from the replica scatter
};

// Requires means.size() == errors.size() >= 1; with one replica the scatter terms are 0.
ReplicaAverage replica_average(const std::vector<double>& means, const std::vector<double>& errors);

// The error of a state point's mean over `replicas` replicas, as the sweep's tables and the
// analyses use it: the block error, or the replica-scatter error where that is larger, the
// latter only from kMinReplicasForScatter replicas on. The standard deviation of two means has
// one degree of freedom: it is below a third of the true spread one time in four and above
// twice it one time in twenty (chi2 with 1 dof), so a maximum with it inflates or keeps errors
// at random. Three replicas give two degrees of freedom, the least the seed's protocol runs
// (SPEC §5: at least 3 independent runs per state point).
inline constexpr int kMinReplicasForScatter = 3;
inline bool replica_scatter_used(double replicas) {
  return replicas >= kMinReplicasForScatter;
}
inline double replica_point_error(double block_error, double replica_error, double replicas) {
  if (replica_scatter_used(replicas) && replica_error > block_error)  // false for NaN
    return replica_error;
  return block_error;
}

}  // namespace jamflow
