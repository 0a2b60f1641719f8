// Input data of the analyses (SPEC §5): state-point summaries read from CSV
// tables or from the HDF5 run files written by `jamflow run`.
//
// Two record kinds:
//  - GranularPoint: a constant-pressure state point (N, P, gdot, phi, mu),
//    with the viscous number J = gdot eta_0 / P (eta_0 = 1 in simulation units);
//  - ShearPoint: a flow-curve point (N, phi, gdot, sigma_xy) for the
//    Olsson–Teitel collapse, grouped into curves ("sets").
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "driver/run_summary.hpp"

namespace jamflow::analysis {

// What a point's errors are made of. A mean over replicas has a block error and a replica
// scatter; the scatter is used (where larger) only from 3 replicas on (lib/statistics.hpp
// replica_point_error).
enum class ErrorBasis {
  kGiven,          // a table without a replica count: its errors as given
  kBlockOne,       // one replica: the block error
  kBlockTwo,       // two replicas: the block error; their scatter (1 dof) is not used
  kBlockTwoShort,  // the same, from blocks shorter than 2 tau (not decorrelated): understated
  kScatter,        // 3 replicas or more: the block error or the replica scatter, the larger
  kCollectedMax,   // a table collected before the parts were separate: its errors are the
                   // larger of the block error and the scatter of 2 or more replicas
  kMixed,          // repeats of one state point with different bases, merged
};
const char* error_basis_name(ErrorBasis b);     // "given", "block_1_replica", ...
const char* error_basis_meaning(ErrorBasis b);  // one phrase for a report

struct GranularPoint {
  std::int64_t n = 0;
  double pressure = 0.0;    // imposed P
  double shear_rate = 0.0;  // gdot
  double j = 0.0;           // gdot / P
  double phi = 0.0, phi_err = 0.0;
  double mu = 0.0, mu_err = 0.0;
  std::string source;  // "file:line" or the run file, for messages
  ErrorBasis error_basis = ErrorBasis::kGiven;
  double replicas = 0.0;  // 0: not given
};

struct ShearPoint {
  std::int64_t n = 0;
  double phi = 0.0;
  double shear_rate = 0.0;
  double sigma = 0.0, sigma_err = 0.0;  // sigma_xy
  // The measured pressure (constant volume), 0 when the data do not give it; the soft
  // granular rheology's comparison on the same points needs it.
  double pressure = 0.0, pressure_err = 0.0;
  // Non-empty when the point's verdicts failed and it was admitted anyway
  // (VerdictAdmission::include_failed): why, e.g. "not steady".
  std::string failed_verdicts;
  // The curve the point belongs to: constant volume -> "N=..,phi=..";
  // constant pressure -> "N=..,imposed_pressure=..". The collapse measure never compares a
  // point with its own curve.
  std::string set;
  std::string source;
  ErrorBasis error_basis = ErrorBasis::kGiven;
  double replicas = 0.0;  // 0: not given
};

// How many of the points have each error basis, for the analyses' JSON and reports.
struct PointErrors {
  std::vector<std::pair<ErrorBasis, std::size_t>> counts;  // bases present, in enum order
  std::size_t points = 0;
};
PointErrors point_errors_of(const std::vector<GranularPoint>& points);
PointErrors point_errors_of(const std::vector<ShearPoint>& points);
// One sentence: "Point errors: 20 of 27 points ... ; 7 ...".
std::string describe(const PointErrors& e);

// The /summary group and root attributes of one `jamflow run` output file (the run-file
// module's reader, driver/run_summary.hpp).
using RunSummary = jamflow::RunFileSummary;

// Reads one run file (read_run_file_summary). Throws InputError naming the file
// and the missing or mistyped attribute. libhdf5 runs in a forked child
// process (at most 20 s, at most 4 GiB more address space): a corrupt file on
// which libhdf5 itself crashes, hangs or exhausts memory is an InputError
// too ("FILE: could not be read: the HDF5 library crashed (signal 11, ...)").
RunSummary read_run_summary(const std::string& path);

// Where read_run_summary runs libhdf5. The fuzz target reads in its own
// process, so that libFuzzer sees the reader's coverage and sanitizer reports;
// everything else keeps the default.
enum class Hdf5Isolation { kChildProcess, kInProcess };
void set_hdf5_isolation(Hdf5Isolation isolation);

// True if the file starts with the HDF5 signature.
bool is_hdf5_file(const std::string& path);

// Reads granular (constant-pressure) data from CSV tables with columns
// N,P,gdot,phi,phi_err,mu,mu_err (any order, extra columns ignored) and from
// constant-pressure run files. Repeated state points (same N, P, gdot: the
// independent runs of SPEC §5) are merged by inverse-variance weighting; identical
// records are refused (see merge_repeats).
std::vector<GranularPoint> read_granular(const std::vector<std::string>& paths);

// Reads flow curves for the Olsson–Teitel collapse from CSV tables with
// columns N,phi,gdot,sigma_xy,sigma_xy_err, from granular CSV tables
// (sigma_xy = mu P), and from run files of either ensemble. Repeated points
// (same curve and gdot) are merged by inverse-variance weighting; identical
// records are refused (see merge_repeats).
std::vector<ShearPoint> read_shear(const std::vector<std::string>& paths);

// What read_shear does with the rows of a collected sweep table whose verdicts failed (see
// analysis/README.md): left out by default, with one note on stderr.
struct VerdictAdmission {
  bool include_failed = false;  // keep them, each marked in ShearPoint::failed_verdicts
  std::vector<std::string>* left_out = nullptr;  // receives "file:line: why" per row left out
};
std::vector<ShearPoint> read_shear(const std::vector<std::string>& paths,
                                   const VerdictAdmission& verdicts);

// Whether two paths name the same file: the same file on disk where both exist (any spelling,
// links included), else the same absolute path once normalised.
bool same_file(const std::string& a, const std::string& b);

// Merging used by the readers (exposed for tests). Before merging, the readers refuse a data
// file given twice and two identical records (a row or run file repeated): merged as
// independent repeats they would shrink the error bars. The message names both.
std::vector<GranularPoint> merge_repeats(std::vector<GranularPoint> points);
std::vector<ShearPoint> merge_repeats(std::vector<ShearPoint> points);

}  // namespace jamflow::analysis
