// Fits of single flow curves and of the viscosity divergence (`jamflow analyze flow-curve`):
//   sigma_xy = A gdot^n                        power law, on each curve
//   sigma_xy = sigma_y + K gdot^n              Herschel–Bulkley, on each curve
//   eta(phi) = eta_0 (phi_c - phi)^(-beta)     divergence, eta = sigma_xy / gdot, phi_c free:
//       constant volume: over the curves (phi) at one gdot; constant pressure: over the rows
//       of one imposed P (each row its measured phi, whose error is neglected).
// Weighted least squares (fit.hpp); errors from the covariance, multiplied by sqrt(chi2/dof)
// when chi2/dof > 1 (FitResult::errors_scaled says where). Each fit reports its parameters,
// errors, chi2/dof, the points used, the points admitted although their verdicts failed, and
// the rows it left out with why.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "analysis/data.hpp"
#include "analysis/error_model.hpp"
#include "analysis/fit.hpp"
#include "analysis/json.hpp"

namespace jamflow::analysis {

struct FlowCurveOptions {
  bool scale_errors = true;  // multiply covariances by chi2/dof where it exceeds 1
  // Rows of a jammed curve (a Herschel–Bulkley yield stress above zero by more than this many
  // sigma) are left out of the constant-volume divergence fits: eta = sigma_xy/gdot then
  // diverges as gdot -> 0 at every phi, not at phi_c.
  double yield_z = 3.0;
};

// One point left out of a fit, and why.
struct LeftOutRow {
  std::string source;  // "file:line" or the run file
  std::string why;
};

struct FlowFit {
  enum class Status { kFit, kSkipped, kFailed };
  Status status = Status::kSkipped;
  std::string reason;  // kSkipped: too few points; kFailed: what the fit reported
  std::string formula;
  FitResult fit;      // parameters, covariance (scaled), chi2, dof, errors_scaled
  ErrorModel errors;  // statistical errors and the degeneracy flag
  // Derived parameters reported beside the fitted ones (eta_0 from ln eta_0), with errors.
  std::vector<std::pair<std::string, Measured>> derived;
  std::size_t points_used = 0;
  std::vector<std::string> failed_included;  // sources of points whose verdicts failed
  std::vector<LeftOutRow> left_out;
};

// One flow curve sigma_xy(gdot): constant volume (N, phi) or constant pressure (N, P).
struct FlowCurve {
  std::string set;
  std::int64_t n = 0;
  bool constant_pressure = false;
  double state = 0.0;              // phi (constant volume) or P (constant pressure)
  std::vector<ShearPoint> points;  // ascending gdot
  FlowFit power_law, herschel_bulkley;
};

// eta(phi) over a group: constant volume at one gdot, or constant pressure at one P.
struct Divergence {
  std::string group;  // "N=1000,shear_rate=1e-05" or "N=1000,imposed_pressure=0.0001"
  std::int64_t n = 0;
  bool constant_pressure = false;
  std::vector<double> phi, eta, eta_err;  // the points used, ascending phi
  FlowFit fit;
};

struct FlowCurveResult {
  PointErrors point_errors;  // what the input points' errors are made of
  std::vector<FlowCurve> curves;
  std::vector<Divergence> divergences;
  std::vector<std::string> warnings;
  std::vector<std::string> failures;  // fits that did not converge (exit status 1)
};

// Fits every curve and every divergence group that has enough points (3 for the power law,
// 4 for Herschel–Bulkley and the divergence); the others are `kSkipped` with the reason.
// Throws InsufficientDataError (exit status 2) when not a single fit could be done, naming
// what each needed.
FlowCurveResult analyze_flow_curves(const std::vector<ShearPoint>& points,
                                    const FlowCurveOptions& options);

// The single fits, exposed for tests. Each throws InsufficientDataError with fewer points than
// parameters + 1 and FitError when the fit fails.
FitResult fit_flow_power_law(const std::vector<ShearPoint>& curve, const FitOptions& options);
FitResult fit_herschel_bulkley(const std::vector<ShearPoint>& curve, const FitOptions& options);
// Fitted in ln eta with d ln eta = eta_err / eta; parameters (ln_eta0, beta, phi_c).
FitResult fit_divergence(const std::vector<double>& phi, const std::vector<double>& eta,
                         const std::vector<double>& eta_err, const FitOptions& options);

// Outputs (the other analyses' are in report.hpp). `left_out` are the rows the reader left out
// for their verdicts; `include_failed` whether failed rows were admitted.
Json flow_curve_json(const FlowCurveResult& r, const std::vector<std::string>& inputs,
                     const std::vector<std::string>& left_out, bool include_failed);
std::string flow_curve_markdown(const FlowCurveResult& r, const std::vector<std::string>& inputs,
                                const std::vector<std::string>& left_out, bool include_failed);
Json flow_curve_plot_data(const FlowCurveResult& r);

}  // namespace jamflow::analysis
