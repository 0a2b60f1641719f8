// Potential-exponent optimization (studies/softness): the seed's alpha_r study, as a comparison
// plan followed by pressure scans. The plan (studies/softness/<preset>.toml) compares the
// integrator settings at both ends of each alpha_r's overlap range, one [[case]] each; its
// [study] table holds the pressure scans' grid, lengths and the common P -> 0 reference. What is
// exposed here is for the tests: the [study] parameters, the P* rule and the cost to strain 1.
#pragma once
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "framework/compare.hpp"
#include "framework/study.hpp"

namespace jamflow::studies {

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

// ---- The P* rule ------------------------------------------------------------------------------

// A point of a pressure scan: usable = its verdicts let it into the conclusions.
struct ScanValue {
  double pressure = 0.0;
  bool usable = false;
  double mu = 0.0, mu_err = 0.0, phi = 0.0, phi_err = 0.0;
};

struct PStar {
  // Per point (input order): 1 agrees with the reference within `sigmas` combined standard
  // errors in both mu and phi, 0 differs, -1 not usable (not compared).
  std::vector<int> agrees;
  std::vector<double> dmu, dmu_err, dphi, dphi_err;
  int smallest = -1;     // the smallest-P usable point (-1: none)
  bool reached = false;  // it agrees with the reference
  double p_star = std::numeric_limits<double>::quiet_NaN();
  bool p_star_is_smallest = false;  // P* is the smallest usable P, and the next larger differs
  bool p_star_is_largest = false;   // no usable P above P*: the true P* may be larger
  // Points below the smallest usable P that their verdicts left out (e.g. correlated): when the
  // smallest usable P differs, "not reached" is then not established, since a left-out point
  // closer to the limit may agree.
  int left_out_below = 0;
  bool left_out_below_agrees = false;  // one of them agrees, on its (uncertain) errors
};

// P* = the largest P such that every usable point at P' <= P agrees with the reference (mu and
// phi within `sigmas` combined standard errors); undetermined (NaN) when the smallest usable
// point differs: the scan never reached the reference's limit (unless points below it were left
// out by their verdicts: then undetermined).
PStar find_p_star(const std::vector<ScanValue>& points, const ScanValue& reference,
                  double sigmas = 2.0);

// Runs a softness plan (its comparison, then the pressure scans and the common reference) into
// options.out_dir; `jamflow study softness` runs studies/softness/<preset>.toml.
int run_softness_plan(const ComparePlan& plan, const StudyOptions& options);

}  // namespace jamflow::studies
