// Study registry: `jamflow study NAME --preset P` runs a registered study.
#pragma once
#include <functional>
#include <map>
#include <set>
#include <string>
#include <vector>

namespace jamflow::studies {

struct StudyOptions {
  std::string preset = "quick";  // quick | standard | paper
  std::string out_dir;           // default: out/<study>-<preset>
  bool quiet = false;
  bool no_plots = false;
  // Rebuild the analysis and the report from the table already in the output folder
  // (OUT/table.csv and OUT/sweep.toml; the soft-rheology study's in its two sub-folders; the
  // olsson-teitel study's plan from its preset when no sweep.toml was kept; study paper
  // rebuilds each part that can) without running or collecting points: for committed results
  // whose point files are not kept. Studies without a table-based report refuse it.
  bool report_only = false;
  // Every study runs its points as sweeps (framework/sweep_study.hpp): points at once (0: the
  // cores), print the point count and cost and stop, or write a Slurm job array instead of
  // running.
  int jobs = 0;
  bool dry_run = false;
  bool slurm = false;
  std::string slurm_time = "24:00:00";
  int slurm_array_size = 0;
  std::string slurm_partition;
  // Folders of earlier runs whose finished replicas of the very same scene are reused
  // (sweep/reuse.hpp); `study paper` passes its whole output folder.
  std::vector<std::string> reuse;
  // --dry-run of several studies (`study paper`): each sweep adds the estimate of the tasks
  // whose scene no earlier sweep had (those would be reused, not run).
  struct DryRunTally {
    double cpu_hours = 0.0;       // every distinct run
    double cpu_hours_left = 0.0;  // the distinct runs not finished yet
    std::size_t finished = 0;     // distinct runs finished before (their files say done)
    std::set<std::string> scenes;
  };
  DryRunTally* tally = nullptr;
  std::vector<std::string> only;  // `study paper --only`: these parts, in its order
  // The command that runs this again (messages of --dry-run and --slurm); empty: `jamflow study
  // NAME --preset P --out DIR`. `jamflow compare` runs its stages with these options too.
  std::string command;
};

using StudyFn = std::function<int(const StudyOptions&)>;

struct StudyInfo {
  std::string name;
  std::string summary;
  StudyFn run;
  // Whether `--report-only` can rebuild the study's report from the tables in its output folder;
  // the others refuse it rather than run their points.
  bool report_only = false;
};

// All studies known to this build, sorted by name.
std::vector<StudyInfo> registry();

// A study registers itself with a namespace-scope `const Registrar r{{name, summary, fn}};`.
// The studies are built as an object library, so every registrar is linked in.
struct Registrar {
  explicit Registrar(StudyInfo info);
};

// Entry point for `jamflow study ...` (args are the words after "study").
int study_main(const std::vector<std::string>& args);

}  // namespace jamflow::studies
