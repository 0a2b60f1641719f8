// `jamflow study paper`: every study of the toolkit in dependency order, on one sweep engine,
// into OUT/<study>/, and one report (OUT/report.md) that puts the seed's figures 1-9 and its
// Table 2 beside jamflow's, with each part's verdicts and cost. Studies that share state points
// run them once (sweep/reuse.hpp). See studies/README.md.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "analysis/json.hpp"
#include "analysis/seed.hpp"
#include "framework/study.hpp"
#include "framework/table_report.hpp"
#include "lib/error.hpp"
#include "studies/common.hpp"
#include "sweep/engine.hpp"
#include "sweep/mpi.hpp"
#include "sweep/slurm.hpp"

namespace jamflow::studies {
namespace {
namespace fs = std::filesystem;

struct Part {
  const char* study;
  const char* seed;  // what of the seed it reproduces
};

// Dependency order: the methodology studies establish the integrators, steps and alpha_r that
// the science studies use (their choices, with the evidence, are in the studies' points), then
// the hard-sphere limit, its size dependence, the soft rheology and the Olsson-Teitel
// comparison, which uses the soft rheology.
const Part kParts[] = {
    {"timestep", "dt and integrator (SPEC §4; the seed's Sec. II)"},
    {"ensemble", "Fig. 1: constant pressure against constant volume"},
    {"softness", "the choice of alpha_r (the seed's Sec. II)"},
    {"stability", "stability on stiff cases (SPEC §4)"},
    {"hard-sphere", "Figs. 2, 3, 4, 7: mu(J), phi(J), the P -> 0 envelope, the viscosity"},
    {"finite-size", "Figs. 5, 6 and Table 2: the large-N limit and nu"},
    {"soft-rheology", "Fig. 8: the soft granular rheology, x and y"},
    {"olsson-teitel", "Fig. 9: the Olsson-Teitel collapse against the soft rheology"},
};

// The opening of a study's report: the lines between its title and its first section.
std::string headline(const fs::path& report) {
  std::istringstream in(read_file(report.string()));
  std::string line, out;
  bool titled = false;
  while (std::getline(in, line)) {
    if (line.rfind("# ", 0) == 0 && !titled) {
      titled = true;
      continue;
    }
    if (line.rfind("## ", 0) == 0)
      break;
    if (titled)
      out += line + "\n";
  }
  while (!out.empty() && (out.back() == '\n' || out.back() == ' '))
    out.pop_back();
  const std::size_t first = out.find_first_not_of("\n ");
  return first == std::string::npos ? std::string() : out.substr(first);
}

// Markdown links and images of a study's report, relative to its folder, made relative to the
// paper report's: "](x/report.md)" becomes "](STUDY/x/report.md)". Addresses with a scheme, an
// absolute path or an anchor are left as they are.
std::string rebase_links(const std::string& md, const std::string& study) {
  std::string out;
  std::size_t at = 0;
  for (std::size_t hit = md.find("](", at); hit != std::string::npos; hit = md.find("](", at)) {
    out += md.substr(at, hit + 2 - at);
    at = hit + 2;
    const std::size_t end = md.find_first_of(") ", at);
    const std::string target = md.substr(at, end == std::string::npos ? end : end - at);
    const bool relative = !target.empty() && target[0] != '/' && target[0] != '#' &&
                          target.find("://") == std::string::npos &&
                          target.rfind("mailto:", 0) != 0;
    if (relative)
      out += study + "/";
  }
  return out + md.substr(at);
}

// A study's figures (its folder's PNG files), as images linked relative to the paper report. The
// cases of a comparison plan keep theirs in their folders, reached through the links of the
// study's table of cases.
std::string figures(const fs::path& dir) {
  std::vector<std::string> names;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec))
    if (e.is_regular_file() && e.path().extension() == ".png")
      names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  std::string md;
  for (const auto& n : names)
    md += "\n![" + dir.filename().string() + ": " + n + "](" + dir.filename().string() + "/" + n +
          ")\n";
  return md;
}

// Table 2 beside jamflow's N -> infinity values (finite-size/analysis.json).
std::string table2_section(const fs::path& analysis) {
  std::ostringstream md;
  md << "\n## Table 2 (N -> infinity)\n\n";
  if (!fs::exists(analysis)) {
    md << "No `finite-size/analysis.json`: the finite-size study did not get to its analysis.\n";
    return md.str();
  }
  analysis::Json j;
  try {
    j = analysis::Json::parse(read_file(analysis.string()));
  } catch (const std::exception& e) {
    md << "`finite-size/analysis.json` cannot be read: " << e.what() << "\n";
    return md.str();
  }
  const auto& ex = j.at("extrapolated");
  if (ex.contains("skipped")) {
    md << "Not extrapolated: " << ex.at("skipped").as_string()
       << " (finite-size/report.md says why).\n";
    return md.str();
  }
  // Only a resolved extrapolation (analysis/README.md: a power law whose amplitude differs from
  // 0 by more than 2 sigma) is an N -> infinity value beside the seed's; the rest is named with
  // the reason and no value.
  std::vector<std::vector<std::string>> rows;
  int resolved = 0;
  for (const seed::SizeLaw& s : seed::kTable2) {
    const std::string name(s.name);
    if (!ex.contains(name))
      continue;
    const auto& e = ex.at(name);
    const bool ok = e.contains("resolved") && e.at("resolved").as_bool();
    const std::string why = e.contains("resolution") ? e.at("resolution").as_string() : "";
    if (ok && e.contains("inf") && e.at("inf").contains("value")) {
      ++resolved;
      const double v = e.at("inf").at("value").as_number(),
                   err = e.at("inf").at("error").as_number(), sys = systematic_of(e, "inf");
      rows.push_back(
          {name, with_systematic(v, err, sys), num(s.inf, 4), sigma_text(v, err, sys, s.inf), why});
    } else {
      rows.push_back({name, "-", num(s.inf, 4), "-", why});
    }
  }
  md << resolved << " of " << rows.size()
     << " parameters have a resolved N -> infinity extrapolation; for the others the "
        "finite-size report gives the per-N fits beside the seed's law at the same N.\n\n";
  md << markdown_table({"parameter", "jamflow", "seed", "difference", "resolution"}, rows);
  // What the sizes could resolve at all (analysis.json `sensitivity`), for the two that give nu.
  std::vector<std::string> chances;
  for (const char* name : {"phi_J", "mu_J"}) {
    if (!ex.contains(name) || !ex.at(name).contains("sensitivity"))
      continue;
    const auto& sv = ex.at(name).at("sensitivity");
    if (sv.contains("chance_resolved") && sv.at("chance_resolved").is_number())
      chances.push_back(std::string(name) + " " + num(sv.at("chance_resolved").as_number(), 2));
  }
  if (!chances.empty())
    md << "\nWere the seed's Table 2 law true, these sizes and errors would resolve A_O with a "
          "chance of "
       << join(chances)
       << " in the normal approximation (finite-size/report.md, \"What these sizes could "
          "resolve\").\n";
  return md.str();
}

// --report-only: the part's report rebuilt from its tables when the study can (else the report
// already in OUT/<study> as it is), and the hours its tables record.
std::vector<std::string> report_only_row(const StudyInfo& info, const Part& part,
                                         const StudyOptions& sub, std::ostringstream& headlines) {
  const fs::path dir = sub.out_dir;
  std::string status;
  if (!fs::exists(dir)) {
    status = "no results in this folder";
  } else if (info.report_only) {
    int code = 0;
    try {
      code = info.run(sub);
    } catch (const std::exception& e) {
      code = 2;
      std::fprintf(stderr, "study paper: %s: %s\n", part.study, e.what());
    }
    status = code == 0   ? "report rebuilt from its tables"
             : code == 1 ? "report rebuilt from its tables, with parts not computed (exit 1)"
                         : "report not rebuilt (exit " + std::to_string(code) + ")";
  } else {
    status = "report as it was written (this study rebuilds it only by running)";
  }
  // The tables of the study and of its stages.
  std::vector<Table> tables;
  std::error_code ec;
  for (const fs::path& t : {dir / "table.csv", dir / "constant-pressure" / "table.csv",
                            dir / "constant-volume" / "table.csv"}) {
    if (fs::exists(t, ec))
      tables.push_back(read_table(t.string()));
  }
  std::vector<const Table*> ptrs;
  for (const auto& t : tables)
    ptrs.push_back(&t);
  std::size_t rows = 0, from_wall = 0;
  const double hours = tables_hours(ptrs, &rows, &from_wall);
  const fs::path report = dir / "report.md";
  if (fs::exists(report))
    headlines << "\n### " << part.study << "\n\n"
              << rebase_links(headline(report), part.study) << "\n"
              << figures(dir);
  return {part.seed,
          part.study,
          status,
          "-",
          rows == 0 ? "-"
                    : num(hours, 3) + (from_wall == rows ? " (wall)"
                                       : from_wall > 0   ? " (part wall)"
                                                         : ""),
          fs::exists(report) ? "[" + std::string(part.study) + "/report.md](" +
                                   std::string(part.study) + "/report.md)"
                             : "-"};
}

int run(const StudyOptions& options) {
  const fs::path out = options.out_dir;
  if (sweep::mpi_launched())
    throw ConfigError(
        "jamflow study paper under an MPI launcher; allowed on one machine (-j) or as one "
        "Slurm job (--slurm): the studies' later stages start from earlier stages' results, "
        "which the ranks of one launch cannot follow");
  if (options.slurm) {
    ensure_dir(out.string());
    fs::create_directories(out / "slurm");
    sweep::SlurmOptions so;
    so.time = options.slurm_time;
    so.partition = options.slurm_partition;
    so.cpus_per_task = options.jobs > 0 ? options.jobs : 32;
    so.exe = sweep::jamflow_exe();
    sweep::check_slurm_time(so.time);
    const std::string dir = fs::absolute(out).lexically_normal().string();
    sweep::BatchJob job;
    job.name = "jamflow-paper";
    job.comment = "# Written by `jamflow study paper --slurm`: every study, preset " +
                  options.preset + ", on one node.\n# Submit with: sbatch " + dir +
                  "/paper.sbatch   (resubmitting it resumes where it stopped)\n";
    job.output = dir + "/slurm/%j.out";
    job.command = "\"$exe\" study paper --preset " + sweep::shell_quoted(options.preset) +
                  " --out " + sweep::shell_quoted(dir) + " -j \"${SLURM_CPUS_PER_TASK:-1}\"";
    for (const auto& name : options.only)
      job.command += " --only " + sweep::shell_quoted(name);
    const std::string script = (out / "paper.sbatch").string();
    write_text(script, sweep::batch_script(job, so));
    std::printf("%s\nsubmit it with: sbatch %s\n", script.c_str(), script.c_str());
    return 0;
  }

  StudyOptions::DryRunTally tally;
  std::vector<std::vector<std::string>> rows;
  std::ostringstream headlines;
  int worst = 0;
  for (const auto& name : options.only) {
    bool known = false;
    for (const Part& part : kParts)
      known = known || name == part.study;
    if (!known)
      throw ConfigError("jamflow study paper --only " + name +
                        "; allowed timestep, ensemble, softness, stability, hard-sphere, "
                        "finite-size, soft-rheology, olsson-teitel");
  }
  for (const Part& part : kParts) {
    if (!options.only.empty() &&
        std::find(options.only.begin(), options.only.end(), part.study) == options.only.end())
      continue;
    const StudyInfo* info = nullptr;
    const auto all = registry();
    for (const auto& s : all) {
      if (s.name == part.study)
        info = &s;
    }
    const fs::path dir = out / part.study;
    if (!info) {
      rows.push_back({part.seed, part.study, "not in this build", "-", "-", "-"});
      worst = std::max(worst, 1);
      continue;
    }
    StudyOptions sub = options;
    sub.out_dir = dir.string();
    sub.reuse.push_back(out.string());  // and the folders given with --reuse
    sub.tally = &tally;
    if (options.report_only) {
      // Rebuild what can be rebuilt from the tables in OUT/<study>; run nothing.
      rows.push_back(report_only_row(*info, part, sub, headlines));
      continue;
    }
    if (!options.quiet && !options.dry_run)
      std::printf("study paper: %s (%s)\n", part.study, part.seed);
    const auto start = std::chrono::steady_clock::now();
    int status = 0;
    std::string what;
    try {
      status = info->run(sub);
    } catch (const std::exception& e) {
      status = 2;
      what = e.what();
      std::fprintf(stderr, "study paper: %s: %s\n", part.study, e.what());
    }
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (status >= 128)
      return status;  // stopped by a signal: the checkpoints continue on the next run
    worst = std::max(worst, status);
    if (options.dry_run)
      continue;
    const std::string verdict = status == 0   ? "complete"
                                : status == 1 ? "complete, with parts not computed (exit 1)"
                                              : "failed (exit " + std::to_string(status) + ")";
    const fs::path report = dir / "report.md";
    rows.push_back({part.seed, part.study, what.empty() ? verdict : verdict + ": " + what,
                    num(wall / 60.0, 3) + " min", num(points_cpu_hours(dir.string()), 3),
                    fs::exists(report) ? "[" + std::string(part.study) + "/report.md](" +
                                             std::string(part.study) + "/report.md)"
                                       : "-"});
    if (fs::exists(report))
      headlines << "\n### " << part.study << "\n\n"
                << rebase_links(headline(report), part.study) << "\n"
                << figures(dir);
  }
  if (options.dry_run) {
    std::printf(
        "study paper --preset %s: %zu distinct runs, about %.3g CPU-hours (each integrator's "
        "measured CPU time per particle and tau_0; runs that studies share are counted once; a "
        "study in stages counts "
        "every stage, those not yet written from stand-in start states); %zu finished, about %.3g "
        "CPU-hours left\n",
        options.preset.c_str(), tally.scenes.size(), tally.cpu_hours, tally.finished,
        tally.cpu_hours_left);
    return worst;
  }
  std::ostringstream md;
  md << "# jamflow study paper, preset `" << options.preset << "`\n\n"
     << "Every study of jamflow, run in dependency order into this folder, each with its own "
        "report, against the seed (Kawasaki, Coslovich, Ikeda and Berthier, PRE 91, 012203, "
        "2015). Points that two studies share were run once (their logs say `reused`). "
     << (options.report_only
             ? "This report was rebuilt from the results in the folder without running anything "
               "(--report-only): CPU hours are those the studies' collected tables record (one "
               "thread per replica; \"wall\": the tables predate CPU time and give wall "
               "seconds; \"-\": the study keeps no collected table); wall time is not "
               "measured.\n\n"
             : "CPU hours are those of each study's collected points (one thread per replica; a "
               "reused point counts in every study that uses it); wall time is this "
               "invocation's (points finished before are not rerun).\n\n")
     << markdown_table({"the seed's", "study", "status", "wall time", "CPU hours", "report"}, rows);
  md << table2_section(out / "finite-size" / "analysis.json");
  md << "\n## Each study's opening\n" << headlines.str();
  write_text((out / "report.md").string(), md.str());
  if (!options.quiet)
    std::printf("study paper: %s\n", (out / "report.md").c_str());
  return worst;
}

const Registrar reg{{"paper",
                     "every study in dependency order on one sweep engine, shared points run "
                     "once, one report beside the seed's Figs. 1-9 and Table 2",
                     run, true}};

}  // namespace
}  // namespace jamflow::studies
