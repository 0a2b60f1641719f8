// Soft granular rheology (paper Sec. V A, SPEC §5):
//   phi(P,J) = phi_J(P) - C_phi J^b_phi,  mu(P,J) = mu_J(P) + C_mu J^b_mu  (phi_scale, mu_scale)
//   phi_J(P) = phi_J(0) + c_phi P^x,      mu_J(P) = mu_J(0) - c_mu P^y     (phi_P, mu_P)
// and the yield stress it implies (label `yield`):
//   sigma_Y = [(phi - phi_J(0))/c_phi]^(1/x) [mu_J(0) - c_mu ((phi - phi_J(0))/c_phi)^(y/x)]
//           = a1 dphi^(1/x) - a2 dphi^((1+y)/x),  dphi = phi - phi_J(0) > 0.
// Besides the paper's two-stage route (collapse each pressure, then fit phi_J(P), mu_J(P)),
// the joint fit takes the whole law at once over every pressure and J (SoftLaw below).
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "analysis/data.hpp"
#include "analysis/fit.hpp"
#include "analysis/hard_sphere.hpp"
#include "analysis/seed.hpp"

namespace jamflow::analysis {

// The P -> 0 exponents and prefactors the collapse uses, with their
// covariances (2 x 2 each: (C_phi, b_phi) and (C_mu, b_mu)).
struct HardSphereShape {
  double c_phi = 0.0, b_phi = 0.0, c_mu = 0.0, b_mu = 0.0;
  std::vector<double> cov_phi = {0, 0, 0, 0};
  std::vector<double> cov_mu = {0, 0, 0, 0};
  std::string source;  // "hard-sphere fit (N=...)" or "--hs-params"
};

// The soft granular rheology as one law of (P, J), ten parameters:
//   phi(P,J) = phi_J0 + c_phi P^x - C_phi J^b_phi,  mu(P,J) = mu_J0 - c_mu P^y + C_mu J^b_mu.
struct SoftLaw {
  // Defaults, where a fit starts: the paper's values (c_phi and c_mu, which it does not give,
  // 0.3).
  double phi_j0 = seed::table2("phi_J").inf, c_phi = 0.3, x = seed::kX;
  double big_c_phi = seed::table2("C_phi").inf, b_phi = seed::table2("b_phi").inf;
  double mu_j0 = seed::table2("mu_J").inf, c_mu = 0.3, y = seed::kY;
  double big_c_mu = seed::table2("C_mu").inf, b_mu = seed::table2("b_mu").inf;

  static const std::array<const char*, 10>& names();  // phi_J0, c_phi, x, C_phi, b_phi, mu_J0, ...
  std::array<double, 10> values() const;
  static SoftLaw from(const std::array<double, 10>& v);

  double phi(double p, double j) const;
  double mu(double p, double j) const;
  // d phi / d ln P at fixed gdot (J = gdot/P): c_phi x P^x + C_phi b_phi J^b_phi > 0, so the
  // pressure at an imposed (phi, gdot) is unique.
  double dphi_dlnp(double p, double gdot) const;
  // The pressure of a constant-volume state (phi, gdot > 0): the root of phi(P, gdot/P) = phi.
  // NaN if it lies outside 1e-14 < P < 1e3.
  double pressure_at(double phi, double gdot) const;
  // sigma_xy = mu(P, gdot/P) P at that pressure (NaN if none, or if mu <= 0 there).
  double sigma_at(double phi, double gdot) const;
  // The yield stress (gdot -> 0, label `yield`): 0 at and below phi_J0.
  double sigma_yield(double phi) const;
};

// Options of the joint fit. Errors: a parametric bootstrap. Each resample draws every phi and
// mu from a Gaussian about the fitted law with the data error times sqrt(max(1, chi2/dof)) of
// that fit (so a law that misses the data by more than their errors does not get error bars
// from the errors alone) and refits from the optimum; a parameter's error is the standard
// deviation over the resamples. Chosen over the curvature of chi2 because x and y enter
// through P^x and P^y over two or three decades of P: the chi2 surface is far from quadratic
// along the valley that trades y against mu_J(0) and c_mu.
struct JointSoftOptions {
  int bootstrap = 200;  // resamples; 0: no bootstrap (the curvature errors only)
  std::uint64_t seed = 20150112;
  double y_target = 0.05;  // the error on y the report asks for; a larger one is explained
};

struct JointSoftFit {
  std::int64_t n = 0;
  std::size_t points = 0;
  std::vector<double> pressures;    // distinct imposed pressures, ascending
  FitResult phi_fit;                // phi_J0, c_phi, x, C_phi, b_phi (curvature errors)
  FitResult mu_fit;                 // mu_J0, c_mu, y, C_mu, b_mu
  SoftLaw law;                      // the optimum
  std::array<Measured, 10> params;  // optimum, bootstrap error (curvature if bootstrap = 0)
  Measured alpha;                   // 1/x, the yield-stress exponent
  std::vector<std::array<double, 10>> samples;  // the bootstrap resamples' optima
  int bootstrap_requested = 0;
  double noise_scale_phi = 1.0, noise_scale_mu = 1.0;  // sqrt(max(1, chi2/dof))
  // Why x or y is not resolved to options.y_target (empty when it is).
  std::vector<std::string> resolution_notes;
  // Systematics (error_model.hpp), from refits without bootstrap on reduced data: the points
  // at the largest or the smallest P dropped (pressure window), and those at the largest or the
  // smallest J (J window). Each refit's ten parameters under its label ("without P = 0.01",
  // ...); per parameter the largest shift of each window (NaN: no refit could be done).
  struct Refit {
    std::string label;
    std::array<double, 10> params{};
  };
  std::vector<Refit> window_refits;
  std::array<double, 10> pressure_window{}, j_window{};
  std::vector<std::string> window_notes;  // refits that could not be done, and why
  // Fit form: the J-shape (C_phi, b_phi, C_mu, b_mu) fixed at the paper's Table 2 law at this N
  // and (phi_J0, c_phi, x), (mu_J0, c_mu, y) refitted; per parameter the shift from the free
  // fit (NaN for the fixed four, and where the refit could not be done).
  std::array<double, 10> form{};
  std::array<double, 10> form_refit{};  // the refit's ten values (the fixed four included)
  std::vector<std::string> form_notes;

  // The local exponents over successive pressure windows (three adjacent pressures each):
  // phi + C_phi J^b_phi - phi_J0 = c P^x (and mu_J0 + C_mu J^b_mu - mu = c P^y) fitted in each
  // window with phi_J0 (mu_J0) and the J-shape held at the joint optimum. `offset_shift`: the
  // largest change of the local exponent when phi_J0 (mu_J0) moves by its statistical error,
  // the part of its error that holding the offset hides.
  struct LocalExponent {
    double p_min = 0.0, p_max = 0.0;
    std::size_t points = 0;
    Measured exponent;  // statistical (scaled by sqrt(chi2/dof) when above 1)
    double offset_shift = 0.0;
    double total_error() const;  // both in quadrature
  };
  std::vector<LocalExponent> local_x, local_y;  // ascending pressure
  std::vector<std::string> local_notes;         // windows that could not be fitted, and why

  // Bootstrap standard deviation of any function of the law (0 without resamples).
  double spread(const std::function<double(const SoftLaw&)>& f) const;
};

// The joint fit of one N's points (at least 3 pressures and 8 points).
// `start` skips the grid search for the starting point (used by resampling callers).
JointSoftFit fit_soft_joint(const std::vector<GranularPoint>& points,
                            const JointSoftOptions& options,
                            const std::optional<SoftLaw>& start = std::nullopt);

// Fills f.window_refits, f.pressure_window and f.j_window (refits of `points` from f.law).
void soft_window_systematics(JointSoftFit& f, const std::vector<GranularPoint>& points);

// Fills f.form, f.form_refit and f.form_notes: the refit with the J-shape fixed at the paper's
// Table 2 law at N = f.n.
void soft_form_systematics(JointSoftFit& f, const std::vector<GranularPoint>& points);

// Fills f.local_x, f.local_y and f.local_notes (needs f.law and f.params).
void soft_local_exponents(JointSoftFit& f, const std::vector<GranularPoint>& points);

// The drift of a local exponent between the lowest and the highest pressure window, and what
// the numbers support saying about it.
struct ExponentDrift {
  bool defined = false;               // at least two windows
  double low = 0.0, low_err = 0.0;    // the lowest-pressure window (total error)
  double high = 0.0, high_err = 0.0;  // the highest-pressure window
  double sigma = 0.0;                 // (low - high) / both errors
  double from_one_sigma = 0.0;        // (low - 1) / low_err
  bool resolved = false;              // |sigma| > 2
};
// Windows whose error is not finite are left out.
ExponentDrift exponent_drift(const std::vector<JointSoftFit::LocalExponent>& local);

// Why x or y is not resolved to `target` given the fit's errors (empty when both are): the
// notes fit_soft_joint attaches, for callers that replace the errors afterwards.
std::vector<std::string> explain_resolution(const JointSoftFit& f,
                                            const std::vector<GranularPoint>& points,
                                            double target);

// Constant-volume points above phi_J0 against the joint law: the measured stress at each
// (phi, gdot), the law's stress there and its yield stress sigma_Y(phi), with bootstrap errors.
struct YieldPoint {
  double phi = 0.0, gdot = 0.0;
  Measured sigma;        // measured sigma_xy
  Measured sigma_law;    // the law at (phi, gdot)
  Measured sigma_yield;  // the law's sigma_Y(phi)
  double pull = 0.0;     // (sigma - sigma_law) / both errors
};
struct YieldComparison {
  std::vector<YieldPoint> points;  // phi > phi_J0 only, ascending phi then gdot
  std::size_t below = 0;           // constant-volume points at or below phi_J0 (not compared)
  double mean_square_pull = 0.0;
};
YieldComparison compare_yield(const JointSoftFit& fit, const std::vector<ShearPoint>& cv);

struct SoftOptions {
  HardSphereOptions hard_sphere;  // envelope and fit options for the shape
  // Fixed shape for every N instead of the per-N hard-sphere fit.
  std::optional<HardSphereShape> fixed_shape;
  bool scale_errors = true;  // multiply covariances by chi2/dof where it exceeds 1
  JointSoftOptions joint;
  // The per-pressure collapse needs 4 pressures and the hard-sphere envelope; when it cannot be
  // done, true throws (the library default), false keeps the joint fit and says why.
  bool require_collapse = true;
  // Constant-volume points (any phi) to compare with the joint law's yield stress.
  std::vector<ShearPoint> yield_data;
};

// phi_J(P), mu_J(P) that best collapse one pressure's data onto the P -> 0
// shape: the inverse-variance weighted means of phi + C_phi J^b_phi and of
// mu - C_mu J^b_mu. The error combines the statistical part with the
// propagated shape uncertainty; the latter is common to all pressures and
// enters the fits of phi_J(P) and mu_J(P) as correlations.
struct PressureCollapse {
  double pressure = 0.0;
  std::size_t points = 0;
  Measured phi_j, mu_j;  // total error (stat and shape)
  double phi_j_stat = 0.0, mu_j_stat = 0.0;
  double chi2_phi = 0.0, chi2_mu = 0.0;              // scatter about the collapse, dof = points - 1
  double grad_phi[2] = {0, 0}, grad_mu[2] = {0, 0};  // d/d(C, b)
};

// The yield-stress law with its two power laws.
struct YieldLaw {
  Measured amplitude_1, exponent_1;  // mu_J(0) c_phi^(-1/x), 1/x
  Measured amplitude_2, exponent_2;  // c_mu c_phi^(-(1+y)/x), (1+y)/x (subtracted)
  std::vector<double> params;        // phi_J0, c_phi, x, mu_J0, c_mu, y
  double sigma_y(double phi) const;  // 0 at and below phi_J(0)
};

struct SoftSize {
  std::int64_t n = 0;
  HardSphereShape shape;
  std::vector<GranularPoint> points;
  std::vector<PressureCollapse> pressures;  // ascending P
  FitResult phi_fit;                        // phi_J0, c_phi, x
  FitResult mu_fit;                         // mu_J0, c_mu, y
  YieldLaw yield;
  std::string collapse_skipped;       // why the per-pressure collapse is missing
  std::optional<JointSoftFit> joint;  // the joint fit over every pressure and J
  std::string joint_skipped;
  std::optional<YieldComparison> yield_data;
};

struct SoftResult {
  PointErrors point_errors;  // what the input points' errors are made of
  std::vector<SoftSize> sizes;
  std::vector<std::string> warnings;
};

std::vector<PressureCollapse> collapse_pressures(const std::vector<GranularPoint>& points,
                                                 const HardSphereShape& shape);

// Fits phi_J(P) and mu_J(P) with their full covariance (needs >= 4 pressures).
void fit_pressure_dependence(SoftSize& size, const SoftOptions& options);

YieldLaw yield_law(const FitResult& phi_fit, const FitResult& mu_fit);

SoftResult analyze_soft(const std::vector<GranularPoint>& points, const SoftOptions& options);

}  // namespace jamflow::analysis
