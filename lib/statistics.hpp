// Time-series statistics: block averages with standard errors and the integrated
// autocorrelation time.
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
// self-consistent window (stop at the first k >= c tau, c = 6). Returns 0.5 for white noise.
double integrated_autocorrelation(const std::vector<double>& x);

}  // namespace jamflow
