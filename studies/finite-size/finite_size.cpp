// `jamflow study finite-size`: the hard-sphere analysis over system sizes, and its large-N
// limit O(N) = O_inf + A_O N^-alpha_O (the seed's Table 2, Figs. 5-6) with nu from phi and
// from mu. The same points and analysis as the hard-sphere study, over more sizes. See
// README.md in this folder.
#include "framework/study.hpp"
#include "studies/granular_report.hpp"
#include "studies/pressure_points.hpp"

namespace jamflow::studies {
namespace {

int run(const StudyOptions& options) {
  return granular::run_grid_study("finite-size", finite_size_preset(options.preset), options);
}

const Registrar reg{{"finite-size",
                     "the hard-sphere analysis over N and its large-N limit: phi_J, mu_J, the "
                     "exponents and nu (Table 2, Figs. 5-6)",
                     run, true}};

}  // namespace
}  // namespace jamflow::studies
