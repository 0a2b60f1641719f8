// Quantitative quality of a data collapse: Houdayer & Hartmann, Phys. Rev. B 70,
// 014418 (2004). The points are already in scaled coordinates (x, y) with the
// error dy of y; each belongs to one curve (a state-point family: a system
// size, a density, ...) and to one branch (the Olsson–Teitel scaling has two).
// Each point i is compared with the master curve Y(x_i) estimated from the
// *other* curves of its branch only: from each other curve the two points
// bracketing x_i, through which a weighted straight line is fitted.
//   S = (1/N_used) sum_i (y_i - Y_i)^2 / (dy_i^2 + dY_i^2),
// dY_i the error of the line at x_i. S ~ 1 for a collapse consistent with the
// data errors, S >> 1 for a bad one. Points without bracketing neighbours do
// not count. Used by the Olsson–Teitel analysis (in log coordinates) and by the
// finite-size collapse of the hard-sphere analysis (paper Fig. 6).
#pragma once

#include <cstddef>
#include <vector>

namespace jamflow::analysis {

struct CollapseQuality {
  double s = 0.0;         // Houdayer–Hartmann S
  std::size_t used = 0;   // points with neighbours on another curve
  std::size_t total = 0;  // points in the data (that could be scaled)
  // Spread of S if the residuals were Gaussian with the observed mean square:
  // a mean of N_used noncentral chi2(1) terms has variance (2 + 4 (S-1)) / N_used
  // (correlations between neighbouring interpolations are neglected).
  double error() const;
  // Consistent with a perfect collapse: S <= 1 + 3 sqrt(2/N_used), the
  // 3-sigma upper end of S for Gaussian residuals with the stated errors.
  bool acceptable() const;
  double threshold() const;  // 1 + 3 sqrt(2/N_used); NaN when no point was used
};

struct CollapsePoint {
  double x = 0.0, y = 0.0, dy = 0.0;  // dy > 0
  std::size_t curve = 0;
  int branch = 0;  // 0 or 1
};

// S over the points (total = points.size()).
CollapseQuality houdayer_hartmann(const std::vector<CollapsePoint>& points);

// An independent measure of the same kind, for checking that a verdict does not hinge on the
// estimator: each point is compared with every other curve of its branch separately, by linear
// interpolation between that curve's two points bracketing its x (error (1-t)^2 dy_a^2 +
// t^2 dy_b^2), and S is the mean over points of the mean over those curves of
// (y - Y_k)^2 / (dy^2 + dY_k^2). Houdayer–Hartmann instead fits one line through all
// neighbours, whose error shrinks with the number of curves. Same S ~ 1 meaning, same
// acceptability bound.
CollapseQuality pairwise_interpolation(const std::vector<CollapsePoint>& points);

}  // namespace jamflow::analysis
