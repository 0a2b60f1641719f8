// Pair potential family U(r) = (eps / alpha_r) (1 - r / a_ij)^alpha_r for r < a_ij, 0 beyond
// (SPEC §1; the seed's Eq. `pot` is alpha_r = 2). Units: eps = a = 1.
//
// The laws themselves are in lib/pair_laws.inl, written once as templates on their arithmetic,
// so that the scalar kernels (reference, portable) and the simd kernel evaluate the same
// expression. The evaluators below are the small value types the kernels are templated on (no
// virtual call per pair). Contract: given r and a_ij with r < a_ij, return U and f/r where
// f = -dU/dr > 0 (repulsion), and the stiffness k = d^2U/dr^2 used by Hessian-vector products.
#pragma once
#include <cmath>

namespace jamflow {

#include "lib/pair_laws.inl"

struct PairValue {
  double energy;
  double f_over_r;
};

// The laws' arithmetic on doubles.
struct ScalarMath {
  static double splat(double c) { return c; }
  static double sqrt(double x) { return std::sqrt(x); }
  static double pow(double x, double p) { return std::pow(x, p); }
};

// alpha_r = 2: the harmonic case, no pow().
struct HarmonicPair {
  double alpha() const { return 2.0; }
  PairValue operator()(double r, double a_ij) const {
    PairValue pv{};
    pv.energy = HarmonicLaw::eval(ScalarMath{}, r * r, a_ij, pv.f_over_r);
    return pv;
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
    PairValue pv{};
    pv.energy = PowerLaw::eval(ScalarMath{}, r * r, a_ij, pv.f_over_r, alpha_r);
    return pv;
  }
  // d^2U/dr^2 = (alpha - 1) delta^(alpha - 2) / a^2
  double stiffness(double r, double a_ij) const {
    const double delta = 1.0 - r / a_ij;
    return (alpha_r - 1.0) * std::pow(delta, alpha_r - 2.0) / (a_ij * a_ij);
  }
};

// Calls f with the evaluator for an exponent: the harmonic one at alpha_r = 2, the general one
// otherwise. Every kernel picks its law through this.
template <class F>
decltype(auto) with_pair_law(double alpha_r, F&& f) {
  if (alpha_r == 2.0)
    return f(HarmonicPair{});
  return f(PowerPair{alpha_r});
}

// Range of alpha_r the toolkit supports (SPEC §1).
inline constexpr double kAlphaMin = 1.2;
inline constexpr double kAlphaMax = 3.0;

}  // namespace jamflow
