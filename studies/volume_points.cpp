#include "studies/volume_points.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>

#include <toml++/toml.h>

#include "analysis/soft.hpp"
#include "lib/config.hpp"
#include "lib/error.hpp"
#include "studies/pressure_points.hpp"

namespace jamflow::studies {

namespace {

double round3(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", x);
  return std::strtod(buf, nullptr);
}

}  // namespace

double expected_pressure(double phi, double gdot) {
  const analysis::SoftLaw law;  // the seed's exponents, Table 2 at N -> infinity
  const double p = law.pressure_at(phi, gdot);
  return std::isfinite(p) ? p : 1e-14;
}

std::string volume_sweep_text(const VolumePreset& g) {
  toml::array n_axis, phi_axis, rate_axis, teq_axis, tav_axis, sample_axis, integ_axis;
  for (const auto n : g.sizes) {
    if (n < 250) {
      throw ConfigError(g.study + " preset " + g.name + ": system.N = " + std::to_string(n) +
                        "; allowed N >= 250 at constant volume");
    }
    for (const double phi : g.phis) {
      for (const double gdot : g.rates) {
        const double p = expected_pressure(phi, gdot);
        const double t_eq =
            round3(std::max({g.strain_eq / gdot, g.relax_pressure / p, g.t_eq_min}));
        const double t_av = round3(std::max(g.strain_av / gdot, g.t_av_min));
        n_axis.push_back(n);
        phi_axis.push_back(phi);
        rate_axis.push_back(gdot);
        teq_axis.push_back(t_eq);
        tav_axis.push_back(t_av);
        sample_axis.push_back(round3(t_av / g.samples));
        integ_axis.push_back(integrator_for(n, p).settings.table());
      }
    }
  }
  toml::table zip;
  zip.insert("system.N", n_axis);
  zip.insert("system.phi", phi_axis);
  zip.insert("shear.rate", rate_axis);
  zip.insert("run.t_eq", teq_axis);
  zip.insert("run.t_av", tav_axis);
  zip.insert("run.sample_every", sample_axis);
  zip.insert("integrator", integ_axis);
  toml::table scene{
      {"system", toml::table{{"N", 1000}, {"phi", 0.65}, {"alpha", 2.0}, {"seed", 1}}},
      {"ensemble", toml::table{{"kind", "constant_volume"}}},
      {"shear", toml::table{{"rate", 1e-4}}},
      {"integrator", toml::table{{"kind", "respa"}, {"dt", 1.0}}},
      {"run", toml::table{{"t_eq", 1000.0},
                          {"t_av", 3000.0},
                          {"sample_every", 3.0},
                          {"round_sample_every", true},
                          {"blocks", 20}}},
      {"output", toml::table{{"checkpoint_every", 300.0}}}};
  toml::table sweep{{"replicas", g.replicas},
                    {"names_from", toml::array{"system.N", "system.phi", "shear.rate"}},
                    {"zip", std::move(zip)}};
  toml::table root{{"sweep", std::move(sweep)}, {"scene", std::move(scene)}};
  std::ostringstream os;
  os << "# The " << g.study << " study's '" << g.name << "' constant-volume points (" << g.why
     << ").\n# Written by `jamflow study`; run by it, or by `jamflow sweep` like any sweep.\n"
     << toml_text(root) << "\n";
  return os.str();
}

}  // namespace jamflow::studies
