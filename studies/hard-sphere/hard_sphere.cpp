// `jamflow study hard-sphere`: the granular rheology of the hard-sphere limit (the seed's
// Figs. 2-4 and 7) from jamflow's own constant-pressure runs. See README.md in this folder.
#include <chrono>

#include "studies/hard-sphere/points.hpp"
#include "studies/hard-sphere/report.hpp"
#include "studies/study.hpp"
#include "studies/sweep_study.hpp"

namespace jamflow::studies {
namespace {

int run(const StudyOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const hard_sphere::GridPreset grid = hard_sphere::grid_preset(options.preset);
  SweepStudy points;
  if (auto status = run_sweep_study("hard-sphere", hard_sphere::sweep_text(grid), options, points))
    return *status;
  const double wall =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return hard_sphere::analyze_and_report("hard-sphere", grid, points, options, wall);
}

const Registrar reg{{"hard-sphere",
                     "hard-sphere granular rheology at constant pressure: mu(J), phi(J), the "
                     "P -> 0 envelope, phi_J, mu_J and the viscosity divergence (Figs. 2-4, 7)",
                     run, true}};

}  // namespace
}  // namespace jamflow::studies
