// Pair potential family U(r) = (eps / alpha_r) (1 - r / a_ij)^alpha_r for r < a_ij, 0 beyond
// (SPEC §1; the seed's Eq. `pot` is alpha_r = 2). Units: eps = a = 1.
//
// Evaluators are small value types templated into the pair loop (no virtual call per pair).
// Contract: given r and a_ij with r < a_ij, return U and f/r where f = -dU/dr > 0 (repulsion),
// and the stiffness k = d^2U/dr^2 used by Hessian-vector products.
#pragma once
#include <cmath>

namespace jamflow {

struct PairValue {
  double energy;
  double f_over_r;
};

// alpha_r = 2: the harmonic case, no pow().
struct HarmonicPair {
  double alpha() const { return 2.0; }
  PairValue operator()(double r, double a_ij) const {
    const double inv_a = 1.0 / a_ij;
    const double delta = 1.0 - r * inv_a;
    return {0.5 * delta * delta, delta * inv_a / r};
  }
  // d^2U/dr^2 = 1 / a^2
  double stiffness(double /*r*/, double a_ij) const { return 1.0 / (a_ij * a_ij); }
};

// General exponent, alpha_r in [1.2, 3]. For alpha_r < 2 the force is continuous but its
// derivative diverges at contact: a stiff case.
struct PowerPair {
  double alpha_r;
  double alpha() const { return alpha_r; }
  PairValue operator()(double r, double a_ij) const {
    const double inv_a = 1.0 / a_ij;
    const double delta = 1.0 - r * inv_a;
    const double dpow = std::pow(delta, alpha_r - 1.0);  // delta^(alpha-1)
    return {dpow * delta / alpha_r, dpow * inv_a / r};
  }
  // d^2U/dr^2 = (alpha - 1) delta^(alpha - 2) / a^2
  double stiffness(double r, double a_ij) const {
    const double delta = 1.0 - r / a_ij;
    return (alpha_r - 1.0) * std::pow(delta, alpha_r - 2.0) / (a_ij * a_ij);
  }
};

// Range of alpha_r the toolkit supports (SPEC §1).
inline constexpr double kAlphaMin = 1.2;
inline constexpr double kAlphaMax = 3.0;

}  // namespace jamflow
