// Timestep study (studies/timestep): error of steady-state means against CPU time for Euler,
// RESPA, CVODE and RKC at fixed state points. A comparison plan per preset (quick.toml,
// standard.toml, paper.toml in this folder, one [[case]] per state point) run by the compare
// engine (framework/compare.hpp), and this study's own report section, exposed for the tests.
#pragma once
#include <string>
#include <vector>

#include "framework/compare.hpp"

namespace jamflow::studies {

// Accuracy targets: observable ("sigma_xy" relative, "phi" absolute, "pressure" relative,
// "balance" = |energy balance - 1|) and the allowed error.
struct AccuracyTarget {
  std::string observable;
  double value;
};
std::vector<AccuracyTarget> accuracy_targets();

// The study's section of the report, a pure function of the cases' outcomes: per accuracy
// target and case the cheapest usable setting (stable, steady and decorrelated by its
// diagnostic window, error + 2 x error of the difference <= target); the seed's claim on Euler
// and RESPA (particles x 4) at dt = 0.4 ... 1.5; the first unstable Euler step per case.
// The same numbers go to OUT/timestep.h5: /targets/tNN (observable, value, and per case the
// cheapest setting's text) and /cases/<case> (first_unstable_euler_dt; NaN: none in the scan).
CompareSection timestep_section(const std::vector<CompareCaseOutcome>& cases);

}  // namespace jamflow::studies
