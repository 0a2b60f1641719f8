// jamflow command line: run a scene, analyse runs, run studies.
#include <CLI/CLI.hpp>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <exception>
#include <string>
#include <vector>

#include "analysis/analyze_cli.hpp"
#include "driver/run.hpp"
#include "ensembles/registry.hpp"
#include "integrators/registry.hpp"
#include "lib/cli_exit.hpp"
#include "lib/error.hpp"
#include "studies/study.hpp"

namespace {

std::atomic<bool> g_stop{false};
extern "C" void on_signal(int) {
  g_stop.store(true);
}

int run_command(const std::vector<std::string>& args) {
  CLI::App app{"Run one state point described by a scene (TOML).", "jamflow run"};
  std::string scene_path, out_path;
  std::vector<std::string> sets;
  bool quiet = false;
  int threads = -1;
  int replicas = 0;
  app.add_option("scene", scene_path, "scene file (TOML); omitted: the embedded default scene");
  app.add_option("-o,--output", out_path, "output HDF5 file (overrides [output] file)");
  app.add_option("--set", sets, "override a scene value: section.key=value (repeatable)");
  app.add_option("--threads", threads,
                 "OpenMP threads (default 1; 0 = all cores; overrides [run] threads)")
      ->check(CLI::Range(0, 1024));  // as [run] threads; the message names the bounds
  app.add_option("--replicas", replicas, "independent replicas (overrides [run] replicas)")
      ->check(CLI::PositiveNumber);
  app.add_flag("-q,--quiet", quiet, "no progress line");
  std::vector<std::string> rev(args.rbegin(), args.rend());
  try {
    app.parse(rev);
  } catch (const CLI::ParseError& e) {
    return jamflow::parse_error_exit(app, e, "jamflow run");
  }
  jamflow::Scene scene = scene_path.empty()
                             ? jamflow::Scene::parse(jamflow::kDefaultScene, "<default scene>")
                             : jamflow::Scene::load(scene_path);
  for (const auto& s : sets)
    scene.set(s);
  if (!out_path.empty())
    scene.set("output.file=\"" + out_path + "\"");
  if (threads >= 0)
    scene.set("run.threads=" + std::to_string(threads));
  if (replicas > 0)
    scene.set("run.replicas=" + std::to_string(replicas));
  const jamflow::RunSpec spec = jamflow::parse_run_spec(scene);
  jamflow::RunOptions opt;
  opt.quiet = quiet;
  opt.stop = &g_stop;
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  return jamflow::run_and_write(spec, opt);
}

void print_usage() {
  std::printf(
      "jamflow %s: overdamped shear rheology of soft spheres near jamming\n\n"
      "usage:\n"
      "  jamflow run [SCENE.toml] [-o OUT.h5] [--set section.key=value]... [--threads N]\n"
      "  jamflow scene                       print the embedded default scene\n"
      "  jamflow analyze {hard-sphere|soft|olsson-teitel} DATA... -o OUT.json\n"
      "  jamflow study NAME --preset {quick|standard|paper}\n"
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
                     "jamflow: error: no command given; allowed: run, scene, analyze, study\n");
      return args.empty() ? 2 : 0;
    }
    if (args[0] == "--version" || args[0] == "-V") {
      std::printf("jamflow %s (git %s)\n", JAMFLOW_VERSION, JAMFLOW_GIT_COMMIT);
      return 0;
    }
    const std::string cmd = args[0];
    const std::vector<std::string> rest(args.begin() + 1, args.end());
    if (cmd == "run")
      return run_command(rest);
    if (cmd == "scene") {
      std::fputs(jamflow::kDefaultScene, stdout);
      return 0;
    }
    if (cmd == "analyze")
      return jamflow::analysis::analyze_main(rest);
    if (cmd == "study")
      return jamflow::studies::study_main(rest);
    std::fprintf(stderr, "jamflow: unknown command '%s'; allowed: run, scene, analyze, study\n",
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
