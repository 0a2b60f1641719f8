// jamflow command line: run a scene, analyse runs, run studies.
#include <CLI/CLI.hpp>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <string>
#include <vector>

#include "analysis/analyze_cli.hpp"
#include "apps/sweep_command.hpp"
#include "driver/checkpoint.hpp"
#include "driver/run.hpp"
#include "ensembles/registry.hpp"
#include "framework/compare.hpp"
#include "framework/study.hpp"
#include "integrators/registry.hpp"
#include "lib/cli_exit.hpp"
#include "lib/error.hpp"
#include "lib/version.hpp"

namespace {

jamflow::RunControl g_control;
extern "C" void on_signal(int sig) {
  if (sig == SIGUSR1)
    g_control.checkpoint.store(true);
  else
    g_control.signal.store(sig);
}

// Overrides that --extend accepts: what lengthens the averaging window, nothing that changes
// the physics of the samples already taken.
bool extend_may_set(const std::string& set) {
  for (const char* key : {"run.t_av=", "run.target_error=", "run.max_time=", "run.threads=",
                          "output.checkpoint_every="}) {
    if (set.rfind(key, 0) == 0)
      return true;
  }
  return false;
}

int run_command(const std::vector<std::string>& args) {
  CLI::App app{"Run one state point described by a scene (TOML).", "jamflow run"};
  std::string scene_path, out_path, resume_path, extend_path;
  std::vector<std::string> sets;
  bool quiet = false, force = false, strict = false;
  int threads = -1;
  int replicas = 0;
  app.add_option("scene", scene_path, "scene file (TOML); omitted: the embedded default scene");
  app.add_option("-o,--output", out_path, "output HDF5 file (overrides [output] file)")
      ->check(jamflow::non_empty_path());
  app.add_option("--set", sets, "override a scene value: section.key=value (repeatable)");
  app.add_option("--threads", threads,
                 "OpenMP threads (default 1; 0 = all cores; overrides [run] threads)")
      ->check(CLI::Range(0, 1024));  // as [run] threads; the message names the bounds
  app.add_option("--replicas", replicas, "independent replicas (overrides [run] replicas)")
      ->check(CLI::Range(1, 10000));  // as [run] replicas; the message names the bounds
  app.add_option(
      "--resume", resume_path,
      "continue an interrupted run from its checkpoint OUT.h5.part (scene from the file)");
  app.add_option("--extend", extend_path,
                 "lengthen a finished run OUT.h5: --set run.t_av=T appends to its series");
  app.add_flag("--force", force, "overwrite an existing output or checkpoint");
  app.add_flag("--strict", strict,
               "exit with status 3 when a verdict (steady, stable, decorrelated) fails");
  app.add_flag("-q,--quiet", quiet, "no progress line");
  std::vector<std::string> rev(args.rbegin(), args.rend());
  try {
    app.parse(rev);
  } catch (const CLI::ParseError& e) {
    return jamflow::parse_error_exit(app, e, "jamflow run");
  }
  jamflow::OutputOptions output;
  output.force = force;
  output.strict = strict;
  jamflow::Scene scene = jamflow::Scene::parse(jamflow::kDefaultScene, "<default scene>");
  if (!resume_path.empty() || !extend_path.empty()) {
    if (!resume_path.empty() && !extend_path.empty())
      throw jamflow::ConfigError("--resume and --extend were both given; allowed one of them");
    const bool extend = !extend_path.empty();
    const std::string from = extend ? extend_path : resume_path;
    if (!scene_path.empty() || replicas > 0 || !out_path.empty())
      throw jamflow::ConfigError(std::string(extend ? "--extend" : "--resume") +
                                 " takes the scene and output from '" + from +
                                 "'; a scene file, -o and --replicas are not allowed with it");
    const std::string part = ".part";
    if (!extend && (from.size() <= part.size() ||
                    from.compare(from.size() - part.size(), part.size(), part) != 0))
      throw jamflow::ConfigError("--resume '" + from +
                                 "': allowed a checkpoint file OUT.h5.part (finished runs are "
                                 "lengthened with --extend)");
    for (const auto& s : sets) {
      if (extend ? !extend_may_set(s) : s.rfind("run.threads=", 0) != 0)
        throw jamflow::ConfigError(
            "--set " + s + " with " + (extend ? "--extend" : "--resume") + "; allowed " +
            (extend ? "run.t_av, run.target_error, run.max_time, run.threads, "
                      "output.checkpoint_every"
                    : "run.threads (a continued run keeps its scene)"));
    }
    // A file that is not a run's (or not there) is bad input, named with its option.
    const std::string option = extend ? "--extend" : "--resume";
    jamflow::RunStatus status;
    try {
      jamflow::Continuation c = jamflow::read_continuation(from, option);
      scene = jamflow::Scene::parse(c.scene, from);
      status = c.status;
      output.continue_from = std::move(c.replicas);
    } catch (const jamflow::IoError& e) {
      throw jamflow::ConfigError(option + " '" + from + "': " + e.what() +
                                 "; allowed a jamflow run file");
    }
    if (extend && !status.is_complete())
      throw jamflow::ConfigError("--extend '" + from + "': the run's status is \"" + status.text() +
                                 "\"; allowed finished runs (continue others with --resume)");
    output.extend = extend;
    const std::string out = extend ? from : from.substr(0, from.size() - part.size());
    scene.set("output.file=\"" + out + "\"");
    if (!extend && !force && std::filesystem::exists(out))
      throw jamflow::ConfigError("--resume: '" + out +
                                 "' exists already; pass --force to replace it");
  } else if (!scene_path.empty()) {
    scene = jamflow::Scene::load(scene_path);
  }
  for (const auto& s : sets)
    scene.set(s);
  if (!out_path.empty())
    scene.set("output.file=\"" + out_path + "\"");
  if (threads >= 0)
    scene.set("run.threads=" + std::to_string(threads));
  if (replicas > 0)
    scene.set("run.replicas=" + std::to_string(replicas));
  const jamflow::RunSpec spec = jamflow::parse_run_spec(scene);
  if (output.continue_from)
    jamflow::check_continuation(spec, *output.continue_from,
                                output.extend ? "--extend" : "--resume",
                                output.extend ? extend_path : resume_path);
  if (output.extend) {
    const auto& first = output.continue_from->front().series.samples;
    const double done = first.empty() ? 0.0 : first.back().time;
    if (spec.t_eq + spec.t_av < done - 1e-9 * spec.sample_every)
      throw jamflow::ConfigError("[run] t_av = " + jamflow::fmt(spec.t_av) +
                                 " with --extend: the run has reached t = " + jamflow::fmt(done) +
                                 "; allowed t_eq + t_av >= that");
  }
  jamflow::RunOptions opt;
  opt.quiet = quiet;
  opt.control = &g_control;
  for (int sig : {SIGINT, SIGTERM, SIGHUP, SIGUSR1})
    std::signal(sig, on_signal);
  return jamflow::run_and_write(spec, opt, output);
}

// `jamflow scene`: the embedded default scene on stdout; --help says so instead.
int scene_command(const std::vector<std::string>& args) {
  CLI::App app{"Print the embedded default scene (TOML) on stdout: a start for a scene file.",
               "jamflow scene"};
  std::vector<std::string> rev(args.rbegin(), args.rend());
  try {
    app.parse(rev);
  } catch (const CLI::ParseError& e) {
    return jamflow::parse_error_exit(app, e, "jamflow scene");
  }
  std::fputs(jamflow::kDefaultScene, stdout);
  return 0;
}

void print_usage() {
  std::printf(
      "jamflow %s: overdamped shear rheology of soft spheres near jamming\n\n"
      "usage:\n"
      "  jamflow run [SCENE.toml] [-o OUT.h5] [--set section.key=value]... [--threads N]\n"
      "              [--force] [--resume OUT.h5.part | --extend OUT.h5 --set run.t_av=T]\n"
      "  jamflow scene                       print the embedded default scene\n"
      "  jamflow analyze {hard-sphere|soft|olsson-teitel|flow-curve} DATA... -o OUT.json\n"
      "  jamflow sweep SWEEP.toml [--out DIR] [-j K] [--dry-run] [--collect TABLE.csv]\n"
      "              [--slurm [--array-size M] [--time HH:MM:SS]] [--task K --array-size M]\n"
      "  mpirun -n R jamflow sweep SWEEP.toml   the points farmed over R MPI ranks\n"
      "  jamflow study NAME --preset {quick|standard|paper}\n"
      "  jamflow compare COMPARE.toml [--out DIR] [-j K] [--dry-run] [--slurm]\n"
      "  jamflow --version | --help\n\n"
      "Each command takes --help.\n",
      JAMFLOW_VERSION);
  // The kinds a scene may name, from the registries.
  std::printf("\n[integrator] kind:\n");
  for (const auto& k : jamflow::registered_integrators())
    std::printf("  %-18s %s\n", k.kind.c_str(), k.description.c_str());
  std::printf("[ensemble] kind:\n");
  for (const auto& k : jamflow::registered_ensembles())
    std::printf("  %-18s %s\n", k.kind.c_str(), k.description.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  try {
    if (args.empty() || args[0] == "--help" || args[0] == "-h" || args[0] == "help") {
      print_usage();
      if (args.empty())
        std::fprintf(stderr,
                     "jamflow: error: no command given; allowed: run, scene, sweep, analyze, "
                     "study, compare\n");
      return args.empty() ? 2 : 0;
    }
    if (args[0] == "--version" || args[0] == "-V") {
      std::printf("jamflow %s (git %s)\n", JAMFLOW_VERSION, jamflow::git_commit());
      return 0;
    }
    const std::string cmd = args[0];
    const std::vector<std::string> rest(args.begin() + 1, args.end());
    if (cmd == "run")
      return run_command(rest);
    if (cmd == "scene")
      return scene_command(rest);
    if (cmd == "analyze")
      return jamflow::analysis::analyze_main(rest);
    if (cmd == "sweep")
      return jamflow::apps::sweep_command(rest);
    if (cmd == "study")
      return jamflow::studies::study_main(rest);
    if (cmd == "compare")
      return jamflow::studies::compare_main(rest);
    std::fprintf(
        stderr,
        "jamflow: unknown command '%s'; allowed: run, scene, sweep, analyze, study, compare\n",
        cmd.c_str());
    return 2;
  } catch (const jamflow::ConfigError& e) {
    std::fprintf(stderr, "jamflow: error: %s\n", jamflow::one_line(e.what()).c_str());
    return 2;
  } catch (const jamflow::InputFileError& e) {  // a scene or init file that cannot be read
    std::fprintf(stderr, "jamflow: error: %s\n", jamflow::one_line(e.what()).c_str());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "jamflow: error: %s\n", jamflow::one_line(e.what()).c_str());
    return 1;
  }
}
