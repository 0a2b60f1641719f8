// `jamflow study finite-size`: the hard-sphere analysis over system sizes, and its large-N
// limit O(N) = O_inf + A_O N^-alpha_O (the seed's Table 2, Figs. 5-6) with nu from phi and
// from mu. The same points and analysis as the hard-sphere study, over more sizes. See
// README.md in this folder.
#include <chrono>

#include "studies/hard-sphere/points.hpp"
#include "studies/hard-sphere/report.hpp"
#include "studies/study.hpp"
#include "studies/sweep_study.hpp"

namespace jamflow::studies {
namespace {

int run(const StudyOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const hard_sphere::GridPreset grid = hard_sphere::finite_size_preset(options.preset);
  SweepStudy points;
  if (auto status = run_sweep_study("finite-size", hard_sphere::sweep_text(grid), options, points))
    return *status;
  const double wall =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return hard_sphere::analyze_and_report("finite-size", grid, points, options, wall);
}

const Registrar reg{{"finite-size",
                     "the hard-sphere analysis over N and its large-N limit: phi_J, mu_J, the "
                     "exponents and nu (Table 2, Figs. 5-6)",
                     run, true}};

}  // namespace
}  // namespace jamflow::studies
