// Stability study (studies/stability): a stable / oscillating / diverged map against the step
// or tolerance on stiff and extreme cases. A comparison plan per preset (quick.toml,
// standard.toml, paper.toml in this folder, one [[case]] per case) run by the compare engine
// (framework/compare.hpp), and this study's own report section, exposed for the tests.
#pragma once
#include <string>
#include <vector>

#include "framework/compare.hpp"

namespace jamflow::studies {

// The study's section, a pure function of the cases' outcomes: per case with an explicit Euler
// scan, the largest stable step and the first unstable one; for the cases that scan RESPA only
// (RESPA with particle sub-steps against N), the verdict table and the size below which each
// step fails, per pressure; each case's diagnostic-window numbers; the conclusions. The same
// numbers go to OUT/stability.h5: /cases/<case> (largest_stable_dt,
// largest_dt_without_oscillation, runs_without_oscillation_left_out, first_unstable_dt,
// first_unstable_verdict, lanes) and /respa_size_thresholds/P=<P>_dt=<dt> (imposed_pressure, dt,
// largest_failing_N, smallest_holding_N, every_size_has_a_verdict; 0: none).
CompareSection stability_section(const std::vector<CompareCaseOutcome>& cases);

}  // namespace jamflow::studies
