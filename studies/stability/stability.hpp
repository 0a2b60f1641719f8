// Stability study (studies/stability): presets and cases, exposed for the tests.
#pragma once
#include <string>
#include <vector>

#include "studies/diagnostics.hpp"
#include "studies/study.hpp"

namespace jamflow::studies {

// Sizes, durations and scan lists of a preset (the physics and the analysis never change).
struct StabilityPreset {
  std::string name;
  std::int64_t n = 200;                           // N of every case but the N = 100 ones
  double strain_prep = 0.05, t_prep_min = 300.0;  // preparation from a random state
  double strain_eq = 0.01, t_eq_min = 100.0;      // per run, after switching integrator
  double strain_av = 0.1, t_av_min = 600.0;       // averaging window
  std::vector<double> dts;                        // Euler (and the prep uses min(0.05, dts[0]))
  std::vector<double> stiff_dts;                  // extra small steps for alpha_r < 2
  std::vector<double> lane_dts;                   // Euler steps of the N = 100 cases
  std::vector<RespaSplitting> respa;
  std::vector<double> respa_dts;
  std::vector<double> cvode_tols;
  double lane_pressure = 1e-4, lane_gdot = 1e-4, lane_strain_av = 0.0;
  // RESPA with the particles on the inner level (4 Euler sub-steps) against N: at each size and
  // pressure (J = respa_size_j), only the steps respa_size_dts. The piston stays on the outer
  // level, and its rate K / (V xi_V) grows as the box shrinks.
  std::vector<std::int64_t> respa_sizes;
  std::vector<double> respa_size_pressures;
  std::vector<double> respa_size_dts = {0.5, 1.0};
  double respa_size_j = 1.0;
  // Particle-steps (N x force evaluations) allowed per run (0: none); over it: "incomplete".
  // 1.25e8 is about 5 s of one core (40 ns each).
  double budget_particle_steps = 0.0;
  long cvode_max_steps = 0;  // CVODE steps per sample interval (0: CVODE's default)
};

StabilityPreset stability_preset(const std::string& name);  // quick | standard | paper

struct StabilityCase {
  std::string name;
  std::string why;
  StatePoint point;
  bool stiff = false;       // alpha_r < 2: add the small steps
  bool lanes = false;       // N = 100 near jamming
  bool respa_size = false;  // the RESPA-against-N scan: only its RESPA steps
  double strain_av = 0.0;
  double t_prep_min = 0.0;  // a longer preparation than the preset's (0: the preset's)
};

std::vector<StabilityCase> stability_cases(const StabilityPreset& preset);

int run_stability(const StudyOptions& options);
// The study for a given preset, restricted to the cases named in `only` (all if empty).
int run_stability_preset(const StabilityPreset& preset, const StudyOptions& options,
                         const std::vector<std::string>& only = {});

}  // namespace jamflow::studies
