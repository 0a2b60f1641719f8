// Houdayer–Hartmann collapse quality (see collapse.hpp).
#include "analysis/collapse.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace jamflow::analysis {

double CollapseQuality::error() const {
  if (used == 0)
    return std::numeric_limits<double>::infinity();
  return std::sqrt((2.0 + 4.0 * std::max(s - 1.0, 0.0)) / static_cast<double>(used));
}

double CollapseQuality::threshold() const {
  return used > 0 ? 1.0 + 3.0 * std::sqrt(2.0 / static_cast<double>(used))
                  : std::numeric_limits<double>::quiet_NaN();
}

bool CollapseQuality::acceptable() const {
  return used > 0 && s <= threshold();
}

namespace {

// Each curve's points per branch, sorted by x (index: curve, then branch 0 or 1).
std::vector<std::array<std::vector<const CollapsePoint*>, 2>> curves_by_branch(
    const std::vector<CollapsePoint>& points) {
  std::size_t ncurves = 0;
  for (const auto& p : points)
    ncurves = std::max(ncurves, p.curve + 1);
  std::vector<std::array<std::vector<const CollapsePoint*>, 2>> curves(ncurves);
  for (const auto& p : points)
    curves[p.curve][p.branch != 0 ? 1 : 0].push_back(&p);
  for (auto& c : curves) {
    for (auto& b : c) {
      std::sort(b.begin(), b.end(),
                [](const CollapsePoint* a, const CollapsePoint* c2) { return a->x < c2->x; });
    }
  }
  return curves;
}

}  // namespace

CollapseQuality houdayer_hartmann(const std::vector<CollapsePoint>& points) {
  const auto curves = curves_by_branch(points);
  const std::size_t ncurves = curves.size();
  CollapseQuality q;
  q.total = points.size();
  double sum = 0.0;
  for (const auto& p : points) {
    const int branch = p.branch != 0 ? 1 : 0;
    const double xi = p.x;
    double s0 = 0, s1 = 0, s2 = 0, t0 = 0, t1 = 0;
    int count = 0;
    for (std::size_t k = 0; k < ncurves; ++k) {
      if (k == p.curve)
        continue;  // never the point's own curve
      const auto& c = curves[k][branch];
      if (c.size() < 2 || xi < c.front()->x || xi > c.back()->x)
        continue;
      auto hi = std::upper_bound(c.begin(), c.end(), xi,
                                 [](double v, const CollapsePoint* a) { return v < a->x; });
      if (hi == c.end())
        --hi;
      auto lo = hi - 1;
      for (auto it : {lo, hi}) {
        const double w = 1.0 / ((*it)->dy * (*it)->dy);
        const double dx = (*it)->x - xi;
        s0 += w;
        s1 += w * dx;
        s2 += w * dx * dx;
        t0 += w * (*it)->y;
        t1 += w * dx * (*it)->y;
      }
      ++count;
    }
    if (count == 0)
      continue;
    // Weighted straight line y = m0 + m1 (x - x_i) through the neighbours:
    // Y_i = m0, dY_i^2 = Var(m0).
    double y_hat = 0.0, var_hat = 0.0;
    const double det = s0 * s2 - s1 * s1;
    if (det > 1e-12 * s0 * s2 && det > 0.0) {
      y_hat = (s2 * t0 - s1 * t1) / det;
      var_hat = s2 / det;
    } else {  // all neighbours at the same x: their weighted mean
      y_hat = t0 / s0;
      var_hat = 1.0 / s0;
    }
    sum += std::pow(p.y - y_hat, 2) / (p.dy * p.dy + var_hat);
    ++q.used;
  }
  q.s = q.used > 0 ? sum / static_cast<double>(q.used) : std::numeric_limits<double>::infinity();
  return q;
}

CollapseQuality pairwise_interpolation(const std::vector<CollapsePoint>& points) {
  const auto curves = curves_by_branch(points);
  const std::size_t ncurves = curves.size();
  CollapseQuality q;
  q.total = points.size();
  double sum = 0.0;
  for (const auto& p : points) {
    const int branch = p.branch != 0 ? 1 : 0;
    double point_sum = 0.0;
    int count = 0;
    for (std::size_t k = 0; k < ncurves; ++k) {
      if (k == p.curve)
        continue;
      const auto& c = curves[k][branch];
      if (c.size() < 2 || p.x < c.front()->x || p.x > c.back()->x)
        continue;
      auto hi = std::upper_bound(c.begin(), c.end(), p.x,
                                 [](double v, const CollapsePoint* a) { return v < a->x; });
      if (hi == c.end())
        --hi;
      const CollapsePoint* b = *hi;
      const CollapsePoint* a = *(hi - 1);
      const double t = b->x > a->x ? (p.x - a->x) / (b->x - a->x) : 0.5;
      const double y = (1.0 - t) * a->y + t * b->y;
      const double var = (1.0 - t) * (1.0 - t) * a->dy * a->dy + t * t * b->dy * b->dy;
      point_sum += std::pow(p.y - y, 2) / (p.dy * p.dy + var);
      ++count;
    }
    if (count == 0)
      continue;
    sum += point_sum / count;
    ++q.used;
  }
  q.s = q.used > 0 ? sum / static_cast<double>(q.used) : std::numeric_limits<double>::infinity();
  return q;
}

}  // namespace jamflow::analysis
