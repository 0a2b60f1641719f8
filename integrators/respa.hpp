// RESPA: a Kolb–Dünweg-style multiple-time-step operator splitting of the overdamped
// dynamics (SPEC §2; Kolb & Dünweg, J. Chem. Phys. 111, 4453 (1999); Tuckerman, Berne,
// Martyna, J. Chem. Phys. 97, 1990 (1992)), in a symmetric (Strang) composition.
//
// The state splits into the particles (scaled coordinates s) and the collective degrees of
// freedom of the cell h(strain, V). The right-hand side is the sum of two vector fields whose
// flows are advanced separately:
//
//   Collective flow C (s fixed, so particles follow the cell affinely):
//     d(strain)/dt = gdot,    dV/dt = (P_hat(s, h) - P) / xi_V     (0 at constant volume)
//   Particle flow S (cell h fixed: the contact forces, the stiff part near contact):
//     ds/dt = h^-1 F(h s) / xi_s
//
// Since r = h s, C + S gives dr/dt = F / xi_s + gdot y e_x + (V'/3V) r: the full dynamics.
// One step of size dt is, with n = n_inner,
//
//   inner = "particles":  Psi(dt) = C(dt/2) o [S(dt/n)]^n o C(dt/2)
//   inner = "piston":     Psi(dt) = S(dt/2) o [C(dt/n)]^n o S(dt/2)
//
// (the rightmost factor acts first). "particles" is the Kolb–Dünweg choice near jamming, where
// the piston is slow; "piston" is for high pressure, small N or small xi_V, where the piston
// rate K / (V xi_V) is the stiff one. At constant volume C is only the affine shear advection
// (exact, no force evaluation), so RESPA is Strang splitting of the shear from the contacts.
//
// Each sub-flow is approximated by one step of a one-step scheme chosen per level (the fields
// and schemes are StateEquation's, integrators/motion.hpp):
//   euler:  y <- y + h f(y)                                    (order 1, 1 evaluation)
//   heun:   y* = y + h f(y),  y <- y + h/2 (f(y) + f(y*))        (order 2, 2 evaluations)
// A sub-flow that needs no evaluation (C at constant volume) is exact with either scheme.
//
// Order. The Strang composition of exact flows is second order; a sub-flow integrated to
// order p contributes a global error O(dt^p). So the order is min(2, p_inner, p_outer) with
// p = 1 (euler), 2 (heun), infinity (exact level). order() is the order for the worst case
// (with a piston), order(ensemble) the exact value for a given ensemble:
//
//   inner_scheme  outer_scheme | piston          | constant volume, inner = particles / piston
//   euler         euler        | 1               | 1 / 1
//   heun          heun         | 2               | 2 / 2
//   heun          euler        | 1               | 2 / 1
//   euler         heun         | 1               | 1 / 2
//
// Measured caveat (N = 1000, P = 1e-5, studies/ensemble/README.md): in the overdamped model
// P_hat fluctuates on the contact time scale, so the piston is not slow compared with the
// contacts. With Euler sub-steps the states at the ends of steps (right after a piston
// half-step) carry an O(dt) bias: <P_hat> sampled there exceeds P by 6% at J = 10 and 1% at
// J = 1 for dt = 1 (3% at dt = 0.5), while Euler's piston obeys <P_hat> - P = xi_V dV / T
// exactly at its step states. Heun on both levels removes the bias (10 evaluations per step
// at n_inner = 3, 3x Euler at dt = 0.3 per unit time).
//
// Cost per step: n (euler) or 2n (heun) evaluations on the inner level, plus 2 (euler) or 4
// (heun) on the outer level; a collective level at constant volume costs none. Remaps and
// memory reorders are applied between steps only (Model::prepare_step), as in Euler.
//
// Scene keys ([integrator] kind = "respa"):
//   dt            outer step (> 0, required)
//   n_inner       inner sub-steps per outer step (integer in [1, 100000], default 4)
//   inner         "particles" | "piston": which level is sub-stepped (default "particles")
//   inner_scheme  "euler" | "heun" (default "euler")
//   outer_scheme  "euler" | "heun" (default: the inner scheme)
#pragma once
#include <string>
#include <vector>

#include "integrators/integrator.hpp"
#include "integrators/motion.hpp"

namespace jamflow {

struct RespaOptions {
  enum class Level { kParticles, kPiston };
  using Scheme = StepScheme;
  double dt = 0.0;
  int n_inner = 4;
  Level inner = Level::kParticles;
  Scheme inner_scheme = Scheme::kEuler;
  Scheme outer_scheme = Scheme::kEuler;
};

class Respa final : public Integrator {
 public:
  explicit Respa(const RespaOptions& options);
  std::string name() const override { return "respa"; }
  // Order with a piston (the worst case); see the table above.
  int order() const override;
  // Exact order for this ensemble (a collective level without a piston is exact).
  int order(const Ensemble& ensemble) const override;
  // Force passes per step over dt, from "Cost per step" above.
  double force_passes_per_time(const Ensemble& ensemble) const override;
  void advance(Model& model, const Ensemble& ensemble, double t_end) override;
  std::vector<std::pair<std::string, double>> statistics() const override;
  void restore_statistics(const std::vector<std::pair<std::string, double>>& stats) override {
    steps_ = static_cast<long long>(statistic(stats, "steps"));
    inner_steps_ = static_cast<long long>(statistic(stats, "inner_steps"));
  }
  double nominal_dt() const override { return options_.dt; }
  const RespaOptions& options() const { return options_; }

 private:
  using Scheme = RespaOptions::Scheme;
  void step(Model& model, const StateEquation& motion, double h);

  RespaOptions options_;
  std::vector<double> force0_;  // Heun: forces at the start of a particle sub-step
  long long steps_ = 0;
  long long inner_steps_ = 0;
};

}  // namespace jamflow
