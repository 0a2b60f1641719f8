// Olsson–Teitel two-branch scaling (paper label `teitel`, Fig. 9):
//   sigma_xy = |phi - phi_J|^alpha G_pm( gdot / |phi - phi_J|^(alpha+beta) ),
// and a quantitative collapse-quality measure, Houdayer & Hartmann's S
// (analysis/collapse.hpp), in the scaled variables
//   x = ln gdot - (alpha+beta) ln|phi - phi_J|,  y = ln sigma - alpha ln|phi - phi_J|,
// with dy = sigma_err/sigma, the curves being the densities and the branches
// the signs of phi - phi_J.
// We use it rather than Bhattacharjee–Seno because it weighs residuals by
// the data errors, so S has an absolute meaning ("consistent within errors"),
// which is what "acceptable collapse" means in the paper.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "analysis/collapse.hpp"
#include "analysis/data.hpp"
#include "analysis/fit.hpp"
#include "analysis/seed.hpp"
#include "analysis/soft.hpp"

namespace jamflow::analysis {

struct CollapseParams {
  double phi_j = seed::kTeitelPhiJ;   // the paper's (Fig. 9)
  double alpha = seed::kTeitelAlpha;  // 1/x
  double beta = seed::kTeitelBeta;    // 1/b_phi
};

class HoudayerHartmann {
 public:
  explicit HoudayerHartmann(std::vector<ShearPoint> points);

  // Quality at the given parameters; sigma_override (one per point) replaces
  // the measured stresses, for the bootstrap.
  CollapseQuality evaluate(const CollapseParams& p,
                           const std::vector<double>* sigma_override = nullptr) const;
  // The independent pairwise-interpolation measure (collapse.hpp) at the same parameters.
  CollapseQuality evaluate_pairwise(const CollapseParams& p) const;

  // Scaled coordinates of every point (for plots): x = gdot/|dphi|^(a+b),
  // y = sigma/|dphi|^a, branch = sign(phi - phi_J).
  struct Scaled {
    double x, y, dy_rel;
    int branch;
    std::size_t set;
  };
  std::vector<Scaled> scaled(const CollapseParams& p) const;

  const std::vector<ShearPoint>& points() const { return points_; }
  const std::vector<std::string>& set_names() const { return set_names_; }

 private:
  std::vector<CollapsePoint> log_scaled(const CollapseParams& p,
                                        const std::vector<double>* sigma_override) const;
  std::vector<ShearPoint> points_;
  std::vector<std::size_t> set_of_;
  std::vector<std::string> set_names_;
  std::vector<double> log_gdot_, log_sigma_, dy_;
};

struct OlssonTeitelOptions {
  CollapseParams at;                    // --at
  std::optional<CollapseParams> start;  // optimiser start (default: at)
  int bootstrap = 100;                  // resamples for the errors
  std::uint64_t seed = 20150112;
  double min_overlap = 0.5;           // optimiser: fraction of points that must have neighbours
  std::optional<double> split_delta;  // near/far split in |phi - phi_J| (default: median)
  std::optional<double> split_gdot;   // slow/fast split in gdot (default: geometric median)
  std::size_t min_subset_points = 12;
  // Fit the soft granular rheology to the same points and report its quality (needs the
  // measured pressure of every point).
  bool soft = true;
};

struct CollapseFit {
  CollapseParams best;
  Measured phi_j, alpha, beta;  // errors: parametric-bootstrap standard deviations
  CollapseQuality quality;
  int bootstrap_used = 0;
  double s_spread = 0.0;  // standard deviation of S at the resamples' optima
};

// The soft granular rheology (soft.hpp) fitted to the same constant-volume points. Each point
// (phi, gdot imposed; P and sigma_xy measured) becomes a granular point (P, J = gdot/P, phi,
// mu = sigma/P); the error of phi is the law's d phi/d ln P at fixed gdot times the relative
// error of P (the imposed phi is exact, the measured P is not; the slope comes from the law
// of the previous round, two rounds from the paper's values). Its quality is the same kind of
// number as S: the mean over points of ((ln sigma - ln sigma_law(phi, gdot)) / dln sigma)^2,
// sigma_law solved from phi(P, gdot/P) = phi. Errors: parametric bootstrap, each sigma and P
// redrawn log-normally within its error and the law refitted from the optimum.
struct SoftComparison {
  JointSoftFit fit;                 // params carry the bootstrap errors
  double s = 0.0;                   // mean squared pull in ln sigma
  double s_spread = 0.0;            // bootstrap standard deviation of s
  std::size_t used = 0, total = 0;  // points with a law stress (a pressure root)
  int bootstrap_used = 0;
  std::vector<double> sigma_law;  // per input point (NaN: no root)
  bool acceptable() const;        // the same criterion as CollapseQuality
};

// Fails with InsufficientDataError when a point has no measured pressure.
SoftComparison compare_soft(const std::vector<ShearPoint>& points, const OlssonTeitelOptions& o);

struct CollapseSubset {
  std::string name, description;
  std::vector<std::size_t> indices;  // into the data
  std::optional<CollapseFit> fit;
  std::string skipped;                     // reason, if not fitted
  CollapseQuality at_global_best;          // this subset at the global optimum
  CollapseQuality complement_at_own_best;  // the rest of the data at this subset's optimum
  CollapseQuality complement_at_global_best;
  // True when the subset's own optimum improves the subset but worsens the
  // rest, and leaves the rest with an unacceptable collapse: the paper's
  // "improving one part of the plot deteriorates another" (Sec. V B).
  bool trade_off = false;
};

// The collapse at one parameter set under both measures (collapse.hpp): whether "a collapse"
// is a property of the data or of the estimator.
struct MeasureComparison {
  std::string label;
  CollapseParams params;
  CollapseQuality houdayer_hartmann, pairwise;
};

struct OlssonTeitelResult {
  PointErrors point_errors;  // what the input points' errors are made of
  // At the paper's parameters, at the Houdayer–Hartmann optimum and at the pairwise measure's
  // own optimum (same optimiser and overlap constraint).
  std::vector<MeasureComparison> measures;
  std::int64_t n = 0;
  std::size_t points = 0, sets = 0;
  CollapseParams at;
  CollapseQuality at_quality;
  CollapseFit best;
  std::vector<CollapseSubset> subsets;
  double split_delta = 0.0, split_gdot = 0.0;
  std::optional<SoftComparison> soft;
  std::string soft_skipped;
  std::vector<std::string> warnings;
};

// Nelder–Mead (gsl_multimin nmsimplex2) on S over (phi_J, alpha, beta),
// restarted from its own optimum; errors from a parametric bootstrap (each
// sigma redrawn log-normally within its error, the optimiser rerun). The
// bootstrap is chosen over the curvature because S is only piecewise smooth:
// it jumps whenever a point gains or loses a bracketing neighbour.
CollapseFit optimize_collapse(const HoudayerHartmann& hh, const CollapseParams& start,
                              const OlssonTeitelOptions& options, std::uint64_t seed);

OlssonTeitelResult analyze_olsson_teitel(const std::vector<ShearPoint>& points,
                                         const OlssonTeitelOptions& options);

}  // namespace jamflow::analysis
