// Studies whose state points are a sweep (sweep/): the study writes its points as a sweep file
// OUT/sweep.toml and runs them with the sweep engine into OUT/runs/ (local cores, or MPI ranks
// under mpirun), or writes a Slurm job array for them (--slurm), or only counts them
// (--dry-run). Rerunning the study finds the finished points, so the analysis of a preset run on
// a cluster is one more `jamflow study` on the same OUT.
#pragma once
#include <optional>
#include <string>

#include "studies/study.hpp"
#include "sweep/plan.hpp"

namespace jamflow::studies {

struct SweepStudy {
  sweep::Plan plan;
  std::string table;  // OUT/table.csv, one row per finished point (sweep --collect)
  std::size_t finished = 0;
  double cpu_hours_estimate = 0.0;
};

// Writes the sweep file, then: --dry-run prints the point count and the CPU-hour estimate and
// returns the exit status 0; --slurm writes the job array and returns 0; otherwise runs every
// unfinished point. A stop by a signal returns 128 + the signal. Returns nothing when the
// points are finished (failed points are reported and left out) and the table is collected
// into `out`.
std::optional<int> run_sweep_study(const std::string& study, const std::string& sweep_text,
                                   const StudyOptions& options, SweepStudy& out);

}  // namespace jamflow::studies
