// Potential-exponent optimization (studies/softness): the seed's alpha_r study. Presets, the
// common hard-sphere reference, the P* rule and the cost model, exposed for the tests.
#pragma once
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "studies/diagnostics.hpp"
#include "studies/study.hpp"

namespace jamflow::studies {

struct SoftnessPreset {
  std::string name;
  std::int64_t n = 150;
  std::vector<double> alphas;
  // Typical overlaps delta; the pressure grid of alpha_r is P = delta^(alpha_r - 1), since the
  // contact force is delta^(alpha_r - 1) (SPEC §1). Grid points with P < p_min are not run (the
  // runs last t >= relax_pressure / P): the range of an alpha_r is its deltas with P >= p_min.
  std::vector<double> deltas;
  double p_min = 0.0;
  std::vector<double> targets_j;  // viscous numbers J = gdot / P
  // Phase A (the fastest stable integrator): at both ends of each alpha_r's overlap range,
  // J = targets_j.front(), every setting run t_scan long from one prepared state: explicit
  // Euler at scan_dts, RESPA with the particles on the inner level (respa_inner Euler
  // sub-steps) at the outer steps respa_dts, CVODE at cvode_tols (atol = rtol x delta), RKC at
  // atol = rkc_overlaps x delta (its default rtol).
  std::vector<double> scan_dts;
  int respa_inner = 4;
  std::vector<double> respa_dts;
  std::vector<double> cvode_tols;
  std::vector<double> rkc_overlaps;
  long cvode_max_steps = 0;  // CVODE steps per sample interval (0: CVODE's default)
  // Preparation from a random state at the hard-sphere law's phi: max(t_prep, strain_prep /
  // gdot, relax_pressure / P), so that the scans start relaxed.
  double t_prep = 300.0, strain_prep = 0.05, t_scan = 500.0;
  double mu_tolerance = 0.01, phi_tolerance = 1e-3;  // "accurate" (plus 2x paired floor)
  // Phase B (pressure scan) durations: t_eq = max(t_min, strain_eq / gdot, relax_pressure / P),
  // t_av = max(t_min, strain_av / gdot, average_pressure / P): a constant-pressure run relaxes
  // on the time scale xi_s a / P (studies/pressure_points.hpp), and its correlation times
  // grow the same way, so blocks of average_pressure / (20 P).
  double strain_eq = 0.1, strain_av = 0.5, t_min = 1000.0;
  double relax_pressure = 5.0, average_pressure = 20.0;
  // The common P -> 0 reference, one per target J: alpha_r = 2 at p_reference (far below the
  // grid), CVODE at reference_rtol (CVODE's default atol), reference_replicas independent
  // replicas, t_eq = max(relax_pressure / P, strain_eq / gdot) and t_av = max(
  // reference_average / P, strain_av / gdot); never cut by the budget.
  double p_reference = 1e-5;
  double reference_rtol = 1e-5;
  double reference_average = 30.0;
  int reference_replicas = 2;
  // Particle-steps (N x force evaluations) allowed per run (0: none); over it a run is
  // "incomplete". 3.75e8 is about 15 s of one core (40 ns each).
  double budget_particle_steps = 0.0;
};

SoftnessPreset softness_preset(const std::string& name);  // quick | standard | paper

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

// ---- Dry-run estimate -----------------------------------------------------------------------

// CPU-hours of each stage from a cost model (studies/softness/README.md "Presets"): Euler and
// RESPA at a measured time per particle force evaluation, CVODE at a measured time per
// particle per tau_0 that falls with P; the pressure scans with the cheaper of CVODE and
// Euler at the largest step found stable in earlier scans. An estimate for planning only.
struct SoftnessEstimate {
  double prep = 0.0, scan = 0.0, pscan = 0.0, reference = 0.0;
  std::size_t runs = 0;
  double total() const { return prep + scan + pscan + reference; }
};
SoftnessEstimate estimate_softness(const SoftnessPreset& preset);

int run_softness(const StudyOptions& options);
int run_softness_preset(const SoftnessPreset& preset, const StudyOptions& options);

}  // namespace jamflow::studies
