// Methodology comparison (`jamflow compare`): paired differences of settings against a
// reference, the statistical floor, cost, fluctuation spreads and autocorrelation times, and the
// recommendation (the cheapest stable setting within a stated tolerance). Pure numerics on a
// table of per-replica values: no run files, no scenes.
//
// Replica k of every setting starts from the same prepared state k, so setting and reference
// are paired replica by replica: the error of their difference is measured on the differences
// themselves, which cancels the part of the fluctuations the two runs share.
#pragma once
#include <cstddef>
#include <string>
#include <vector>

#include "lib/statistics.hpp"

namespace jamflow::analysis {

// One observable of one replica of one setting, over its averaging window.
struct ReplicaObservable {
  double mean = 0.0;
  double block_error = 0.0;  // standard error of the mean from the block means
  double block_std = 0.0;    // standard deviation of the block means
  double tau = 0.0;          // integrated autocorrelation time (time units)
  // Block error of (this - reference) from the paired difference series (same sample times);
  // NaN when the grids differ, and then the block errors are combined in quadrature.
  double paired_error = 0.0;
};

struct SettingInput {
  std::string label;
  std::string ensemble;  // the ensemble kind, for the spread ratios
  // Every replica finished and passed the stable verdict; else why not (for the report).
  bool stable = true;
  std::string why_unstable;
  // Every replica passed the steady verdict (no trend over its window): a drifting window's mean
  // is not the steady state's, so such a setting is not recommended either.
  bool steady = true;
  double particles = 0.0;  // N
  // Stopped by its per-run budget ([run] max_force_evaluations): too slow to finish, which is
  // not a failure of stability. Such a setting is not analysed and not listed as unstable.
  bool over_budget = false;
  // Known to be converged (a step or tolerance far finer than the others): its differences from
  // the reference are statistical only. The scatter of the converged settings' means (the
  // reference among them) about their weighted mean measures how far the errors understate the
  // run-to-run scatter; see CompareResult::converged_scatter.
  bool converged = false;
  // Per replica: CPU seconds per tau_0 of simulated time. Empty for a setting that did not run.
  std::vector<double> cpu_per_tau;
  // [observable][replica]; every observable has as many replicas as cpu_per_tau.
  std::vector<std::vector<ReplicaObservable>> observables;
};

struct CompareInput {
  std::vector<std::string> observables;
  std::vector<SettingInput> settings;
  std::size_t reference = 0;
  std::size_t blocks = 20;  // blocks per window (the error of a single replica's block std)
  // A setting is within tolerance if, for every observable, |difference| <= tolerance_sigma x
  // its error, or |difference| <= relative_tolerance[o] x |reference mean| (0: not used).
  double tolerance_sigma = 2.0;
  std::vector<double> relative_tolerance;  // per observable; empty: none
};

// From kMinReplicasForScatter replicas on (lib/statistics.hpp, the rule of every table), the
// error of a difference (and of a mean) is the replica scatter; below, the block errors.

enum class ErrorSource { kNone, kReplicaScatter, kBlocks };
const char* error_source_name(ErrorSource s);  // "replica scatter", "block errors", "none"

struct Estimate {
  double value = 0.0, error = 0.0;
};

struct ObservableResult {
  Estimate mean;        // over replicas, with the error the difference uses (source below)
  Estimate difference;  // mean over replicas of (setting - reference)
  ErrorSource source = ErrorSource::kNone;
  double z = 0.0;      // |difference| / its error (0 for no difference)
  double floor = 0.0;  // the reference's own error: differences below it are not resolved
  // |difference| / floor: the ranking's measure, scale-free across observables.
  double error_in_floors = 0.0;
  bool within = false;
  // Fluctuations: the standard deviation of the block means (mean over replicas) and of the
  // replica means (needs 2 replicas), and each relative to the reference's, with errors.
  Estimate block_std, replica_std, block_std_ratio, replica_std_ratio;
  Estimate tau;  // mean over replicas (error from their scatter; 0 with one replica)
};

struct SettingResult {
  std::string label, ensemble;
  bool ran = false;  // has replicas to analyse
  bool stable = false;
  bool over_budget = false;  // SettingInput::over_budget (then not stable, not in `unstable`)
  std::string why_unstable;
  Estimate cpu_per_tau;           // CPU seconds per tau_0 (mean over replicas)
  Estimate cpu_per_particle_tau;  // the same per particle
  std::vector<ObservableResult> observables;
  bool steady = false;
  bool within = false;                 // stable, steady and within tolerance in every observable
  double worst_error_in_floors = 0.0;  // max over observables of ObservableResult::error_in_floors
  std::size_t rank = 0;  // 1 = smallest worst_error_in_floors; settings that did not run last
};

struct CompareResult {
  std::vector<SettingResult> settings;
  // The cheapest setting (CPU per particle and tau_0) that is within tolerance; -1: none.
  int recommended = -1;
  std::vector<std::size_t> unstable;     // settings that failed (not stable), in input order
  std::vector<std::size_t> over_budget;  // settings stopped by their budget, in input order
  // Per observable: the converged settings' (SettingInput::converged, stable, and the reference)
  // means about their weighted mean. With 2 or more of them and chi2/dof > 1, every error of
  // that observable (means, differences, floors) is multiplied by sqrt(chi2/dof), the rule of
  // the fits (analysis/error_model.hpp), before z, the tolerance and the ranking.
  struct ConvergedScatter {
    int settings = 0;  // how many entered (0 or 1: no scaling)
    double reduced_chi2 = 0.0;
    double error_scale = 1.0;
  };
  std::vector<ConvergedScatter> converged_scatter;
};

// Requires every setting to have the input's observables; throws std::invalid_argument
// otherwise, or when the reference is out of range.
CompareResult compare(const CompareInput& input);

}  // namespace jamflow::analysis
