// Potential-exponent optimization (studies/softness): the seed's alpha_r study, as a comparison
// plan followed by pressure scans. The plan (studies/softness/<preset>.toml) compares the
// integrator settings at both ends of each alpha_r's overlap range, one [[case]] each; its
// [study] table holds the pressure scans' grid, lengths and the common P -> 0 reference. What is
// exposed here is for the tests: the [study] parameters and the cost to strain 1; the P* rule is
// analysis/p_star.hpp.
#pragma once
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "analysis/p_star.hpp"
#include "framework/compare.hpp"
#include "framework/study.hpp"

namespace jamflow::studies {

using analysis::find_p_star;
using analysis::PStar;
using analysis::ScanValue;

// The [study] table of a softness plan. The pressure grid of alpha_r is P = delta^(alpha_r - 1)
// over the typical overlaps `deltas` (the contact force is delta^(alpha_r - 1), SPEC §1), without
// the points below p_min. The cases of the plan are the ends of each alpha_r's range at J =
// targets_j.front().
struct SoftnessParameters {
  std::vector<double> targets_j;  // viscous numbers J = gdot / P
  std::vector<double> deltas;
  double p_min = 0.0;
  // "Accurate" against the case's reference: |d mu| / mu <= mu_tolerance and |d phi| <=
  // phi_tolerance, each plus 2x the paired error of the difference.
  double mu_tolerance = 0.01, phi_tolerance = 1e-3;
  // Pressure-scan lengths: t_eq = max(t_min, strain_eq / gdot, relax_pressure / P), t_av =
  // max(t_min, strain_av / gdot, average_pressure / P) (a constant-pressure run relaxes on the
  // time scale xi_s a / P, studies/pressure_points.hpp, and its correlation times grow alike).
  double strain_eq = 0.1, strain_av = 0.5, t_min = 1000.0;
  double relax_pressure = 5.0, average_pressure = 20.0;
  // The common P -> 0 reference, one per J: alpha_r = 2 at p_reference, CVODE at reference_rtol
  // (its default atol), reference_replicas replicas, t_eq = max(relax_pressure / P, strain_eq /
  // gdot), t_av = max(reference_average / P, strain_av / gdot); never cut by a budget.
  double p_reference = 1e-5, reference_rtol = 1e-5, reference_average = 40.0;
  std::int64_t reference_replicas = 2;
};

// Reads a plan's [study] table; a missing or bad key is one ConfigError line naming it.
SoftnessParameters softness_parameters(const ComparePlan& plan);

// Particle-steps per particle to shear to strain 1 (t = 1 / gdot, gdot = J P) with step dt.
double steps_per_particle(double j, double pressure, double dt);
// The cost to shear to strain 1 at (J, P) from a cost per unit time (seconds or force
// evaluations per tau_0): per_tau / (J P).
double cost_to_strain_one(double per_tau, double j, double pressure);

// Runs a softness plan (its comparison, then the pressure scans and the common reference) into
// options.out_dir; `jamflow study softness` runs studies/softness/<preset>.toml.
int run_softness_plan(const ComparePlan& plan, const StudyOptions& options);

}  // namespace jamflow::studies
