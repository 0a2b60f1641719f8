// Granular rheology in the hard-sphere (P -> 0) and large-N limits
// (paper Secs. III–IV, SPEC §5):
//   phi = phi_J - C_phi J^b_phi, mu = mu_J + C_mu J^b_mu   (phi_visco_no, mu_visco_no)
//   O(N) = O_inf + A_O N^-alpha_O                         (O_finite, Table 2)
//   xi ~ J^-nu, nu = b / (alpha_O d)                      (nu)
//   eta/eta_0 = mu_J [C_phi/(phi_J-phi)]^(1/b_phi)
//             + C_mu [C_phi/(phi_J-phi)]^((1-b_mu)/b_phi) (eta)
#pragma once

#include <cstdint>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "analysis/collapse.hpp"
#include "analysis/data.hpp"
#include "analysis/error_model.hpp"
#include "analysis/fit.hpp"

namespace jamflow::analysis {

// --- the hard-sphere envelope (Fig. 4 arrows) --------------------------------
//
// For one N, each point (P, J) is compared with the nearest lower and the
// nearest higher pressure whose data bracket its J (linear interpolation in
// ln J of phi, mu and their errors). Two values agree if both pulls
// |Delta phi|/sigma and |Delta mu|/sigma are <= z (sigma: both errors in
// quadrature). Finite-pressure deviations grow with P (at fixed J) and grow
// as J decreases (at fixed P); hence, scanning each pressure from large to
// small J:
//  - disagreement with the lower pressure, confirmed by the next smaller-J
//    point (a real deviation persists as J decreases): this pressure has left
//    the P -> 0 limit; it and all its smaller-J points are out. An isolated
//    disagreement (the next point agrees again) is a fluctuation: only that
//    point is out;
//  - agreement with the lower pressure: in the envelope;
//  - no lower pressure at this J, agreement with the higher one: in the
//    envelope (two pressures that agree are both in the limit, the lower one
//    even more so);
//  - otherwise untestable: out, unless it lies at larger J than an accepted
//    point of the same pressure (deviations only shrink as J grows);
//  - guard: the last accepted point(s) just above a pressure's deviation
//    onset are dropped too (EnvelopeOptions::guard).
// A single pressure cannot be tested at all: every point is untestable.
enum class EnvelopeStatus {
  kAgrees,          // agrees with another pressure within z sigma
  kAboveAgreement,  // untestable, but at larger J than an agreeing point
  kDisagrees,       // disagrees with the lower pressure
  kBelowOnset,      // smaller J than a disagreement of the same pressure
  kUntestable,      // nothing to compare with (or only a deviating higher P)
  kGuard,           // agreed, but next to its pressure's deviation onset
};

bool in_envelope(EnvelopeStatus s);
const char* to_string(EnvelopeStatus s);

struct EnvelopeOptions {
  // Pull threshold (both phi and mu). Accepted points may still deviate by
  // up to ~z combined sigma, which biases the fits: on the synthetic tests
  // (with guard = 1), z = 2 keeps the bias of the fitted parameters below
  // ~0.4 sigma, z = 2.5-3 gives 0.6-0.9 sigma; smaller z discards more good
  // data.
  double z = 2.0;
  // Points of a pressure just above its deviation onset (larger J) dropped
  // as well: the deviation grows gradually, so the last agreeing points
  // already carry up to ~z sigma of it.
  int guard = 1;
};

struct EnvelopePoint {
  GranularPoint point;
  EnvelopeStatus status = EnvelopeStatus::kUntestable;
  // Pulls against the pressure it was judged by (0 if none).
  double pull_phi = 0.0, pull_mu = 0.0;
  double reference_pressure = 0.0;
};

// Points of one N (any order); returns them sorted by (P, J) with a status.
std::vector<EnvelopePoint> select_envelope(const std::vector<GranularPoint>& points,
                                           const EnvelopeOptions& options);

// --- per-size fits and the large-N extrapolation -----------------------------

struct HardSphereOptions {
  EnvelopeOptions envelope;
  bool scale_errors = true;  // multiply covariances by chi2/dof where it exceeds 1
  // Window for the effective viscosity exponent, in phi. Unset: the default
  // phi_J - 0.1 .. phi_J - 0.01, the range of typical experiments.
  std::optional<double> window_min, window_max;
  int dimension = 3;
  int min_sizes_for_extrapolation = 4;  // 3 parameters + 1 degree of freedom
  // The form systematic of each size's fits: refit with b_phi (b_mu) fixed at the seed's
  // Table 2 law at that N (error_model.hpp).
  bool form_systematic = true;
  // An extrapolation is resolved (its O_inf used as the N -> infinity value) when it is a
  // power-law fit whose amplitude differs from 0 by more than this many sigma.
  double resolved_amplitude_sigma = 2.0;
};

struct SizeFit {
  std::int64_t n = 0;
  std::vector<EnvelopePoint> points;
  FitResult phi;  // parameters phi_J, C_phi, b_phi
  FitResult mu;   // parameters mu_J, C_mu, b_mu
  // Statistical and systematic errors and the degeneracy flag of each fit (window: J).
  ErrorModel phi_errors, mu_errors;
  std::size_t points_used = 0;
  double j_min = 0.0, j_max = 0.0;  // envelope range
};

// The six parameters, in the order of Table 2.
const std::vector<std::string>& hard_sphere_parameters();

// What the sizes could resolve: were a parameter to follow a size law O_inf + A N^-alpha exactly
// (the seed's Table 2 column), at these sizes with these errors, the linearized (Fisher) errors
// of A and alpha of the fit, and the chance that the resolution rule (|A| > threshold sigma)
// is met, in the normal approximation. This tells a "not resolved" the data could not avoid
// from one that speaks against the law. alpha's error bounds that of nu = b / (alpha d) from
// below: sigma_nu / nu >= sigma_alpha / alpha.
struct SizeSensitivity {
  double a = 0.0, alpha = 0.0;  // the law's
  double sigma_a = std::numeric_limits<double>::quiet_NaN();
  double sigma_alpha = std::numeric_limits<double>::quiet_NaN();
  double z = std::numeric_limits<double>::quiet_NaN();      // |A| / sigma_A
  double power = std::numeric_limits<double>::quiet_NaN();  // P(|A_fit| > threshold sigma_A)
  // The factor on every size's error that gives the rule a chance of kTargetPower (the
  // Fisher errors scale with the data's; replicas as its inverse square).
  double error_scale = std::numeric_limits<double>::quiet_NaN();
  static constexpr double kTargetPower = 0.8;
};
// NaN fields when the Fisher matrix is singular (fewer than 3 distinct sizes, a zero A).
SizeSensitivity size_sensitivity(double a, double alpha, const std::vector<double>& sizes,
                                 const std::vector<double>& errors, double threshold_sigma);

// Large-N extrapolation of one parameter, O(N) = O_inf + A N^-alpha.
// With a handful of sizes the exponent is often not resolved: when the
// profile chi2(alpha) (O_inf and A fitted for each alpha) keeps decreasing as
// alpha -> infinity, the data show only a deviation of the smallest size and
// no power-law approach. Reporting a fitted alpha and A then would be
// fiction; we report O_inf with a profile-likelihood error (the set of O_inf
// with chi2 <= chi2_min + 1 over all alpha) and a lower bound on alpha.
// When instead chi2 keeps decreasing as alpha -> 0, the data show no
// convergence with N: if a constant describes them (chi2 p-value >= 0.05)
// there is no significant N-dependence and O_inf is their weighted mean
// (kConstant; biased if a trend hides in the noise), otherwise O_inf is not
// determined (kNotResolved). These are properties of the data, reported as
// warnings; kFailed is a numerical failure.
struct Extrapolation {
  enum class Status { kFit, kExponentUnbounded, kConstant, kNotResolved, kFailed };
  std::string parameter;
  Status status = Status::kFailed;
  std::optional<FitResult> fit;    // kFit: parameters inf, A, alpha
  Measured inf;                    // kFit and kExponentUnbounded
  double alpha_lower_bound = 0.0;  // kExponentUnbounded (chi2 <= chi2_min + 1)
  double chi2 = 0.0;               // at the optimum
  int dof = 0;
  std::string message;  // why not kFit
  // Resolved: a kFit whose amplitude A differs from 0 by more than
  // HardSphereOptions::resolved_amplitude_sigma, from at least min_sizes_for_extrapolation
  // sizes. Only a resolved O_inf is an N -> infinity value; `resolution` says why (not).
  bool resolved = false;
  std::string resolution;
  // The systematic error of O_inf: the largest of the sizes' systematic errors of O (J window
  // and fit form, ErrorModel). The same choices are made at every size, so their shifts are
  // taken as common to all sizes, which moves O_inf by as much and leaves A_O and alpha_O; NaN
  // where no size has one.
  double systematic = std::numeric_limits<double>::quiet_NaN();
  // At the seed's Table 2 law of this parameter, with the sizes' errors the fit used.
  std::optional<SizeSensitivity> sensitivity;
  // A constant (the weighted mean) fitted to the same sizes: its chi2 and dof. With chi2 above,
  // chi2_constant - chi2 is the likelihood-ratio statistic of the power law against no
  // N-dependence, which (unlike A_O's z) does not depend on the unit of N. NaN below 4 sizes.
  double chi2_constant = std::numeric_limits<double>::quiet_NaN();
  int dof_constant = 0;
  double chi2_power_law = std::numeric_limits<double>::quiet_NaN();  // its minimum over alpha
};

// Readings of an extrapolation that do not depend on the unit of N (the resolution rule's z of A
// does): the likelihood ratio of the power law against a constant, delta_chi2 = chi2_constant -
// chi2_power_law (unscaled errors), its p from chi2 with 2 dof (approximate: alpha is undefined
// under a constant), and for a kFit sigma_alpha / alpha (else NaN). nullopt below 4 sizes.
struct UnitFreeReading {
  double delta_chi2 = 0.0, p_constant = 0.0;
  double alpha_relative_error = std::numeric_limits<double>::quiet_NaN();
};
std::optional<UnitFreeReading> unit_free_reading(const Extrapolation& e);

// Exposed for tests: sizes, values and errors of one parameter.
Extrapolation extrapolate_in_size(const std::string& parameter, const std::vector<double>& sizes,
                                  const std::vector<double>& values,
                                  const std::vector<double>& errors, const FitOptions& options);

// Viscosity law (eta) from a parameter set, with its two power-law parts
// eta = a1 dphi^-e1 + a2 dphi^-e2 (dphi = phi_J - phi), their crossover and
// the effective exponent -d ln eta / d ln dphi over a window.
struct ViscosityLaw {
  std::string source;  // "N -> infinity" or "N = <largest>"
  // phi_J, b_phi, C_phi, mu_J, b_mu, C_mu and their covariance (6 x 6).
  std::vector<double> params;
  std::vector<double> covariance;
  Measured amplitude_1, exponent_1;  // mu_J C_phi^(1/b_phi), 1/b_phi
  Measured amplitude_2, exponent_2;  // C_mu C_phi^((1-b_mu)/b_phi), (1-b_mu)/b_phi
  Measured crossover_delta_phi;      // where both parts are equal
  double window_min = 0.0, window_max = 0.0;
  Measured effective_exponent;  // chord slope over the window
  Measured local_exponent_at_min, local_exponent_at_max;
  // Systematic errors of the exponents: the parameters' systematic errors (J window and fit
  // form, analysis/error_model.hpp) propagated as independent; 0 where the parameters carry none
  // (the N -> infinity extrapolations). The Measured errors above are statistical only.
  double exponent_1_systematic = 0.0, exponent_2_systematic = 0.0;
  double effective_exponent_systematic = 0.0;

  double eta(double phi) const;  // eta / eta_0
};

// `systematic`: each parameter's systematic error (Table 2 order; empty: none).
ViscosityLaw viscosity_law(std::vector<double> params, std::vector<double> covariance,
                           std::string source, double window_min, double window_max,
                           const std::vector<double>& systematic = {});

// A size whose envelope holds too few points for the fits (or whose fit failed):
// its envelope is still reported.
struct UnfittedSize {
  std::int64_t n = 0;
  std::vector<EnvelopePoint> points;
  std::string reason;
};

// The finite-size collapse of one parameter (paper Fig. 6, Eqs. scaling_phi,
// scaling_mu): with O(J, N) = O_inf + A N^-alpha -/+ C J^b, the envelope points
// of every fitted size collapse onto one curve in
//   x = J N^(alpha/b),  y = (O(J, N) - O_inf) / (A N^-alpha)
// (y -> 1 as x -> 0, for phi y = 1 + |C/A| x^b). The quality is Houdayer and
// Hartmann's S over the sizes as curves (analysis/collapse.hpp), with
// dy = O_err / |A N^-alpha|: S ~ 1 is a collapse within the errors.
struct FiniteSizeCollapse {
  std::string parameter;  // "phi" or "mu"
  double inf = 0.0, a = 0.0, alpha = 0.0, b = 0.0;
  std::vector<CollapsePoint> scaled;  // curve = index into HardSphereResult::sizes
  CollapseQuality quality;
  std::string unavailable;  // why not computed (then the rest is empty)
};

struct HardSphereResult {
  PointErrors point_errors;            // what the input points' errors are made of
  std::vector<SizeFit> sizes;          // ascending N
  std::vector<UnfittedSize> unfitted;  // ascending N
  FiniteSizeCollapse collapse_phi, collapse_mu;
  std::vector<Extrapolation> extrapolations;  // empty when skipped
  std::string extrapolation_skipped;          // reason, when skipped
  std::optional<Measured> nu_phi, nu_mu;
  // Their systematic errors, from that of b_inf (Extrapolation::systematic; a shift common to
  // every size leaves alpha_O as it is); NaN where b_inf has none.
  double nu_phi_systematic = std::numeric_limits<double>::quiet_NaN();
  double nu_mu_systematic = std::numeric_limits<double>::quiet_NaN();
  std::optional<ViscosityLaw> viscosity;
  std::vector<std::string> warnings;
  std::vector<std::string> failures;  // parts that could not be computed
  // Sizes that could not be fitted for lack of data (InsufficientDataError), not for a fit that
  // failed: when these are all of them, the data cannot support the analysis (exit status 2).
  std::size_t sizes_without_enough_data = 0;
};

// Per-N envelope and fits; throws (InsufficientDataError, FitError) when a
// size cannot be fitted, naming N.
SizeFit fit_size(std::int64_t n, const std::vector<GranularPoint>& points,
                 const HardSphereOptions& options);

// Every size is fitted where its envelope allows; a size that cannot be fitted
// goes to `unfitted` and to `failures` (the rest is still computed).
HardSphereResult analyze_hard_sphere(const std::vector<GranularPoint>& points,
                                     const HardSphereOptions& options);

// Group points by N (ascending).
std::map<std::int64_t, std::vector<GranularPoint>> group_by_size(
    const std::vector<GranularPoint>& points);

}  // namespace jamflow::analysis
