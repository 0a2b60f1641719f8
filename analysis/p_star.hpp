// The P* rule of the softness study (studies/softness): along a pressure scan at one viscous
// number J, the largest pressure at which the soft-sphere values mu and phi still agree with a
// common P -> 0 (hard-sphere) reference, within their combined standard errors. Pure numerics on
// the scan's values.
#pragma once
#include <limits>
#include <vector>

namespace jamflow::analysis {

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

}  // namespace jamflow::analysis
