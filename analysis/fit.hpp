// Weighted nonlinear least squares on top of GSL's gsl_multifit_nlinear
// (Levenberg–Marquardt trust region), with parameter covariances, plus the
// power-law-with-offset fit used everywhere in the paper:
//   phi = phi_J - C_phi J^b_phi, mu = mu_J + C_mu J^b_mu    (phi_visco_no, mu_visco_no)
//   O(N) = O_inf + A_O N^-alpha_O                          (O_finite)
//   phi_J(P) = phi_J(0) + c_phi P^x, mu_J(P) = mu_J(0) - c_mu P^y  (phi_P, mu_P)
//
// Errors: the covariance is (J^T W J)^-1 with W the inverse data covariance,
// multiplied by chi2/dof when that exceeds 1 (the data scatter more than their
// errors say; FitOptions::scale_errors_by_chi2, on by default), and the result
// records whether it was. Systematic errors: error_model.hpp.
#pragma once

#include <functional>
#include <span>
#include <string>
#include <vector>

namespace jamflow::analysis {

// A number with its 1-sigma error.
struct Measured {
  double value = 0.0;
  double error = 0.0;
};

// Model y = f(x; p). When grad is non-empty it receives df/dp_k.
using ModelFunction =
    std::function<double(double x, std::span<const double> p, std::span<double> grad)>;

struct FitData {
  std::vector<double> x, y;
  // Either one error per point (uncorrelated data)...
  std::vector<double> sigma;
  // ...or, if non-empty, the full n x n data covariance (row-major). Used when
  // the data share a common error, e.g. phi_J(P) values that all depend on the
  // same hard-sphere C_phi and b_phi.
  std::vector<double> covariance;

  std::size_t size() const { return x.size(); }
};

struct FitOptions {
  int max_iterations = 500;
  // Multiply the covariance by chi2/dof when chi2/dof > 1 (never shrink it).
  bool scale_errors_by_chi2 = true;
  // Names the fit in error messages, e.g. "phi = phi_J - C_phi J^b_phi (N=1000)".
  std::string label = "fit";
};

struct FitResult {
  std::vector<std::string> names;
  std::vector<double> params;
  std::vector<double> covariance;  // p x p, row-major
  double chi2 = 0.0;
  int dof = 0;
  int iterations = 0;
  bool errors_scaled = false;  // covariance multiplied by chi2/dof (> 1)

  std::size_t size() const { return params.size(); }
  std::size_t index(const std::string& name) const;  // throws std::out_of_range
  Measured operator[](const std::string& name) const;
  Measured at(std::size_t i) const;
  double cov(std::size_t i, std::size_t j) const { return covariance[i * params.size() + j]; }
  double reduced_chi2() const { return dof > 0 ? chi2 / dof : 0.0; }
};

// Minimises sum_i r_i^2 with r = L^-1 (f(x; p) - y), L the Cholesky factor of
// the data covariance (r_i = (f - y_i)/sigma_i without correlations).
// Throws InsufficientDataError when n < p + 1 (a fit with no residual degree of
// freedom cannot tell whether the model fits), FitError on non-finite data,
// no convergence or a parameter the data do not constrain.
FitResult fit_least_squares(const FitData& data, const ModelFunction& model,
                            std::vector<double> start, std::vector<std::string> names,
                            const FitOptions& options);

// y = a + sign * c * x^(exponent_sign * b), x > 0; parameters (a, c, b).
// For a fixed b the model is linear in (a, c), so the start is the minimum
// of the profile chi2(b) over a grid of b in [b_min, b_max]; the final fit
// then refines all three parameters (b may leave the grid range).
struct PowerLawForm {
  double sign = 1.0;
  double exponent_sign = 1.0;
  double b_min = 0.02, b_max = 2.0;
  std::string a_name = "a", c_name = "c", b_name = "b";
};

FitResult fit_power_law_offset(const FitData& data, const PowerLawForm& form,
                               const FitOptions& options);

double power_law_offset_value(const PowerLawForm& form, double x, double a, double c, double b);

// Linear error propagation g(p) with covariance cov (p x p row-major), using
// central differences with steps of 1e-4 sigma_k. Throws FitError if g is
// non-finite at p.
Measured propagate(const std::function<double(std::span<const double>)>& g,
                   std::span<const double> p, std::span<const double> cov, const std::string& what);

// Block-diagonal covariance of independent parameter groups.
std::vector<double> block_diagonal(const std::vector<std::vector<double>>& blocks,
                                   const std::vector<std::size_t>& sizes);

}  // namespace jamflow::analysis
