// Block averages and autocorrelation times.
#include "lib/statistics.hpp"

#include <cmath>
#include <string>

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
  for (std::size_t b = 0; b < blocks; ++b) {
    double s = 0.0;
    for (std::size_t k = 0; k < len; ++k)
      s += x[offset + b * len + k];
    out.blocks[b] = s / double(len);
  }
  double m = 0.0;
  for (double v : out.blocks)
    m += v;
  m /= double(blocks);
  double var = 0.0;
  for (double v : out.blocks)
    var += (v - m) * (v - m);
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
  double m = 0.0;
  for (double v : x)
    m += v;
  m /= double(n);
  double c0 = 0.0;
  for (double v : x)
    c0 += (v - m) * (v - m);
  c0 /= double(n);
  if (!(c0 > 0.0))
    return 0.5;
  double tau = 0.5;
  for (std::size_t k = 1; k < n / 2; ++k) {
    double ck = 0.0;
    for (std::size_t i = 0; i + k < n; ++i)
      ck += (x[i] - m) * (x[i + k] - m);
    ck /= double(n);
    tau += ck / c0;
    if (double(k) >= 6.0 * tau)
      break;
  }
  return tau < 0.5 ? 0.5 : tau;
}

}  // namespace jamflow
