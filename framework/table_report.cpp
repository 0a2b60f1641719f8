#include "framework/table_report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>

#include "analysis/admission.hpp"
#include "driver/checkpoint.hpp"
#include "framework/report.hpp"
#include "lib/statistics.hpp"
#include "sweep/execute.hpp"
#include "sweep/plan.hpp"

namespace jamflow::studies {

Table read_table(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec))
    return {};
  return read_csv_table(path);
}

double points_cpu_hours(const std::string& dir, std::size_t* from_wall) {
  namespace fs = std::filesystem;
  double seconds = 0.0;
  std::size_t walls = 0;
  std::error_code ec;
  for (auto it = fs::recursive_directory_iterator(dir, ec);
       !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
    if (it->path().filename() != "sweep.toml")
      continue;
    // Each sweep of a study (a stage, or the study itself) runs into runs/ beside its file.
    try {
      const sweep::Plan plan =
          sweep::load_plan(it->path().string(), (it->path().parent_path() / "runs").string());
      for (const auto& t : plan.tasks()) {
        if (sweep::probe(plan, t) != sweep::TaskState::kDone)
          continue;
        for (const auto& r : read_run_file(plan.task_file(t), false).replicas) {
          seconds += r.cpu_seconds;  // an older file's wall seconds (read_run_file)
          walls += r.cpu_from_wall ? 1 : 0;
        }
      }
    } catch (const std::exception&) {
      // a sweep file that no longer loads, or a run file that cannot be read: nothing to count
    }
  }
  if (from_wall)
    *from_wall = walls;
  return seconds / 3600.0;
}

std::string cost_line(const std::string& dir, double cpu_hours_estimate, double wall_seconds) {
  std::size_t walls = 0;
  const double hours = points_cpu_hours(dir, &walls);
  return "- Cost: " + num(hours, 3) +
         " CPU-hours measured (the runs' CPU seconds, one thread each, summed" +
         (walls > 0 ? "; " + std::to_string(walls) +
                          " run files written before CPU time was recorded count their wall "
                          "seconds"
                    : std::string()) +
         "), against " + num(cpu_hours_estimate, 3) +
         " CPU-hours estimated; this invocation took " + num(wall_seconds / 60.0, 3) +
         " min of wall time (points finished earlier are not rerun).\n\n";
}

double tables_hours(const std::vector<const Table*>& tables, std::size_t* rows_out,
                    std::size_t* from_wall_out) {
  double seconds = 0.0;
  std::size_t rows = 0, from_wall = 0;
  for (const Table* t : tables) {
    for (std::size_t r = 0; r < t->rows.size(); ++r) {
      const double cpu = t->number(r, "cpu_seconds");
      const bool wall = !std::isfinite(cpu) || t->number(r, "cpu_from_wall") > 0.5;
      const double v = std::isfinite(cpu) ? cpu : t->number(r, "wall_seconds");
      if (!std::isfinite(v))
        continue;
      seconds += v;
      ++rows;
      from_wall += wall ? 1 : 0;
    }
  }
  if (rows_out)
    *rows_out = rows;
  if (from_wall_out)
    *from_wall_out = from_wall;
  return seconds / 3600.0;
}

std::string cost_line_from_tables(const std::vector<const Table*>& tables,
                                  double cpu_hours_estimate) {
  std::size_t rows = 0, from_wall = 0;
  const double hours = tables_hours(tables, &rows, &from_wall);
  const bool all_wall = from_wall == rows;
  return "- Cost: " + num(hours, 3) + (all_wall ? " hours" : " CPU-hours") + " measured over the " +
         std::to_string(rows) + " finished points (" +
         (all_wall ? "the tables' wall seconds of each replica on one thread, summed: the tables "
                     "were collected before CPU time was recorded"
                   : "the tables' CPU seconds, one thread per replica, summed" +
                         (from_wall > 0 ? "; " + std::to_string(from_wall) +
                                              " points give their wall seconds, recorded before "
                                              "CPU time was"
                                        : std::string())) +
         "), against " + num(cpu_hours_estimate, 3) +
         " CPU-hours that the current cost model estimates for the same points (the report "
         "was rebuilt from the tables, nothing was run).\n\n";
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream os;
  os << in.rdbuf();
  return os.str();
}

analysis::Json read_analysis(const std::string& study, const std::string& json_path) {
  if (!std::filesystem::exists(json_path))
    return analysis::Json::object();
  try {
    return analysis::Json::parse(read_file(json_path));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: warning: cannot read %s: %s\n", study.c_str(), json_path.c_str(),
                 e.what());
    return analysis::Json::object();
  }
}

double number_of(const analysis::Json& j, const std::string& key, double fallback) {
  return j.is_object() && j.contains(key) && j.at(key).is_number() ? j.at(key).as_number()
                                                                   : fallback;
}

bool measured(const analysis::Json& j, const std::string& key, double& v, double& e) {
  if (!j.is_object() || !j.contains(key))
    return false;
  const auto& m = j.at(key);
  if (!m.is_object() || !m.contains("value") || !m.at("value").is_number())
    return false;
  v = m.at("value").as_number();
  e = number_of(m, "error");
  return true;
}

double systematic_of(const analysis::Json& j, const std::string& key) {
  if (!j.is_object() || !j.contains(key) || !j.at(key).is_object())
    return std::nan("");
  return number_of(j.at(key), "systematic");
}

std::string with_systematic(double v, double e, double sys) {
  return pm(v, e) + (std::isfinite(sys) ? " ± " + num(sys, 2) + " (systematic)" : "");
}

std::string sigma_text(double ours, double err, double seed) {
  if (!(err > 0.0) || !std::isfinite(ours))
    return "n/a";
  const double z = (ours - seed) / err;
  char buf[64];
  std::snprintf(buf, sizeof buf, "%+.1f sigma%s", z, std::fabs(z) > 2.0 ? " (disagrees)" : "");
  return buf;
}

std::string sigma_text(double ours, double err, double sys, double seed) {
  return sigma_text(ours, std::hypot(err, std::isfinite(sys) ? sys : 0.0), seed);
}

namespace {

// What a kept row's error is, as analysis/data.cpp reads it: the replica scatter from 3
// replicas (or from 2 in a table collected before the error parts were separate), else the
// block error of 2 replicas, which blocks this short understate.
std::string kept_label(const Table& table, std::size_t r) {
  const double k = table.number(r, "replicas");
  const bool scatter = table.column("phi_block_err") >= 0 ? replica_scatter_used(k) : k >= 2.0;
  return scatter ? "kept: replica-scatter errors"
                 : "kept: block errors of 2 replicas (understated: blocks shorter than 2 tau)";
}

}  // namespace

std::string sweep_cost_markdown(const Table& table, const SweepStudy& run,
                                const RowLabel& integrator_label, bool* has_cost) {
  if (has_cost)
    *has_cost = false;
  struct Cost {
    int points = 0;
    double seconds = 0.0, particle_evaluations = 0.0, particle_time = 0.0;
    double estimated_seconds = 0.0;  // the sweep's estimate (sweep::estimate_cost) of them
  };
  std::map<std::string, double> estimated_per_point;  // point name -> estimated CPU seconds
  for (const auto& t : run.plan.tasks())              // Task::cost is in CPU seconds
    estimated_per_point[run.plan.points[t.point].name] += t.cost;
  std::map<std::string, Cost> by_kind;
  Cost all;
  std::string slowest;
  double slowest_seconds = 0.0;
  const bool has_cpu = table.column("cpu_seconds") >= 0;
  const bool has_equivalents = table.column("force_pass_equivalents") >= 0;
  std::size_t from_wall = 0;
  for (std::size_t r = 0; r < table.rows.size(); ++r) {
    const double n = table.number(r, "N");
    const double wall = table.number(r, has_cpu ? "cpu_seconds" : "wall_seconds");
    const double evals =
        table.number(r, has_equivalents ? "force_pass_equivalents" : "force_evaluations");
    if (!(wall > 0.0) || !(evals > 0.0))
      continue;
    from_wall += !has_cpu || table.number(r, "cpu_from_wall") > 0.5 ? 1 : 0;
    const double reps = std::max(1.0, table.number(r, "replicas"));
    const double t = table.number(r, "run.t_eq") + table.number(r, "run.t_av");
    for (Cost* c : {&by_kind[integrator_label(table, r)], &all}) {
      ++c->points;
      c->estimated_seconds += estimated_per_point[table.text(r, "point")];
      c->seconds += wall;
      c->particle_evaluations += n * evals;
      c->particle_time += std::isfinite(t) ? n * t * reps : 0.0;
    }
    if (wall > slowest_seconds) {
      slowest_seconds = wall;
      slowest = table.text(r, "point");
    }
  }
  std::ostringstream md;
  md << "\n## Cost\n\n";
  if (all.points == 0) {
    md << "The table has no cost columns (collected before they existed).\n";
    return md.str();
  }
  if (has_cost)
    *has_cost = true;
  std::vector<std::vector<std::string>> rows;
  auto row = [&](const std::string& name, const Cost& c) {
    rows.push_back({name, std::to_string(c.points), num(c.seconds / 3600.0, 3),
                    num(1e9 * c.seconds / c.particle_evaluations, 3),
                    c.particle_time > 0.0 ? num(c.particle_evaluations / c.particle_time, 3) : "-",
                    c.particle_time > 0.0 ? num(1e9 * c.seconds / c.particle_time, 3) : "-"});
  };
  for (const auto& [kind, c] : by_kind)
    row(kind, c);
  row("all", all);
  md << "Measured from the point files: CPU time of each replica on one thread, on a 2-core "
        "machine shared with other work; force evaluations are force-pass equivalents (CVODE's "
        "Jacobian work included)";
  if (from_wall > 0)
    md << "; " << from_wall
       << " points' files were written before CPU time (or force-pass equivalents) was "
          "recorded and give their wall time (and force evaluations) instead";
  md << ".\n\n"
     << markdown_table({"integrator", "points", "CPU hours", "ns per particle force evaluation",
                        "force evaluations per tau_0", "ns per particle per tau_0"},
                       rows);
  // Which integrator was cheaper here, from these numbers only (and only when more than one
  // ran: the points of different integrators are at different state points, so this compares
  // their costs where each ran, not at equal accuracy).
  if (by_kind.size() > 1) {
    std::string cheapest;
    double best = 0.0;
    for (const auto& [kind, c] : by_kind) {
      if (c.particle_time <= 0.0)
        continue;
      const double v = 1e9 * c.seconds / c.particle_time;
      if (cheapest.empty() || v < best) {
        cheapest = kind;
        best = v;
      }
    }
    if (!cheapest.empty())
      md << "\nPer particle and tau_0, " << cheapest << " cost least here (" << num(best, 3)
         << " ns), over the points it ran (the integrators ran different state points).\n";
  }
  md << "\nThe most expensive point: " << slowest << ", " << num(slowest_seconds, 3)
     << " CPU seconds over its replicas. The cost model (each integrator's measured CPU time "
        "per particle and tau_0) estimates "
     << num(run.cpu_hours_estimate, 3) << " CPU-hours for the sweep's " << run.plan.points.size()
     << " points";
  if (all.estimated_seconds > 0.0 && all.seconds > 0.0)
    md << "; the " << all.points << " finished points took "
       << num(all.seconds / all.estimated_seconds, 2) << " times their estimate ("
       << num(all.estimated_seconds / 3600.0, 3) << " CPU-hours)";
  md << ".\n";
  return md.str();
}

std::vector<std::vector<std::string>> flagged_rows(const Table& table) {
  std::vector<std::vector<std::string>> flagged;
  for (std::size_t r = 0; r < table.rows.size(); ++r) {
    auto verdict = [&](const char* name) -> std::optional<bool> {
      const double v = table.number(r, name);
      return v == 0.0 || v == 1.0 ? std::optional<bool>(v == 1.0) : std::nullopt;
    };
    const analysis::Admission a =
        analysis::admit({verdict("steady"), verdict("stable"), verdict("decorrelated"),
                         table.number(r, "replicas")});
    std::string why;
    for (const char* v : {"steady", "stable", "decorrelated"}) {
      if (verdict(v) == false)
        why.append(why.empty() ? "" : ", ").append("not ").append(v);
    }
    if (!why.empty()) {
      flagged.push_back({table.text(r, "point"), why,
                         a.admitted ? kept_label(table, r) : std::string("left out")});
    }
  }
  return flagged;
}

std::string verdicts_markdown(const Table& table, const std::string& what) {
  std::ostringstream md;
  const auto flagged = flagged_rows(table);
  if (flagged.empty()) {
    md << "Every " << what << " point is steady, stable and decorrelated in every replica.\n\n";
    return md.str();
  }
  std::size_t left = 0;
  for (const auto& f : flagged)
    left += f[2].rfind("left out", 0) == 0;
  if (left == 0)
    md << "No " << what << " point is left out of the analysis (none is unsteady or unstable).";
  else
    md << left << " of " << table.rows.size() << " " << what
       << " points are left out of the analysis (not steady or not stable in some replica, "
          "or not decorrelated with one replica).";
  md << " A point whose blocks are shorter than 2 tau (not decorrelated) is kept when it has "
        "several replicas: from 3 its error bars include the scatter of independent replicas; "
        "with 2 they are the block errors, which such short blocks understate (a table collected "
        "before the block error and the scatter were separate columns holds the scatter of 2; "
        "analysis/README.md).\n\n";
  // The left-out points by name; the kept ones counted.
  std::vector<std::vector<std::string>> listed;
  for (const auto& f : flagged) {
    if (f[2].rfind("left out", 0) == 0)
      listed.push_back(f);
  }
  if (!listed.empty())
    md << markdown_table({"point", "verdict", "used"}, listed) << "\n";
  if (flagged.size() > listed.size())
    md << flagged.size() - listed.size()
       << " more are not decorrelated and are kept (table.csv, column decorrelated; their errors "
          "as said above).\n\n";
  return md.str();
}

}  // namespace jamflow::studies
