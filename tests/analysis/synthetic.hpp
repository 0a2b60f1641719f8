// Synthetic data generated from the paper's own formulas, for the analysis
// tests: Table 2 finite-size parameters, the soft granular rheology
// (x = 0.75, y = 0.56), and a known smooth two-branch Olsson–Teitel function.
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include "analysis/data.hpp"

namespace jamflow::analysis::testing {

// Table 2: O(N) = O_inf + A_O N^-alpha_O for the six parameters.
struct RheologyParams {
  double phi_j, b_phi, c_phi, mu_j, b_mu, c_mu;
};
RheologyParams table2_at(double n);
RheologyParams table2_infinite();

// Soft granular rheology prefactors (the paper gives only the exponents; the
// prefactors are ours, chosen so that phi_J(P) - phi_J(0) ~ 1e-2 at P = 1e-2).
struct SoftTruth {
  double c_phi = 0.3, x = 0.75, c_mu = 0.3, y = 0.56;
};

// Constant-pressure data: for each N and P, shear rates log-spaced in
// [gdot_min, gdot_max]; phi = phi_J(N) + c_phi P^x - C_phi J^b_phi and
// mu = mu_J(N) - c_mu P^y + C_mu J^b_mu, with Gaussian noise of standard
// deviation rel_noise * C_phi J^b_phi (resp. C_mu J^b_mu): a fixed relative
// precision on the distance to the J -> 0 limit, as the constant-width error
// bars of the log-log Fig. 4. Finite-pressure data therefore deviate
// significantly below a P-dependent crossover J, as in the paper.
struct GranularSpec {
  std::vector<std::int64_t> sizes = {1000};
  std::vector<double> pressures = {1e-7, 1e-6, 1e-5, 1e-4};
  double gdot_min = 1e-13, gdot_max = 1e-9;
  int points_per_decade = 3;
  double rel_noise = 0.02;
  bool soft = true;  // false: pure hard-sphere data at every P
  // true: only phi_J and mu_J depend on N (b and C at their N -> infinity
  // values), the paper's finite-size scaling form (scalingphi, scalingmu)
  bool size_independent_shape = false;
  SoftTruth soft_truth;
  std::uint64_t seed = 1;
};

std::vector<GranularPoint> make_granular(const GranularSpec& spec);

// Known two-branch scaling function with the Olsson–Teitel asymptotics, q =
// alpha/(alpha+beta): G+(x) = 1 + x^q (yield stress), G-(x) = x/(1 + x^(1-q))
// (Newtonian at small x); both ~ x^q at large x.
double g_plus(double x, double q);
double g_minus(double x, double q);

struct TwoBranchSpec {
  double phi_j = 0.6474, alpha = 1.33, beta = 2.55;
  std::vector<double> phis = {0.600, 0.615, 0.625, 0.632, 0.637, 0.641, 0.644,
                              0.651, 0.655, 0.660, 0.670, 0.685, 0.700};
  double gdot_min = 1e-8, gdot_max = 1e-3;
  int points_per_decade = 3;
  double rel_noise = 0.02;  // sigma_err = rel_noise * sigma
  std::int64_t n = 10000;
  std::uint64_t seed = 7;
};

std::vector<ShearPoint> make_two_branch(const TwoBranchSpec& spec);

// Constant-volume flow curves predicted by the soft granular rheology with
// Table 2's N -> infinity parameters: P solves
// phi = phi_J(0) + c_phi P^x - C_phi (gdot/P)^b_phi, then
// sigma = P [mu_J(0) - c_mu P^y + C_mu J^b_mu]. Not of the two-branch form. The measured
// pressure carries the same relative noise as sigma (drawn from a second stream).
std::vector<ShearPoint> make_soft_flow_curves(const TwoBranchSpec& spec, const SoftTruth& soft);

}  // namespace jamflow::analysis::testing
