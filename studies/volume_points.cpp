#include "studies/volume_points.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>

#include <toml++/toml.h>

#include "analysis/soft.hpp"
#include "framework/point_plan.hpp"
#include "lib/config.hpp"
#include "lib/error.hpp"
#include "studies/pressure_points.hpp"

namespace jamflow::studies {

double expected_pressure(double phi, double gdot) {
  const analysis::SoftLaw law;  // the seed's exponents, Table 2 at N -> infinity
  const double p = law.pressure_at(phi, gdot);
  return std::isfinite(p) ? p : 1e-14;
}

std::string volume_sweep_text(const VolumePreset& g) {
  PointPlan plan;
  plan.replicas = g.replicas;
  plan.base_phi = 0.65;
  plan.constant_pressure = false;
  for (const auto n : g.sizes) {
    if (n < 250) {
      throw ConfigError(g.study + " preset " + g.name + ": system.N = " + std::to_string(n) +
                        "; allowed N >= 250 at constant volume");
    }
    for (const double phi : g.phis) {
      for (const double gdot : g.rates) {
        const double p = expected_pressure(phi, gdot);
        PlannedPoint pt;
        pt.n = n;
        pt.phi = phi;
        pt.shear_rate = gdot;
        pt.t_eq = round3(std::max({g.strain_eq / gdot, g.relax_pressure / p, g.t_eq_min}));
        pt.t_av = round3(std::max(g.strain_av / gdot, g.t_av_min));
        pt.sample_every = round3(pt.t_av / g.samples);
        pt.integrator = integrator_for(n, p).settings;
        plan.points.push_back(std::move(pt));
      }
    }
  }
  plan.header = "# The " + g.study + " study's '" + g.name + "' constant-volume points (" + g.why +
                ").\n# Written by `jamflow study`; run by it, or by `jamflow sweep` like any "
                "sweep.\n";
  return sweep_text(plan);
}

}  // namespace jamflow::studies
