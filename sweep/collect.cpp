#include "sweep/collect.hpp"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "driver/checkpoint.hpp"
#include "driver/run.hpp"
#include "lib/error.hpp"
#include "lib/names.hpp"
#include "lib/statistics.hpp"
#include "lib/table.hpp"
#include "sweep/execute.hpp"

namespace jamflow::sweep {
namespace fs = std::filesystem;

namespace {

std::string cell(double v) {
  if (std::isnan(v))
    return "";
  return fmt(v);
}

}  // namespace

namespace {

// The table of collect (all_points false: the points complete in every replica) or of
// point_table (every point, and the status column).
PointTable build_table(const Plan& plan, bool all_points) {
  PointTable out;
  const auto tasks = plan.tasks();
  std::vector<std::vector<const Task*>> of_point(plan.points.size());
  for (const auto& t : tasks)
    of_point[t.point].push_back(&t);

  struct Row {
    const Point* point;
    RunSpec spec;
    Summary sum;
    // Summed over replicas: the cost. cpu_from_wall: some replica's file was written before
    // CPU time was recorded, and its wall seconds stand in.
    double wall_seconds = 0.0, cpu_seconds = 0.0, force_evaluations = 0.0, equivalents = 0.0;
    bool cpu_from_wall = false;
    // Complete, or the status of the first replica that is not (then no results).
    RunStatus status = RunStatus::complete();
  };
  std::vector<Row> rows;
  bool all_cp = true;
  for (const auto& p : plan.points) {
    auto& ts = of_point[p.index];
    std::sort(ts.begin(), ts.end(), [](auto a, auto b) { return a->replica < b->replica; });
    std::vector<Summary> sums;
    double wall = 0.0, cpu = 0.0, evaluations = 0.0, equivalents = 0.0;  // summed: the cost
    bool cpu_from_wall = false;
    std::string why;
    RunStatus point_status = RunStatus::complete();
    for (const Task* t : ts) {
      RunStatus status = RunStatus::not_run();
      const TaskState s = probe(plan, *t, &status);
      const std::string detail = status.kind == RunStatus::Kind::kNotRun ? "" : status.text();
      if (s != TaskState::kDone || !status.is_complete()) {
        why = std::string("r")
                  .append(std::to_string(t->replica))
                  .append(" ")
                  .append(s == TaskState::kDone ? "finished without a summary" : state_name(s));
        if (!detail.empty())
          why.append(" (").append(detail).append(")");
        point_status = status;
        break;
      }
      const ReplicaResult res = read_run_file(plan.task_file(*t), false).replicas.front();
      sums.push_back(res.summary);
      wall += res.wall_seconds;
      cpu += res.cpu_seconds;
      cpu_from_wall = cpu_from_wall || res.cpu_from_wall;
      const double passes = statistic(res.integrator_stats, "force_evaluations");
      evaluations += passes;
      // A file written before force-pass equivalents were recorded: its force passes.
      equivalents += statistic(res.integrator_stats, "force_pass_equivalents", passes);
    }
    if (!why.empty()) {
      out.left_out.push_back(p.name + ": " + why);
      if (!all_points)
        continue;
      Row row{&p, parse_run_spec(plan.task_scene(*ts.front())), {}};
      row.status = point_status;
      all_cp = all_cp && row.spec.ensemble->imposed_pressure().has_value();
      rows.push_back(std::move(row));
      continue;
    }
    Row row{&p, parse_run_spec(plan.task_scene(*ts.front())), {}};
    row.wall_seconds = wall;
    row.cpu_seconds = cpu;
    row.cpu_from_wall = cpu_from_wall;
    row.force_evaluations = evaluations;
    row.equivalents = equivalents;
    row.sum = sums.size() > 1 ? combine_replicas(sums) : sums.front();
    all_cp = all_cp && row.spec.ensemble->imposed_pressure().has_value();
    rows.push_back(std::move(row));
  }

  // The varied keys, less those whose quantity has its own column under its one name
  // (lib/names.hpp): shear.rate is shear_rate, ensemble.pressure imposed_pressure.
  const bool pressure_column = all_cp && !rows.empty();
  auto own_column = [&](const std::string& key) {
    return key == "shear.rate" || (key == "ensemble.pressure" && pressure_column);
  };
  std::vector<std::string> header = {"point"};
  for (const auto& a : plan.axes) {
    if (!own_column(a))
      header.push_back(a);
  }
  for (const char* c : {"ensemble", "N"})
    header.push_back(c);
  if (pressure_column)
    header.emplace_back(names::kImposedPressure);
  const std::vector<std::string> observables = {"phi", "pressure", "sigma_xy", "eta", "mu"};
  header.emplace_back(names::kShearRate);
  for (const auto& o : observables) {
    header.push_back(o);
    header.push_back(o + "_err");
  }
  for (const char* c :
       {"J", "energy_balance", "replicas", "steady", "stable", "decorrelated", "wall_seconds",
        "cpu_seconds", "cpu_from_wall", "force_evaluations", "force_pass_equivalents", "folder"})
    header.push_back(c);
  // The two parts of each error, after every older column so that readers by position still
  // work: <o>_err above is the block error, or the replica scatter where it is larger and there
  // are at least 3 replicas (lib/statistics.hpp replica_point_error); <o>_block_err is the
  // block error of the mean over replicas and <o>_replica_err the replica scatter's (empty with
  // one replica).
  for (const auto& o : observables) {
    header.push_back(o + "_block_err");
    header.push_back(o + "_replica_err");
  }
  if (all_points)
    header.push_back("status");

  std::vector<std::vector<std::string>>& table = out.rows;
  for (const auto& row : rows) {
    const bool complete = row.status.is_complete();
    const Summary& sum = row.sum;
    const double nan = std::nan("");
    const bool several = sum.replicas.value_or(1.0) > 1.5;
    // The observables of the table, in its order.
    const std::optional<Estimate> estimates[] = {sum.phi, sum.pressure, sum.sigma_xy, sum.eta,
                                                 sum.mu};
    std::vector<std::string> cells = {row.point->name};
    for (const auto& [k, val] : row.point->values) {
      if (!own_column(k))
        cells.push_back(csv_cell(val));
    }
    cells.push_back(row.spec.ensemble->name());
    cells.push_back(std::to_string(row.point->n));
    if (all_cp)
      cells.push_back(fmt(*row.spec.ensemble->imposed_pressure()));
    cells.push_back(fmt(row.spec.shear_rate));
    const double replicas = several ? *sum.replicas : 1.0;
    for (const auto& e : estimates) {
      const Estimate x = e.value_or(Estimate{});
      cells.push_back(cell(x.value));
      cells.push_back(cell(replica_point_error(x.err, x.replica_err.value_or(nan), replicas)));
    }
    cells.push_back(cell(sum.J.value_or(nan)));
    cells.push_back(cell(sum.computed ? sum.energy_balance : nan));
    cells.push_back(!complete ? "" : std::to_string(static_cast<long long>(replicas)));
    for (const Verdict* v : {&sum.steady, &sum.stable, &sum.decorrelated})
      cells.push_back(cell(sum.computed ? v->value() : nan));
    const double none = std::nan("");  // the cost of a point without results: not summed
    cells.push_back(cell(complete ? row.wall_seconds : none));
    cells.push_back(cell(complete ? row.cpu_seconds : none));
    cells.push_back(!complete ? "" : row.cpu_from_wall ? "1" : "0");
    cells.push_back(cell(complete ? row.force_evaluations : none));
    cells.push_back(cell(complete ? row.equivalents : none));
    cells.push_back(csv_cell(fs::relative(plan.point_dir(*row.point), plan.out_dir).string()));
    for (const auto& e : estimates) {
      const Estimate x = e.value_or(Estimate{});
      cells.push_back(cell(x.err));
      cells.push_back(cell(several ? x.replica_err.value_or(nan) : nan));
    }
    if (all_points)
      cells.push_back(row.status.text());
    out.status.push_back(row.status);
    table.push_back(std::move(cells));
  }
  out.header = std::move(header);
  return out;
}

}  // namespace

PointTable point_table(const Plan& plan) {
  return build_table(plan, true);
}

Collected collect(const Plan& plan, const std::string& path) {
  const std::string ext = fs::path(path).extension().string();
  if (ext != ".csv" && ext != ".h5")
    throw ConfigError("--collect '" + path + "': allowed a table file ending in .csv or .h5");
  const PointTable t = build_table(plan, false);
  const auto& header = t.header;
  const auto& table = t.rows;
  if (ext == ".csv") {
    write_csv_table(path, header, table);
  } else {
    write_h5_table(path, header, table);
  }
  Collected out;
  out.rows = table.size();
  out.left_out = t.left_out;
  return out;
}

}  // namespace jamflow::sweep
