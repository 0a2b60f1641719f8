// Soft granular rheology (paper Sec. V A, SPEC §5):
//   phi(P,J) = phi_J(P) - C_phi J^b_phi,  mu(P,J) = mu_J(P) + C_mu J^b_mu  (phi_scale, mu_scale)
//   phi_J(P) = phi_J(0) + c_phi P^x,      mu_J(P) = mu_J(0) - c_mu P^y     (phi_P, mu_P)
// and the yield stress it implies (label `yield`):
//   sigma_Y = [(phi - phi_J(0))/c_phi]^(1/x) [mu_J(0) - c_mu ((phi - phi_J(0))/c_phi)^(y/x)]
//           = a1 dphi^(1/x) - a2 dphi^((1+y)/x),  dphi = phi - phi_J(0) > 0.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "analysis/data.hpp"
#include "analysis/fit.hpp"
#include "analysis/hard_sphere.hpp"

namespace jamflow::analysis {

// The P -> 0 exponents and prefactors the collapse uses, with their
// covariances (2 x 2 each: (C_phi, b_phi) and (C_mu, b_mu)).
struct HardSphereShape {
  double c_phi = 0.0, b_phi = 0.0, c_mu = 0.0, b_mu = 0.0;
  std::vector<double> cov_phi = {0, 0, 0, 0};
  std::vector<double> cov_mu = {0, 0, 0, 0};
  std::string source;  // "hard-sphere fit (N=...)" or "--hs-params"
};

struct SoftOptions {
  HardSphereOptions hard_sphere;  // envelope and fit options for the shape
  // Fixed shape for every N instead of the per-N hard-sphere fit.
  std::optional<HardSphereShape> fixed_shape;
  bool scale_errors = false;
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
};

struct SoftResult {
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
