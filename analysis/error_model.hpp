// The error model every fit of the analyses reports (SPEC §5 fits; Table 2, x and y):
//  - a statistical error from the covariance, multiplied by sqrt(chi2/dof) when chi2/dof > 1
//    (the data scatter more than their errors say; fit.hpp does the scaling), with the flag and
//    chi2/dof beside it;
//  - systematic errors, carried separately:
//      window: refit without the points at the largest x, and without those at the smallest x
//              (x = J for the hard-sphere laws, P for the pressure laws); the systematic is the
//              larger of the two shifts of each parameter;
//      form:   for y = a +/- c x^b, refit with b fixed at a reference exponent (the seed's
//              Table 2 law at the same N); the shift of a and c;
//    their quadrature sum is the parameter's `systematic`;
//  - a degeneracy flag: a parameter outside its physical range (mu_J < 0, an exponent <= 0) or
//    not determined by the data (error >= |value|). A degenerate fit is reported, never compared
//    with a reference in sigma.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "analysis/fit.hpp"

namespace jamflow::analysis {

struct ParameterErrors {
  std::string name;
  double value = 0.0;
  double statistical = 0.0;  // sqrt(covariance), already scaled when chi2/dof > 1
  // NaN when not computable (a refit without enough points, or no reference exponent).
  double window = 0.0;
  double form = 0.0;
  double systematic() const;  // quadrature sum of the computable ones; NaN if none is
};

struct ErrorModel {
  double reduced_chi2 = 0.0;
  int dof = 0;
  bool errors_scaled = false;  // statistical errors multiplied by sqrt(chi2/dof)
  std::vector<ParameterErrors> parameters;
  std::vector<std::string> notes;  // refits that could not be done, and why
  bool degenerate = false;
  std::string degenerate_reason;

  const ParameterErrors& operator[](const std::string& name) const;  // throws std::out_of_range
};

// A physical range of a parameter (inclusive bounds; unset = unbounded).
struct ParameterBound {
  std::string name;
  std::optional<double> lower, upper;
};

// Why the fit is degenerate (empty if it is not): a parameter outside its bound, or an error
// at least as large as the value's magnitude (the data do not determine it).
std::string degeneracy(const FitResult& fit, const std::vector<ParameterBound>& bounds);

// The data without the points whose x equals (to 1e-9 relative) the largest (highest = true)
// or the smallest x; the covariance, if any, restricted accordingly.
FitData drop_extreme_x(const FitData& data, bool highest);

// The window systematic of each parameter of `base`: max over {drop highest x, drop lowest x}
// of |refit - base|; NaN where neither refit could be done (notes say why, labelled with
// x_name).
std::vector<double> window_shifts(const FitData& data, const FitResult& base,
                                  const std::function<FitResult(const FitData&)>& refit,
                                  const std::string& x_name, std::vector<std::string>& notes);

// y = a + sign c x^(exponent_sign b) with b fixed: the fit of (a, c) alone.
FitResult fit_power_law_fixed_exponent(const FitData& data, const PowerLawForm& form, double b,
                                       const FitOptions& options);

// The whole error model of a fit of y = a +/- c x^b (fit_power_law_offset): window systematic
// in x, form systematic against `reference_b` (none if unset), degeneracy against `bounds`.
ErrorModel power_law_error_model(const FitData& data, const PowerLawForm& form,
                                 const FitResult& base, const FitOptions& options,
                                 std::optional<double> reference_b,
                                 const std::vector<ParameterBound>& bounds,
                                 const std::string& x_name);

// Independent estimates x_k +- e_k of one quantity: their weighted mean, chi2/dof about it
// (n - 1 degrees of freedom) and sqrt(max(1, chi2/dof)), the factor by which the errors
// understate the scatter (the same rule as a fit's). Fewer than 2 finite estimates: NaN chi2,
// scale 1.
struct Scatter {
  double mean = 0.0;
  double reduced_chi2 = 0.0;
  int dof = 0;
  double error_scale = 1.0;
};
Scatter scatter_of(const std::vector<double>& x, const std::vector<double>& e);

// The statistical part only (and the degeneracy), for fits whose systematics are computed by
// their caller.
ErrorModel statistical_error_model(const FitResult& fit, const std::vector<ParameterBound>& bounds);

}  // namespace jamflow::analysis
