// Timestep study (studies/timestep): error of steady-state means against CPU time for Euler,
// RESPA and CVODE at fixed state points. Presets and analysis exposed for the tests.
#pragma once
#include <string>
#include <vector>

#include "studies/diagnostics.hpp"
#include "studies/study.hpp"

namespace jamflow::studies {

struct RespaScan {
  RespaSplitting splitting;
  std::vector<double> dts;  // outer steps
};

struct TimestepPreset {
  std::string name;
  std::vector<StatePoint> points;
  double strain_prep = 0.1, t_prep_min = 500.0;  // shared preparation from a random state
  double strain_eq = 0.01, t_eq_min = 100.0;     // per run, after switching integrator
  double strain_av = 0.1, t_av_min = 1000.0;     // averaging window
  std::vector<double> euler_dts;                 // the smallest is the reference
  std::vector<RespaScan> respa;
  std::vector<double> cvode_tols;
  // RKC's atol in units of the typical overlap delta = P^(1/(alpha_r - 1)) (rtol its default).
  std::vector<double> rkc_overlaps;
  // Particle-steps (N x force evaluations) allowed per run but the reference (0: none); over it
  // a run is "incomplete". 2.5e8 is about 10 s of one core (40 ns each).
  double budget_particle_steps = 0.0;
  long cvode_max_steps = 0;
};

TimestepPreset timestep_preset(const std::string& name);  // quick | standard | paper

// Accuracy targets: observable ("sigma_xy" relative, "phi" absolute, "pressure" relative,
// "balance" = |energy balance - 1|) and the allowed error.
struct AccuracyTarget {
  std::string observable;
  double value;
};
std::vector<AccuracyTarget> accuracy_targets();

int run_timestep(const StudyOptions& options);
int run_timestep_preset(const TimestepPreset& preset, const StudyOptions& options);

}  // namespace jamflow::studies
