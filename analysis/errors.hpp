// Typed exceptions of the analysis module. The CLI maps InputError (bad files,
// bad options, data that cannot support the requested analysis) to exit code 2
// and every other AnalysisError (a fit that does not converge, a singular
// covariance) to exit code 1.
#pragma once

#include <stdexcept>
#include <string>

namespace jamflow::analysis {

class AnalysisError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Malformed input: unreadable file, bad column, bad option value.
class InputError : public AnalysisError {
 public:
  using AnalysisError::AnalysisError;
};

// Well-formed input that cannot support the analysis: too few points for a
// fit, an empty hard-sphere envelope, too few system sizes or pressures.
class InsufficientDataError : public InputError {
 public:
  using InputError::InputError;
};

// A numerical procedure failed: no convergence, singular or non-finite
// covariance, a non-finite result.
class FitError : public AnalysisError {
 public:
  using AnalysisError::AnalysisError;
};

}  // namespace jamflow::analysis
