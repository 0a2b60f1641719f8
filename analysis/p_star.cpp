#include "analysis/p_star.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace jamflow::analysis {
namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
}  // namespace

PStar find_p_star(const std::vector<ScanValue>& points, const ScanValue& ref, double sigmas) {
  PStar out;
  const std::size_t m = points.size();
  out.agrees.assign(m, -1);
  out.dmu.assign(m, kNaN);
  out.dmu_err.assign(m, kNaN);
  out.dphi.assign(m, kNaN);
  out.dphi_err.assign(m, kNaN);
  std::vector<std::size_t> order(m);
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return points[a].pressure < points[b].pressure; });
  for (std::size_t k = 0; k < m; ++k) {
    const ScanValue& p = points[k];
    if (!p.usable || !ref.usable)
      continue;
    out.dmu[k] = p.mu - ref.mu;
    out.dmu_err[k] = std::hypot(p.mu_err, ref.mu_err);
    out.dphi[k] = p.phi - ref.phi;
    out.dphi_err[k] = std::hypot(p.phi_err, ref.phi_err);
    out.agrees[k] = std::abs(out.dmu[k]) <= sigmas * out.dmu_err[k] &&
                    std::abs(out.dphi[k]) <= sigmas * out.dphi_err[k];
  }
  bool chain = true, above = false;
  std::size_t in_chain = 0;
  for (const std::size_t k : order) {
    if (out.agrees[k] < 0)
      continue;
    if (out.smallest < 0) {
      out.smallest = int(k);
      out.reached = out.agrees[k] == 1;
    }
    if (!chain || out.agrees[k] != 1) {
      above = above || chain;  // the first usable point that differs
      chain = false;
      continue;
    }
    out.p_star = points[k].pressure;
    ++in_chain;
  }
  if (!out.reached)
    out.p_star = kNaN;
  if (out.smallest >= 0 && ref.usable) {
    for (std::size_t k = 0; k < m; ++k) {
      const ScanValue& p = points[k];
      if (p.usable || !(p.pressure < points[std::size_t(out.smallest)].pressure) ||
          !std::isfinite(p.mu) || !std::isfinite(p.phi))
        continue;
      ++out.left_out_below;
      out.left_out_below_agrees =
          out.left_out_below_agrees ||
          (std::abs(p.mu - ref.mu) <= sigmas * std::hypot(p.mu_err, ref.mu_err) &&
           std::abs(p.phi - ref.phi) <= sigmas * std::hypot(p.phi_err, ref.phi_err));
    }
  }
  out.p_star_is_smallest = out.reached && in_chain == 1 && above;
  out.p_star_is_largest = out.reached && !above;
  return out;
}

}  // namespace jamflow::analysis
