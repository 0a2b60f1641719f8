// The run file: the HDF5 layout of a run (README "Output"), its final and .part files, and the
// check of an output path before anything is computed.
#include <unistd.h>

#include <cmath>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string_view>
#include <utility>
#include <variant>

#include "driver/checkpoint.hpp"
#include "driver/run.hpp"
#include "lib/error.hpp"
#include "lib/h5.hpp"
#include "lib/version.hpp"

#ifndef JAMFLOW_VERSION
#define JAMFLOW_VERSION "unknown"
#endif

namespace jamflow {

namespace {

std::string iso_now() {
  const std::time_t t = std::time(nullptr);
  char buf[64];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
  return buf;
}

// Units of the quantities by name (unit_of). Counters, flags and ratios are "1".
constexpr std::pair<std::string_view, std::string_view> kUnits[] = {
    // Series and summary values.
    {"time", "tau_0"},
    {"strain", "1"},
    {"volume", "a^3"},
    {"phi", "1"},
    {"pressure", "eps/a^3"},
    {"imposed_pressure", "eps/a^3"},
    {"sigma_xy", "eps/a^3"},
    {"energy", "eps"},
    {"dissipation", "eps/tau_0"},
    {"piston_dissipation", "eps/tau_0"},
    {"eta", "xi_s/a"},
    {"mu", "1"},
    {"J", "1"},  // gdot eta_0 / P
    {"shear_rate", "1/tau_0"},
    {"energy_balance", "1"},
    {"energy_balance_corrected", "1"},
    {"force_step_correlation", "1"},
    {"samples", "1"},
    {"replicas", "1"},
    {"block_length", "tau_0"},
    {"t_eq", "tau_0"},
    {"t_av", "tau_0"},
    {"steady", "1"},  // verdicts: 1 pass, 0 fail, NaN not checked
    {"stable", "1"},
    {"decorrelated", "1"},
    {"N", "1"},
    {"alpha", "1"},        // the potential's exponent
    {"xi_V", "xi_s/a^4"},  // the piston's friction
    {"wall_seconds", "s"},
    {"cpu_seconds", "s"},
    // The final configuration.
    {"positions", "a"},
    {"diameters", "a"},
    {"species", "1"},
    {"cell", "a"},
    // The checkpoint: scaled (fractional) coordinates, image counters, particle ids and the
    // neighbour lists' rows and entries are numbers; h^-1 of a cell is an inverse length.
    {"pos", "1"},
    {"image", "1"},
    {"diameter", "a"},
    {"id", "1"},
    {"start", "1"},
    {"entries", "1"},
    {"inner_start", "1"},
    {"inner_entries", "1"},
    {"ref_pos", "1"},
    {"inner_ref_pos", "1"},
    {"h_ref_inv", "1/a"},
    {"inner_h_ref_inv", "1/a"},
};

// The integrators' counters and state (Integrator::statistics, and the driver's own), as the
// summary's integrator_<name>: counts are "1".
constexpr std::pair<std::string_view, std::string_view> kIntegratorUnits[] = {
    {"steps", "1"},
    {"force_evaluations", "1"},
    {"force_pass_equivalents", "1"},
    {"neighbour_list_builds", "1"},
    // RESPA
    {"inner_steps", "1"},
    // RKC
    {"rejected_steps", "1"},
    {"stage_evaluations", "1"},
    {"dom_eig_estimates", "1"},
    {"dom_eig_evaluations", "1"},
    {"max_stages_used", "1"},
    {"steps_since_dom_eig", "1"},
    {"need_dom_eig", "1"},
    {"spectral_radius", "1/tau_0"},
    {"step_next", "tau_0"},
    {"step_last", "tau_0"},
    {"error_last", "1"},  // the weighted error norm
    // CVODE
    {"rhs_evaluations", "1"},
    {"nonlinear_iterations", "1"},
    {"linear_iterations", "1"},
    {"jtimes_evaluations", "1"},
    {"error_test_failures", "1"},
    {"nonlinear_convergence_failures", "1"},
    {"linear_convergence_failures", "1"},
    {"preconditioner_setups", "1"},
    {"preconditioner_solves", "1"},
    {"jtimes_setups", "1"},
    {"rhs_recoverable_failures", "1"},
    {"reinits", "1"},
    {"atol", "a"},  // the absolute tolerance, a contact length
};

template <std::size_t K>
std::string lookup(const std::pair<std::string_view, std::string_view> (&table)[K],
                   std::string_view name) {
  for (const auto& [key, unit] : table)
    if (key == name)
      return std::string(unit);
  return {};
}

}  // namespace

std::string unit_of(std::string_view name) {
  if (std::string u = lookup(kUnits, name); !u.empty())
    return u;
  const auto strip = [&](std::string_view affix, bool prefix) -> std::optional<std::string_view> {
    if (name.size() <= affix.size())
      return std::nullopt;
    if (prefix)
      return name.substr(0, affix.size()) == affix ? std::optional(name.substr(affix.size()))
                                                   : std::nullopt;
    return name.substr(name.size() - affix.size()) == affix
               ? std::optional(name.substr(0, name.size() - affix.size()))
               : std::nullopt;
  };
  // An error, a scatter or a sum has the unit of its quantity.
  for (std::string_view suffix : {"_replica_err", "_err", "_block_std", "_total"})
    if (const auto base = strip(suffix, false))
      return unit_of(*base);
  if (const auto base = strip("integrator_", true))
    return lookup(kIntegratorUnits, *base);
  // Integrated autocorrelation times, and the t-statistics of the block means' trend.
  if (const auto base = strip("tau_", true); base && !unit_of(*base).empty())
    return "tau_0";
  if (const auto base = strip("trend_t_", true); base && !unit_of(*base).empty())
    return "1";
  return {};
}

void write_unit(H5Writer& w, const std::string& path) {
  const std::string unit = unit_of(std::string_view(path).substr(path.rfind('/') + 1));
  if (!unit.empty())
    w.attr(path, "unit", unit);
}

Configuration configuration_of(const State& st) {
  Configuration c;
  const std::size_t n = st.size();
  c.positions.resize(3 * n);
  c.diameters.resize(n);
  c.species.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const auto id = static_cast<std::size_t>(st.id[i]);
    Eigen::Vector3d s = st.scaled(i);
    for (int k = 0; k < 3; ++k)
      s[k] -= std::floor(s[k]);
    const Eigen::Vector3d x = st.box.h() * s;
    for (int k = 0; k < 3; ++k)
      c.positions[3 * id + k] = x[k];
    c.diameters[id] = st.diameter[i];
    c.species[id] = st.species[i];
  }
  const Eigen::Matrix3d cell = st.box.h().transpose();
  c.cell.resize(9);
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b)
      c.cell[3 * a + b] = cell(a, b);
  c.strain = st.box.strain;
  c.time = st.time;
  return c;
}

namespace {

// `summary` replaces r's own summary values, counters and wall time (the replica mean at the
// top level of a multi-replica file).
void write_replica(H5Writer& w, const RunSpec& spec, const ReplicaResult& r,
                   const std::string& prefix, const ReplicaResult* summary = nullptr) {
  const auto& ss = r.series;
  const std::string ts = prefix + "/timeseries";
  for (const auto& [name, field] : kSeriesFields) {
    if (timeseries_has(spec, name)) {
      w.dataset(ts + "/" + name, ss.column(field));
      write_unit(w, ts + "/" + name);
    }
  }
  w.attr(ts, "t_eq", r.summary.t_eq.value_or(spec.t_eq));
  w.attr(ts, "seed", static_cast<std::int64_t>(r.seed));

  // Final configuration, in particle id order; cell rows are the lattice vectors.
  const Configuration c = configuration_of(r.final_state);
  const std::size_t n = c.diameters.size();
  const std::string fin = prefix + "/final";
  w.dataset(fin + "/positions", c.positions, {n, 3});
  w.dataset(fin + "/diameters", c.diameters);
  w.dataset(fin + "/species", c.species);
  w.dataset(fin + "/cell", c.cell, {3, 3});
  for (const char* name : {"positions", "diameters", "species", "cell"})
    write_unit(w, fin + "/" + name);
  w.attr(fin, "strain", c.strain);
  w.attr(fin, "time", c.time);

  const std::string sm = prefix + "/summary";
  w.group(sm);
  const Attributes values = summary_attributes(spec, r, summary);
  w.attrs(sm, values);
  // Attributes cannot carry attributes: the units of the numbers, by name, in a subgroup.
  w.group(sm + "/units");
  for (const auto& [name, value] : values) {
    const std::string unit = unit_of(name);
    if (!std::holds_alternative<std::string>(value) && !unit.empty())
      w.attr(sm + "/units", name, unit);
  }
}

}  // namespace

Attributes summary_attributes(const RunSpec& spec, const ReplicaResult& r,
                              const ReplicaResult* summary) {
  Attributes out;
  const ReplicaResult& src = summary ? *summary : r;
  for (const auto& [k, v] : src.summary.values())
    out.emplace_back(k, v);
  if (src.summary.computed)
    for (const auto& [k, v] : kVerdicts)
      out.emplace_back("verdict_" + std::string(k), (src.summary.*v).text());
  for (const auto& [k, v] :
       {std::pair{"run_length", &r.summary.run_length}, {"t_eq_method", &r.summary.t_eq_method}})
    if (*v)
      out.emplace_back(k, **v);
  out.emplace_back("N", static_cast<std::int64_t>(r.final_state.size()));
  out.emplace_back("alpha", spec.alpha);
  spec.ensemble->describe(out);
  out.emplace_back("integrator", spec.integrator.kind);
  for (const auto& [k, v] : src.integrator_stats)
    out.emplace_back("integrator_" + k, v);
  out.emplace_back("wall_seconds", src.wall_seconds);
  out.emplace_back("cpu_seconds", src.cpu_seconds);
  if (src.cpu_from_wall)
    out.emplace_back(
        "cpu_seconds_note",
        "includes wall seconds: continued from a checkpoint that recorded no CPU time");
  out.emplace_back("status", src.status.text());
  return out;
}

ReplicaResult replicas_summary(const std::vector<ReplicaResult>& replicas) {
  // Counters need not be additive (CVODE's atol, say): the first replica's; the times summed
  // as totals beside them.
  ReplicaResult all;
  all.integrator_stats = replicas.front().integrator_stats;
  all.wall_seconds = replicas.front().wall_seconds;
  all.cpu_seconds = replicas.front().cpu_seconds;
  all.status = replicas.front().status;
  std::vector<Summary> sums;
  double wall = 0.0, cpu = 0.0;
  for (const auto& r : replicas) {
    sums.push_back(r.summary);
    wall += r.wall_seconds;
    cpu += r.cpu_seconds;
    all.cpu_from_wall = all.cpu_from_wall || r.cpu_from_wall;
  }
  all.summary = combine_replicas(sums);
  all.summary.wall_seconds_total = wall;
  all.summary.cpu_seconds_total = cpu;
  return all;
}

void write_run_layout(H5Writer& w, const RunSpec& spec,
                      const std::vector<ReplicaResult>& replicas) {
  w.attr("/", "scene", spec.scene_text);
  w.attr("/", "version", JAMFLOW_VERSION);
  w.attr("/", "git_commit", git_commit());
  w.attr("/", "created", iso_now());
  RunStatus status;  // the first replica's that is not complete
  std::int64_t resumes = 0;
  std::string history;
  for (const auto& r : replicas) {
    if (!r.status.is_complete() && status.is_complete())
      status = r.status;
    resumes += r.resumes;
    if (r.history != "none" && r.history != "kept")
      history += (history.empty() ? "" : "; ") + r.history;
  }
  if (!replicas.empty()) {
    w.attr("/", "kernel", replicas.front().kernel);
    w.attr("/", "kernel_target", replicas.front().kernel_target);
    w.attr("/", "threads", static_cast<std::int64_t>(replicas.front().threads));
    // "none", "kept", or where an adaptive solver started afresh (a continued run).
    w.attr("/", "solver_history", history.empty() ? replicas.front().history : history);
  }
  w.attr("/", "replicas", static_cast<std::int64_t>(replicas.size()));
  w.attr("/", "resumes", resumes);
  w.attr("/", "status", status.text());
  if (replicas.empty())
    return;
  if (replicas.size() > 1 && status.is_complete()) {
    // Top level: the first replica's series and final state, the summary of all replicas.
    const ReplicaResult all = replicas_summary(replicas);
    write_replica(w, spec, replicas.front(), "", &all);
  } else {
    write_replica(w, spec, replicas.front(), "");
  }
  if (replicas.size() > 1) {
    for (std::size_t k = 0; k < replicas.size(); ++k) {
      write_replica(w, spec, replicas[k], "/replicas/" + std::to_string(k));
    }
  }
  std::vector<std::string> timeseries;
  for (std::size_t k = 0; k < replicas.size(); ++k)
    timeseries.push_back(replicas.size() > 1 ? "/replicas/" + std::to_string(k) + "/timeseries"
                                             : "/timeseries");
  write_checkpoint(w, spec, replicas, timeseries);
}

bool write_run_file(const RunSpec& spec, const std::vector<ReplicaResult>& replicas,
                    const std::string& path) {
  bool complete = !replicas.empty();
  for (const auto& r : replicas)
    complete = complete && r.status.is_finished();
  H5Writer w(complete ? path : path + ".part", ".tmp");
  write_run_layout(w, spec, replicas);
  w.commit();
  return complete;
}

void check_output(const std::string& file, const OutputOptions& output) {
  namespace fs = std::filesystem;
  const auto bad = [&](const std::string& why) {
    throw ConfigError("[output] file = \"" + file + "\" " + why);
  };
  const fs::path p(file);
  if (file.empty() || !p.has_filename() || p.filename() == "." || p.filename() == "..")
    bad("is not a file name; allowed a path to an .h5 file, such as \"run.h5\"");
  std::error_code ec;
  if (fs::is_directory(p, ec))
    bad("is a directory; allowed a path to an .h5 file inside it");
  const fs::path dir = p.has_parent_path() ? p.parent_path() : fs::path(".");
  if (!fs::is_directory(dir, ec))
    bad("is in a directory that does not exist ('" + dir.string() + "'); create it first");
  // Writable, as the run will find it: a probe file is created and removed.
  const fs::path probe = dir / (".jamflow-probe-" + std::to_string(::getpid()));
  {
    std::ofstream f(probe);
    if (!f)
      bad("is in a directory that is not writable ('" + dir.string() + "')");
  }
  fs::remove(probe, ec);
  if (output.continue_from)
    return;  // --resume and --extend replace their own files (checked by the caller)
  if (!output.force && fs::exists(p, ec))
    bad("exists; pass --force to overwrite it, or --extend it");
  if (!output.force && fs::exists(file + ".part", ec))
    bad("has a checkpoint beside it ('" + file + ".part'); continue it with --resume " + file +
        ".part, or pass --force to start over");
}

}  // namespace jamflow
