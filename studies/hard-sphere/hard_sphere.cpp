// `jamflow study hard-sphere`: the granular rheology of the hard-sphere limit (the seed's
// Figs. 2-4 and 7) from jamflow's own constant-pressure runs. See README.md in this folder.
#include "framework/study.hpp"
#include "studies/granular_report.hpp"
#include "studies/pressure_points.hpp"

namespace jamflow::studies {
namespace {

int run(const StudyOptions& options) {
  return granular::run_grid_study("hard-sphere", grid_preset(options.preset), options);
}

const Registrar reg{{"hard-sphere",
                     "hard-sphere granular rheology at constant pressure: mu(J), phi(J), the "
                     "P -> 0 envelope, phi_J, mu_J and the viscosity divergence (Figs. 2-4, 7)",
                     run, true}};

}  // namespace
}  // namespace jamflow::studies
