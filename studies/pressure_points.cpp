#include "studies/pressure_points.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <set>
#include <sstream>
#include <tuple>

#include <toml++/toml.h>

#include "framework/point_plan.hpp"
#include "lib/config.hpp"
#include "lib/error.hpp"
#include "studies/common.hpp"

namespace jamflow::studies {

GridPreset grid_preset(const std::string& preset) {
  GridPreset g;
  g.name = preset;
  if (preset == "quick") {
    g.sizes = {256};
    g.pressures = {3e-3, 1e-3, 3e-4};
    g.js = {1.0, 0.3, 0.1};
    g.replicas = 2;
    g.strain_eq = 1.0;
    g.strain_av = 2.0;
    g.t_eq_min = 100.0;
    g.t_av_min = 200.0;
    g.samples = 200;
    g.why = "the pipeline end to end on N = 256 in about a CPU-minute; not the physics";
  } else if (preset == "standard") {
    // The hard-sphere limit at N = 1000: P = 1e-5 and a guard pressure 3e-5 that shows the
    // envelope is reached (at P >= 3e-4 phi still moved by 0.004-0.005 between pressures), J
    // over 3.5 decades, three replicas, t_eq = t_av = 1/gdot (strain 2 per point), RKC at
    // atol = 0.1 delta (integrator_for).
    g.sizes = {1000};
    g.pressures = {3e-5, 1e-5};
    g.js = {1.0, 0.3, 0.1, 0.03, 0.01, 3e-3, 1e-3, 3e-4};
    g.replicas = 3;
    g.strain_eq = 1.0;
    g.t_av_is_t_eq = true;
    g.why = "N = 1000 at P = 3e-5 and 1e-5, J from 1 to 3e-4, three replicas";
  } else if (preset == "paper") {
    g.sizes = {100, 300, 500, 1000, 3000, 10000};
    g.pressures = {1e-2, 3e-3, 1e-3, 3e-4, 1e-4, 3e-5, 1e-5};
    g.js = {1.0, 0.3, 0.1, 0.03, 0.01, 3e-3, 1e-3, 3e-4, 1e-4, 3e-5, 1e-5};
    g.gdot_min = 3.9e-9;  // the seed's smallest shear rate, 3.98e-9
    g.replicas = 3;
    // With that floor the hard-sphere limit ends at J = 1e-3 (P = 1e-5), 2.5 decades of
    // viscosity: J = 3e-4 remains only at P = 3e-5, which at N = 1000 is outside the limit (the
    // standard results). A ladder at N = 1000 below the seed's floor reaches J = 3e-5 (4
    // decades), each J at two pressures so that the envelope can test it: J = 3e-4 at 1e-5 and
    // 3e-6, J = 1e-4 and 3e-5 at 3e-6 and 1e-6. About 390 of the preset's 2.66e3 CPU-hours.
    g.extensions.push_back({{1000}, {1e-5, 3e-6}, {3e-4}, 0.0});
    g.extensions.push_back({{1000}, {3e-6, 1e-6}, {1e-4, 3e-5}, 0.0});
    g.why =
        "the seed's grid: six sizes, P from 1e-2 to 1e-5, gdot down to 4e-9; and at "
        "N = 1000 a ladder to J = 3e-5 at P = 3e-6 and 1e-6; a cluster";
  } else {
    throw ConfigError("--preset " + preset + "; allowed quick, standard, paper");
  }
  return g;
}

GridPreset finite_size_preset(const std::string& preset) {
  GridPreset g = grid_preset(preset);
  if (preset == "quick") {
    g.sizes = {256, 362, 512, 724};
    g.pressures = {3e-3, 1e-3};
    g.why = "four sizes (the large-N fit needs four) in a few CPU-minutes; not the physics";
  } else if (preset == "standard") {
    // The hard-sphere standard points over N = 100 to 2000 (cost about proportional to N),
    // J down to 1e-3, RKC at atol = 0.1 delta. N = 100 (the seed's smallest size) was added
    // after N = 250-2000 resolved no N-dependence beyond N = 250 being lower: a second small
    // size is the cheapest lever on A_O and alpha_O (about 3% of the preset's cost).
    g.sizes = {100, 250, 500, 1000, 2000};
    g.js = {1.0, 0.3, 0.1, 0.03, 0.01, 3e-3, 1e-3};
    g.why = "N = 100, 250, 500, 1000, 2000 at P = 3e-5 and 1e-5, J from 1 to 1e-3, three replicas";
  } else if (preset == "paper") {
    // The seed's grid without the hard-sphere preset's low-J ladder, which only N = 1000 has:
    // the N -> infinity extrapolation compares sizes fitted over the same J, and a wider window
    // at one size would move its b and C alone.
    g.extensions.clear();
    g.why = "the seed's grid: six sizes, P from 1e-2 to 1e-5, gdot down to 4e-9; a cluster";
  }
  return g;
}

PointIntegrator integrator_for(std::int64_t n, double pressure) {
  if (pressure <= 1e-4) {
    // atol in units of the typical overlap delta = P (alpha_r = 2). At atol = delta the window
    // means agree with Euler's at J >= 1e-3 (benchmarks/README.md), but at J = 3e-4, P = 1e-5
    // (gdot = 3e-9, steps of 400-900 tau_0) the energy balance was 0.88 and 0.90 in two
    // replicas: the stability verdict fails. 0.1 delta costs about 1.8x more per tau_0.
    return {IntegratorSettings("rkc").set("atol", 0.1 * pressure),
            "RKC, atol = 0.1 delta: cheapest near jamming (P <= 1e-4) whose runs pass the "
            "stability verdict"};
  }
  if (n >= 500)
    return {IntegratorSettings("respa").set("dt", 1.0),
            "RESPA, particles inner, dt = 1: stable at N >= 500"};
  if (n >= 250)
    return {IntegratorSettings("respa").set("dt", 0.5),
            "RESPA, particles inner, dt = 0.5: dt = 1 oscillates at N = 250"};
  return {IntegratorSettings("respa").set("dt", 0.1).set("inner", "piston").set("n_inner", 8),
          "RESPA, piston inner (8 sub-steps), dt = 0.1 below N = 250: a stiff piston in a small "
          "box"};
}

std::string pressure_sweep_text(const GridPreset& g) {
  PointPlan plan;
  plan.replicas = g.replicas;
  plan.base_phi = 0.6;
  plan.constant_pressure = true;
  std::vector<GridPreset::Extension> parts{{g.sizes, g.pressures, g.js, g.gdot_min}};
  parts.insert(parts.end(), g.extensions.begin(), g.extensions.end());
  std::set<std::tuple<std::int64_t, double, double>> planned;
  for (const auto& part : parts) {
    for (const auto n : part.sizes) {
      for (const double p : part.pressures) {
        for (const double j : part.js) {
          const double gdot = round3(j * p);  // 9e-05, not 8.999999999999999e-05
          if (gdot < part.gdot_min || !planned.insert({n, p, gdot}).second)
            continue;
          PlannedPoint pt;
          pt.n = n;
          // The start: the seed's hard-sphere law, 0.01 lower and at most 0.63.
          pt.phi = std::round(phi_start(j, n, 0.01, 0.63) * 1e4) / 1e4;
          pt.pressure = p;
          pt.shear_rate = gdot;
          pt.t_eq = round3(std::max({g.strain_eq / gdot, g.relax_pressure / p, g.t_eq_min}));
          pt.t_av = g.t_av_is_t_eq ? pt.t_eq : round3(std::max(g.strain_av / gdot, g.t_av_min));
          pt.sample_every = round3(pt.t_av / g.samples);
          pt.integrator = integrator_for(n, p).settings;
          plan.points.push_back(std::move(pt));
        }
      }
    }
  }
  plan.header = "# The " + g.study + " study's '" + g.name + "' points (" + g.why +
                ").\n# Written by `jamflow study`; run by it, or by `jamflow sweep` like any "
                "sweep.\n";
  return sweep_text(plan);
}

// An integrator as the report names it: the kind and its step ("respa dt 0.5"), RKC by its
// tolerance in units of delta = P. From the table's integrator column (what the point really
// ran), or, in a table collected before that column existed, as the preset chooses it.
std::string integrator_label(const Table& table, std::size_t r) {
  const double pressure = table.number(r, "imposed_pressure");  // NaN at constant volume
  const auto label = [&](const std::string& kind, double dt, double atol) {
    if (kind == "cvode")
      return kind;
    if (kind == "rkc" && !std::isfinite(atol))
      return kind + " (default atol)";
    if (kind == "rkc")
      return kind + " atol=" +
             (std::isfinite(pressure) ? num(atol / pressure, 2) + " delta" : num(atol, 3));
    return kind + " dt " + num(dt, 2);
  };
  if (table.column("integrator") < 0) {
    const IntegratorSettings ic =
        integrator_for(std::int64_t(table.number(r, "N")), pressure).settings;
    return label(ic.kind, ic.number("dt").value_or(0.0), ic.number("atol").value_or(0.0));
  }
  // The column joins key and value, keys sorted: "atol3e-06_kindrkc", "dt0.5_kindrespa".
  const std::string t = table.text(r, "integrator");
  const auto value = [&](const std::string& key) {
    std::size_t at = 0;
    while ((at = t.find(key, at)) != std::string::npos && at > 0 && t[at - 1] != '_')
      ++at;
    return at == std::string::npos ? std::nan("")
                                   : std::strtod(t.c_str() + at + key.size(), nullptr);
  };
  for (const char* kind : {"cvode", "rkc", "respa", "euler"}) {
    if (t.find(std::string("kind") + kind) != std::string::npos)
      return label(kind, value("dt"), value("atol"));
  }
  return t;
}

std::string integrators_line(const Table& table) {
  std::map<std::string, int> counts;
  for (std::size_t r = 0; r < table.rows.size(); ++r)
    ++counts[integrator_label(table, r)];
  std::string out;
  for (const auto& [label, count] : counts)
    out += (out.empty() ? "" : ", ") + label + " (" + std::to_string(count) + ")";
  return out;
}

}  // namespace jamflow::studies
