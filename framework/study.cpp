// `jamflow study` command line and registry.
#include "framework/study.hpp"

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>

#include "lib/cli_exit.hpp"
#include "lib/error.hpp"

namespace jamflow::studies {

namespace {
std::vector<StudyInfo>& mutable_registry() {
  static std::vector<StudyInfo> studies;
  return studies;
}
}  // namespace

Registrar::Registrar(StudyInfo info) {
  mutable_registry().push_back(std::move(info));
}

std::vector<StudyInfo> registry() {
  std::vector<StudyInfo> out = mutable_registry();
  std::sort(out.begin(), out.end(),
            [](const StudyInfo& a, const StudyInfo& b) { return a.name < b.name; });
  return out;
}

int study_main(const std::vector<std::string>& args) {
  CLI::App app{"Run a methodology study (see studies/README.md)", "jamflow study"};
  std::string name;
  StudyOptions opt;
  std::string names;
  for (const auto& s : registry())
    names += (names.empty() ? "" : ", ") + s.name;
  app.add_option("name", name, "study to run: " + (names.empty() ? "(none built)" : names))
      ->required();
  app.add_option("--preset", opt.preset,
                 "required: quick (CI, minutes), standard (hours on 2 cores; its results are "
                 "committed), paper (cluster)")
      ->check(CLI::IsMember({"quick", "standard", "paper"}));
  app.add_option("--out", opt.out_dir, "output folder (default out/<study>-<preset>)")
      ->check(non_empty_path());
  app.add_flag("--quiet", opt.quiet, "no progress lines");
  app.add_option("-j,--jobs", opt.jobs,
                 "points run at once, each a `jamflow run` process on one thread (default: the "
                 "cores)")
      ->check(CLI::Range(1, 4096));
  app.add_flag("--dry-run", opt.dry_run,
               "print the point count and the expected CPU-hours (of a study in stages: every "
               "unfinished stage, a later one from its scenes), and stop");
  app.add_flag("--slurm", opt.slurm,
               "write the study's points as a Slurm job array (OUT/runs/sweep.sbatch, or "
               "OUT/STAGE/runs/sweep.sbatch for the first unfinished stage of a study in "
               "stages); rerun the same command when it is done: the next stage's array, or "
               "the report after the last");
  app.add_option("--time", opt.slurm_time, "Slurm time limit per array task (--slurm)");
  app.add_option("--array-size", opt.slurm_array_size, "Slurm array tasks (--slurm)")
      ->check(CLI::Range(1, 100000));
  app.add_option("--partition", opt.slurm_partition, "Slurm partition (--slurm)");
  app.add_flag("--no-plots", opt.no_plots, "skip PNG plots");
  app.add_flag("--report-only", opt.report_only,
               "rebuild the analysis and report from OUT/table.csv without running points "
               "(hard-sphere, finite-size, soft-rheology, olsson-teitel)");
  app.add_option("--reuse", opt.reuse,
                 "folder of other sweeps (repeatable): finished replicas of the very same scene "
                 "are copied in, not rerun (study paper passes its own output folder)")
      ->check(reuse_folder());
  app.add_option("--only", opt.only, "study paper: run only these studies (in its order)")
      ->delimiter(',');
  std::vector<std::string> rev(args.rbegin(), args.rend());
  try {
    app.parse(rev);
  } catch (const CLI::ParseError& e) {
    return parse_error_exit(app, e, "jamflow study");
  }
  for (const auto& s : registry()) {
    if (s.name == name) {
      // No silent default: the preset sets a study's cost by orders of magnitude.
      if (app.count("--preset") == 0)
        throw ConfigError("jamflow study " + name +
                          ": --preset is not given; allowed: quick, standard, paper");
      if (!opt.only.empty() && name != "paper")
        throw ConfigError("jamflow study " + name + " --only; allowed with study paper only");
      if (opt.report_only && !s.report_only) {
        std::string allowed;
        for (const auto& t : registry()) {
          if (t.report_only)
            allowed += (allowed.empty() ? "" : ", ") + t.name;
        }
        throw ConfigError("jamflow study " + name + " --report-only; allowed with " + allowed +
                          " (this study has no report rebuilt from a table: it would run)");
      }
      if (opt.out_dir.empty())
        opt.out_dir = "out/" + name + "-" + opt.preset;
      return s.run(opt);
    }
  }
  std::fprintf(stderr, "jamflow study: unknown study '%s'; allowed: %s\n", name.c_str(),
               names.c_str());
  return 2;
}

}  // namespace jamflow::studies
