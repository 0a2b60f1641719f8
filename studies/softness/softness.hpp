// Potential-exponent optimization (studies/softness): the seed's alpha_r study. Presets and
// the cost model, exposed for the tests.
#pragma once
#include <string>
#include <vector>

#include "studies/diagnostics.hpp"
#include "studies/study.hpp"

namespace jamflow::studies {

struct SoftnessPreset {
  std::string name;
  std::int64_t n = 150;
  std::vector<double> alphas;
  // Typical overlaps delta; the pressure grid of alpha_r is P = delta^(alpha_r - 1), since the
  // contact force is delta^(alpha_r - 1) (SPEC §1): equal delta = equal distance from the
  // hard-sphere limit. The smallest delta is the P -> 0 reference.
  std::vector<double> deltas;
  std::vector<double> targets_j;  // viscous numbers J = gdot / P
  // Phase A (largest stable and accurate dt): an Euler scan at the largest and the smallest
  // delta, J = targets_j.front(), each run t_scan long after a preparation of t_prep.
  std::vector<double> scan_dts;
  // Preparation from a random state: max(t_prep, strain_prep / gdot) (the piston needs a time
  // ~ V xi_V / P to find the density, and the flow a strain of order 0.1).
  double t_prep = 300.0, strain_prep = 0.05, t_scan = 500.0;
  double mu_tolerance = 0.01, phi_tolerance = 1e-3;  // "accurate" (plus 2x paired floor)
  // Phase B (pressure scan) durations: t_eq = max(t_min, strain_eq / gdot), same for t_av.
  double strain_eq = 0.1, strain_av = 0.5, t_min = 1000.0;
  // Particle-steps (N x force evaluations) allowed per run (0: none); over it a run is
  // "incomplete". 3.75e8 is about 15 s of one core (40 ns each).
  double budget_particle_steps = 0.0;
};

SoftnessPreset softness_preset(const std::string& name);  // quick | standard | paper

// Particle-steps per particle to shear to strain 1 (t = 1 / gdot, gdot = J P) with step dt.
double steps_per_particle(double j, double pressure, double dt);

int run_softness(const StudyOptions& options);
int run_softness_preset(const SoftnessPreset& preset, const StudyOptions& options);

}  // namespace jamflow::studies
