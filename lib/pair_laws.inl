// The pair laws of lib/potential.hpp, written once as templates on their arithmetic: `m`
// supplies splat(c), sqrt(x) and pow(x, p), and V (double, or a SIMD vector of pairs) has
// + - * /. For r^2 < a_ij^2, eval(m, r2, a_ij, f_over_r) returns U and sets f/r, where
// f = -dU/dr > 0 (repulsion). A pair costs one square root and one division: 1 / (a r) gives
// both r / a = r^2 / (a r) and f / r.
//
// No include guard, on purpose: lib/potential.hpp includes this into namespace jamflow for the
// scalar kernels, and lib/kernels/simd.cpp includes it again into each Highway target's
// namespace, where the compiler builds it for that instruction set. Include nothing here.

// alpha_r = 2: the harmonic case, U = delta^2 / 2 with delta = 1 - r / a, f / r = delta / (a r).
struct HarmonicLaw {
  template <class Math, class V>
  static V eval(const Math& m, V r2, V a_ij, V& f_over_r) {
    const V inv_ar = m.splat(1.0) / (a_ij * m.sqrt(r2));
    const V delta = m.splat(1.0) - r2 * inv_ar;
    f_over_r = delta * inv_ar;
    return m.splat(0.5) * delta * delta;
  }
};

// General exponent: U = delta^alpha / alpha, f / r = delta^(alpha - 1) / (a r).
struct PowerLaw {
  template <class Math, class V>
  static V eval(const Math& m, V r2, V a_ij, V& f_over_r, double alpha_r) {
    const V inv_ar = m.splat(1.0) / (a_ij * m.sqrt(r2));
    const V delta = m.splat(1.0) - r2 * inv_ar;
    const V dpow = m.pow(delta, alpha_r - 1.0);  // delta^(alpha - 1)
    f_over_r = dpow * inv_ar;
    return dpow * delta * m.splat(1.0 / alpha_r);
  }
};
