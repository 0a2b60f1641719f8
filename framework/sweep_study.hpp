// Studies whose state points are a sweep (sweep/): the study writes its points as a sweep file
// OUT/sweep.toml and runs them with the sweep engine into OUT/runs/ (local cores, or MPI ranks
// under mpirun), or writes a Slurm job array for them (--slurm), or only counts them
// (--dry-run). Rerunning the study finds the finished points, so the analysis of a preset run on
// a cluster is one more `jamflow study` on the same OUT.
//
// A study in stages (a preparation whose final states start later runs) runs each stage as its
// own sweep in OUT/<stage>/ (sweep.toml, runs/). A stage whose points are all finished is read
// back whatever the options; the first unfinished one is written as a job array (--slurm) or
// run. --dry-run counts every unfinished stage: a stage after an unfinished one is counted from
// its scenes with stand-in start states (same N, lengths and integrators; only the start
// configuration is missing, and the count does not depend on it). Under mpirun, a launch that
// computed a stage other than the last ends there: the same command again goes on with the next
// stage.
#pragma once
#include <optional>
#include <string>

#include "framework/study.hpp"
#include "sweep/plan.hpp"

namespace jamflow::studies {

struct SweepStudy {
  sweep::Plan plan;
  std::string table;  // OUT/table.csv, one row per finished point (sweep --collect)
  std::size_t finished = 0;
  double cpu_hours_estimate = 0.0;
  // --dry-run of a stage that is not the last: counted, not run; its results are stand-ins.
  bool counted_only = false;
};

// Where a sweep goes in a study's output folder.
struct SweepStage {
  std::string name;           // empty: OUT itself (one-stage studies); else OUT/<name>
  bool last = true;           // no stage comes after this one
  bool collect_table = true;  // collect OUT/table.csv (one-stage studies)
};

// Writes the sweep file, then: --dry-run prints the point count and the CPU-hour estimate and
// returns the exit status 0 (a stage before the last: returns nothing, with out.counted_only, so
// that the study goes on to count the next stage); --slurm writes the job array and returns 0;
// otherwise runs every unfinished point. A stop by a signal returns 128 + the signal. Returns
// nothing when the points are finished (failed points are reported and left out) and, with
// collect_table, the table is collected into `out`.
std::optional<int> run_sweep_study(const std::string& study, const std::string& sweep_text,
                                   const StudyOptions& options, SweepStudy& out,
                                   const SweepStage& stage = {});

// The sweep and table already in an output folder (OUT/sweep.toml, OUT/table.csv), for
// --report-only. Throws ConfigError when either is missing.
SweepStudy existing_sweep(const std::string& out_dir);

}  // namespace jamflow::studies
