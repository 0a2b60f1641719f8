// `jamflow analyze` command line (see analyze_cli.hpp).
#include "analysis/analyze_cli.hpp"

#include <CLI/CLI.hpp>

#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>

#include "analysis/data.hpp"
#include "analysis/errors.hpp"
#include "analysis/flow_curve.hpp"
#include "analysis/hard_sphere.hpp"
#include "analysis/json.hpp"
#include "analysis/olsson_teitel.hpp"
#include "analysis/plots.hpp"
#include "analysis/report.hpp"
#include "analysis/soft.hpp"

namespace jamflow::analysis {

namespace {

constexpr const char* kProgram = "jamflow analyze";

void print_error(const std::string& what) {
  std::string line = what;
  for (char& c : line) {
    if (c == '\n')
      c = ' ';
  }
  std::cerr << kProgram << ": error: " << line << "\n";
}

void print_warning(const std::string& what) {
  std::cerr << kProgram << ": warning: " << what << "\n";
}

// "a:b:c" -> numbers, with the option named in errors.
std::vector<double> parse_numbers(const std::string& text, std::size_t count,
                                  const std::string& option, const std::string& meaning) {
  std::vector<double> out;
  std::size_t start = 0;
  while (true) {
    std::size_t end = text.find(':', start);
    std::string field =
        text.substr(start, end == std::string::npos ? std::string::npos : end - start);
    double v = 0.0;
    auto res = std::from_chars(field.data(), field.data() + field.size(), v);
    if (field.empty() || res.ec != std::errc() || res.ptr != field.data() + field.size() ||
        !std::isfinite(v)) {
      throw InputError(option + " '" + text + "': expected " + meaning +
                       " (finite numbers "
                       "separated by ':'), bad field '" +
                       field + "'");
    }
    out.push_back(v);
    if (end == std::string::npos)
      break;
    start = end + 1;
  }
  if (out.size() != count) {
    throw InputError(option + " '" + text + "': expected " + std::to_string(count) + " numbers (" +
                     meaning + "), got " + std::to_string(out.size()));
  }
  return out;
}

struct Outputs {
  std::string json, markdown, sidecar, prefix;
};

Outputs output_paths(const std::string& json_path) {
  namespace fs = std::filesystem;
  fs::path p(json_path);
  fs::path stem = p.parent_path() / p.stem();
  return {json_path, stem.string() + ".md", stem.string() + ".plotdata.json", stem.string()};
}

void write_file(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out)
    throw InputError("cannot write output file '" + path + "'");
  out << text;
  out.close();
  if (!out)
    throw InputError("error while writing '" + path + "'");
}

// Writes JSON, markdown and plots; returns the exit code contribution.
int write_outputs(const Outputs& o, const Json& json, const std::string& markdown,
                  const Json& plot_data, const std::string& script, bool plots) {
  // Serialise first: a non-finite number must fail before anything is written.
  const std::string json_text = json.dump(2);
  const std::string sidecar_text = plot_data.dump(1);
  write_file(o.json, json_text);
  write_file(o.markdown, markdown);
  if (!plots)
    return 0;
  write_file(o.sidecar, sidecar_text);
  PlotOutcome outcome = run_plot_script(script, o.sidecar, o.prefix);
  if (outcome.status == PlotStatus::kUnavailable) {
    print_warning(outcome.message);
  } else if (outcome.status == PlotStatus::kFailed) {
    print_error(outcome.message);
    return 1;
  }
  return 0;
}

}  // namespace

namespace {

// The exit code of `body`, with the errors every analysis shares: an output that would replace
// an input (2), input errors (2), failed analyses (1), anything else (1), each one line.
template <class F>
int guarded(const std::vector<std::string>& inputs, const std::string& output, F&& body) {
  try {
    if (output.empty())
      throw InputError("-o '': allowed a file name for the JSON output");
    const Outputs out = output_paths(output);
    // Nothing written may replace an input, however its path is spelled.
    for (const std::string& path : {out.json, out.markdown, out.sidecar}) {
      for (const std::string& in : inputs) {
        if (same_file(path, in)) {
          throw InputError("-o '" + output + "' would overwrite the input '" + in + "' (with " +
                           path + "); allowed an output that is none of the data files");
        }
      }
    }
    return body(out);
  } catch (const InputError& e) {
    print_error(e.what());
    return 2;
  } catch (const AnalysisError& e) {
    print_error(e.what());
    return 1;
  } catch (const std::exception& e) {
    print_error(std::string("internal error: ") + e.what());
    return 1;
  }
}

}  // namespace

int analyze_hard_sphere_files(const std::vector<std::string>& files, const HardSphereOptions& o,
                              const AnalysisOutputs& outputs) {
  return guarded(files, outputs.json, [&](const Outputs& out) {
    auto data = read_granular(files);
    HardSphereResult r = analyze_hard_sphere(data, o);
    for (const auto& w : r.warnings)
      print_warning(w);
    int code = write_outputs(out, hard_sphere_json(r, o, files), hard_sphere_markdown(r, o, files),
                             hard_sphere_plot_data(r), "hard_sphere.py", outputs.plots);
    for (const auto& f : r.failures)
      print_error(f);
    if (r.failures.empty())
      return code;
    // No size could be fitted, each for lack of data: the data cannot support the analysis.
    const bool no_data = r.sizes.empty() && r.sizes_without_enough_data == r.unfitted.size();
    return no_data ? 2 : 1;
  });
}

int analyze_soft_files(const std::vector<std::string>& files,
                       const std::vector<std::string>& yield_files, SoftOptions o,
                       const AnalysisOutputs& outputs) {
  std::vector<std::string> inputs = files;
  inputs.insert(inputs.end(), yield_files.begin(), yield_files.end());
  return guarded(inputs, outputs.json, [&](const Outputs& out) {
    if (!yield_files.empty())
      o.yield_data = read_shear(yield_files);
    auto data = read_granular(files);
    SoftResult r = analyze_soft(data, o);
    for (const auto& w : r.warnings)
      print_warning(w);
    return write_outputs(out, soft_json(r, o, files), soft_markdown(r, o, files), soft_plot_data(r),
                         "soft.py", outputs.plots);
  });
}

int analyze_olsson_teitel_files(const std::vector<std::string>& files, const OlssonTeitelOptions& o,
                                std::optional<std::int64_t> size, const AnalysisOutputs& outputs) {
  return guarded(files, outputs.json, [&](const Outputs& out) {
    auto data = read_shear(files);
    if (size) {
      std::vector<ShearPoint> kept;
      for (const auto& p : data) {
        if (p.n == *size)
          kept.push_back(p);
      }
      if (kept.empty()) {
        throw InputError("--size " + std::to_string(*size) + ": no data at this N");
      }
      data = std::move(kept);
    }
    OlssonTeitelResult r = analyze_olsson_teitel(data, o);
    for (const auto& w : r.warnings)
      print_warning(w);
    return write_outputs(out, olsson_teitel_json(r, o, files), olsson_teitel_markdown(r, o, files),
                         olsson_teitel_plot_data(r, data), "olsson_teitel.py", outputs.plots);
  });
}

int analyze_flow_curve_files(const std::vector<std::string>& files, const FlowCurveOptions& o,
                             bool include_failed, const AnalysisOutputs& outputs) {
  return guarded(files, outputs.json, [&](const Outputs& out) {
    std::vector<std::string> left_out;
    VerdictAdmission verdicts;
    verdicts.include_failed = include_failed;
    verdicts.left_out = &left_out;
    auto data = read_shear(files, verdicts);
    FlowCurveResult r = analyze_flow_curves(data, o);
    for (const auto& w : r.warnings)
      print_warning(w);
    int code = write_outputs(out, flow_curve_json(r, files, left_out, include_failed),
                             flow_curve_markdown(r, files, left_out, include_failed),
                             flow_curve_plot_data(r), "flow_curve.py", outputs.plots);
    for (const auto& f : r.failures)
      print_error(f);
    return r.failures.empty() ? code : 1;
  });
}

int analyze_main(const std::vector<std::string>& args) {
  CLI::App app{
      "Analyses of state-point summaries (SPEC §5): granular rheology in the hard-sphere and "
      "large-N limits, soft granular rheology, Olsson–Teitel collapse quality.\n"
      "DATA are CSV tables (N,imposed_pressure,shear_rate,phi,phi_err,mu,mu_err or "
      "N,phi,shear_rate,sigma_xy,sigma_xy_err) "
      "or run files written by `jamflow run`.",
      kProgram};
  app.require_subcommand(1);
  app.set_help_all_flag("--help-all", "Help for every subcommand");

  std::vector<std::string> files;
  std::string output;
  bool no_plots = false, unscaled_errors = false;
  double envelope_z = EnvelopeOptions{}.z;
  std::string window, hs_params, at_text, start_text;
  int bootstrap = OlssonTeitelOptions{}.bootstrap;
  std::uint64_t seed = OlssonTeitelOptions{}.seed;
  double min_overlap = OlssonTeitelOptions{}.min_overlap;
  double split_delta = 0.0, split_gdot = 0.0;
  std::int64_t size = 0;

  auto common = [&](CLI::App* sub) {
    sub->add_option("DATA", files, "CSV tables and/or jamflow run files")->required();
    sub->add_option("-o,--output", output,
                    "output JSON; the report (.md), plot data and "
                    "PNGs are written next to it")
        ->required();
    sub->add_flag("--no-plots", no_plots, "do not run the matplotlib scripts");
    sub->add_flag("--unscaled-errors", unscaled_errors,
                  "do not multiply fit covariances by chi2/dof where it exceeds 1 (the default "
                  "scales them, and the output says so)");
  };
  CLI::App* hs =
      app.add_subcommand("hard-sphere",
                         "hard-sphere envelope, phi(J), mu(J) per N, N -> infinity (Table 2), nu, "
                         "eta(phi); plots Figs. 4-7");
  common(hs);
  hs->add_option("--envelope-z", envelope_z,
                 "pull threshold for agreeing with another pressure (default 2)");
  hs->add_option("--window", window,
                 "phimin:phimax for the effective viscosity exponent (default phi_J-0.1 : "
                 "phi_J-0.01)");
  CLI::App* soft = app.add_subcommand(
      "soft", "phi_J(P), mu_J(P) collapse, their power laws and the yield stress; plots Fig. 8");
  common(soft);
  soft->add_option("--envelope-z", envelope_z,
                   "pull threshold of the hard-sphere envelope used for the P -> 0 shape");
  soft->add_option("--hs-params", hs_params,
                   "b_phi:C_phi:b_mu:C_mu: fixed P -> 0 shape instead of each N's hard-sphere fit");
  int soft_bootstrap = JointSoftOptions{}.bootstrap;
  std::uint64_t soft_seed = JointSoftOptions{}.seed;
  std::vector<std::string> yield_files;
  soft->add_option("--bootstrap", soft_bootstrap,
                   "parametric-bootstrap resamples of the joint fit (default 200; 0 or >= 10)");
  soft->add_option("--seed", soft_seed, "bootstrap random seed");
  soft->add_option("--yield-data", yield_files,
                   "constant-volume tables or run files to compare with the joint law's yield "
                   "stress (points above phi_J0)");
  CLI::App* ot = app.add_subcommand(
      "olsson-teitel",
      "Houdayer–Hartmann collapse quality of the two-branch scaling; plots Fig. 9");
  common(ot);
  {
    const CollapseParams paper;
    char at_default[96];
    std::snprintf(at_default, sizeof at_default,
                  "phi_J:alpha:beta to evaluate (default the paper's, %g:%g:%g)", paper.phi_j,
                  paper.alpha, paper.beta);
    ot->add_option("--at", at_text, at_default);
  }
  ot->add_option("--start", start_text, "phi_J:alpha:beta optimiser start (default: --at)");
  ot->add_option("--bootstrap", bootstrap, "bootstrap resamples for errors (default 100, >= 10)");
  ot->add_option("--seed", seed, "bootstrap random seed");
  ot->add_option("--min-overlap", min_overlap,
                 "fraction of points that must have neighbours during optimisation (default 0.5)");
  CLI::Option* split_delta_opt =
      ot->add_option("--split-delta", split_delta,
                     "near/far split in |phi - phi_J| (default: median over points)");
  CLI::Option* split_gdot_opt =
      ot->add_option("--split-shear-rate", split_gdot,
                     "slow/fast split in the shear rate (default: geometric median)");
  // The option's deprecated name, still accepted (hidden from --help, warned about).
  CLI::Option* split_gdot_old =
      ot->add_option("--split-gdot", split_gdot)->group("")->excludes(split_gdot_opt);
  CLI::Option* size_opt =
      ot->add_option("--size", size, "system size N to analyse when the data hold several");
  CLI::App* fc = app.add_subcommand(
      "flow-curve",
      "power-law and Herschel-Bulkley fits of sigma_xy(gdot) on each curve, and eta(phi) "
      "divergence fits with phi_c free");
  common(fc);
  bool include_failed = false;
  fc->add_flag("--include-failed", include_failed,
               "include the rows whose verdicts failed (steady, stable, decorrelated), marked "
               "as such in the JSON and the report");

  // An unknown analysis would otherwise be taken for a stray argument ("A subcommand is
  // required").
  if (!args.empty() && !args[0].empty() && args[0][0] != '-' && args[0] != "hard-sphere" &&
      args[0] != "soft" && args[0] != "olsson-teitel" && args[0] != "flow-curve") {
    print_error("unknown analysis '" + args[0] +
                "'; allowed: hard-sphere, soft, olsson-teitel, flow-curve");
    return 2;
  }
  try {
    std::vector<std::string> reversed(args.rbegin(), args.rend());
    app.parse(reversed);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e, std::cout, std::cerr);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e, std::cout, std::cerr);
  } catch (const CLI::ParseError& e) {
    print_error(std::string(e.what()) + " (see `" + kProgram + " --help`)");
    return 2;
  }

  // The options' own errors (--window 1:2:3, --bootstrap 5) are input errors, as the data's.
  const AnalysisOutputs out{output, !no_plots};
  try {
    if (hs->parsed()) {
      HardSphereOptions o;
      o.envelope.z = envelope_z;
      o.scale_errors = !unscaled_errors;
      if (!window.empty()) {
        auto w = parse_numbers(window, 2, "--window", "phimin:phimax");
        o.window_min = w[0];
        o.window_max = w[1];
      }
      return analyze_hard_sphere_files(files, o, out);
    }
    if (fc->parsed()) {
      FlowCurveOptions o;
      o.scale_errors = !unscaled_errors;
      return analyze_flow_curve_files(files, o, include_failed, out);
    }
    if (soft->parsed()) {
      SoftOptions o;
      o.hard_sphere.envelope.z = envelope_z;
      o.hard_sphere.scale_errors = !unscaled_errors;
      o.scale_errors = !unscaled_errors;
      if (!hs_params.empty()) {
        auto v = parse_numbers(hs_params, 4, "--hs-params", "b_phi:C_phi:b_mu:C_mu");
        HardSphereShape s;
        s.b_phi = v[0];
        s.c_phi = v[1];
        s.b_mu = v[2];
        s.c_mu = v[3];
        s.source = "--hs-params (taken as exact)";
        o.fixed_shape = s;
      }
      // The command line keeps the joint fit when the per-pressure collapse cannot be done.
      o.require_collapse = false;
      o.joint.bootstrap = soft_bootstrap;
      o.joint.seed = soft_seed;
      if (soft_bootstrap < 0 || (soft_bootstrap > 0 && soft_bootstrap < 10)) {
        throw InputError("--bootstrap " + std::to_string(soft_bootstrap) +
                         " (allowed: 0, or 10 and more resamples)");
      }
      return analyze_soft_files(files, yield_files, o, out);
    }
    OlssonTeitelOptions o;
    if (!at_text.empty()) {
      auto v = parse_numbers(at_text, 3, "--at", "phi_J:alpha:beta");
      o.at = {v[0], v[1], v[2]};
    }
    if (!start_text.empty()) {
      auto v = parse_numbers(start_text, 3, "--start", "phi_J:alpha:beta");
      o.start = CollapseParams{v[0], v[1], v[2]};
    }
    o.bootstrap = bootstrap;
    o.seed = seed;
    o.min_overlap = min_overlap;
    if (split_delta_opt->count() > 0)
      o.split_delta = split_delta;
    if (split_gdot_old->count() > 0)
      std::fprintf(stderr, "warning: --split-gdot is deprecated; use --split-shear-rate\n");
    if (split_gdot_opt->count() > 0 || split_gdot_old->count() > 0)
      o.split_gdot = split_gdot;
    std::optional<std::int64_t> only;
    if (size_opt->count() > 0)
      only = size;
    return analyze_olsson_teitel_files(files, o, only, out);
  } catch (const InputError& e) {
    print_error(e.what());
    return 2;
  }
}

}  // namespace jamflow::analysis
