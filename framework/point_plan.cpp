#include "framework/point_plan.hpp"

#include <cstdio>
#include <cstdlib>
#include <sstream>

#include <toml++/toml.h>

#include "studies/common.hpp"

namespace jamflow::studies {

double round3(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", x);
  return std::strtod(buf, nullptr);
}

std::string sweep_text(const PointPlan& plan) {
  toml::array n_axis, phi_axis, p_axis, rate_axis, teq_axis, tav_axis, sample_axis, integ_axis;
  for (const PlannedPoint& p : plan.points) {
    n_axis.push_back(p.n);
    phi_axis.push_back(p.phi);
    if (plan.constant_pressure)
      p_axis.push_back(p.pressure.value_or(0.0));
    rate_axis.push_back(p.shear_rate);
    teq_axis.push_back(p.t_eq);
    tav_axis.push_back(p.t_av);
    sample_axis.push_back(p.sample_every);
    integ_axis.push_back(p.integrator.table());
  }
  toml::table zip;
  zip.insert("system.N", n_axis);
  zip.insert("system.phi", phi_axis);
  if (plan.constant_pressure)
    zip.insert("ensemble.pressure", p_axis);
  zip.insert("shear.rate", rate_axis);
  zip.insert("run.t_eq", teq_axis);
  zip.insert("run.t_av", tav_axis);
  zip.insert("run.sample_every", sample_axis);
  zip.insert("integrator", integ_axis);
  // The base scene: what every point shares (the zip replaces the rest).
  toml::table scene{
      {"system", toml::table{{"N", 1000}, {"phi", plan.base_phi}, {"alpha", 2.0}, {"seed", 1}}},
      {"ensemble",
       plan.constant_pressure
           ? toml::table{{"kind", "constant_pressure"}, {"pressure", 1e-3}, {"xi_V", 1e-4}}
           : toml::table{{"kind", "constant_volume"}}},
      {"shear", toml::table{{"rate", 1e-4}}},
      {"integrator", toml::table{{"kind", "respa"}, {"dt", 1.0}}},
      {"run", toml::table{{"t_eq", 1000.0},
                          {"t_av", 3000.0},
                          {"sample_every", 3.0},
                          {"round_sample_every", true},
                          {"blocks", 20}}},
      {"output", toml::table{{"checkpoint_every", 300.0}}}};
  toml::table sweep{
      {"replicas", plan.replicas},
      {"names_from",
       toml::array{"system.N", plan.constant_pressure ? "ensemble.pressure" : "system.phi",
                   "shear.rate"}},
      {"zip", std::move(zip)}};
  toml::table root{{"sweep", std::move(sweep)}, {"scene", std::move(scene)}};
  std::ostringstream os;
  os << plan.header << toml_text(root) << "\n";
  return os.str();
}

}  // namespace jamflow::studies
