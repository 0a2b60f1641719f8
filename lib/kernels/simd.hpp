// The simd backend's view of Highway's run-time dispatch: which instruction-set targets the
// build compiled, which this CPU runs, and a way to pin one (tests, benchmarks, and the
// JAMFLOW_SIMD_TARGET environment variable).
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "lib/kernels/backend.hpp"

namespace jamflow::kernels {

struct SimdTarget {
  std::int64_t bits;  // Highway's target bit
  std::string name;   // e.g. "AVX3", "AVX2", "SSE4", "EMU128"
  bool supported;     // this CPU runs it
  bool vector;        // the pair loop runs four pairs per vector there (256 bits and more)
};

// Every target the build compiled the simd kernel for, best first.
std::vector<SimdTarget> simd_targets();
// The target the next pass dispatches to.
SimdTarget simd_current_target();
// Restricts dispatch to the target named `name` (a ConfigError if it was not compiled or this
// CPU cannot run it); an empty name goes back to the environment's JAMFLOW_SIMD_TARGET, or to
// no restriction. Process-wide; an explicit pin wins over the environment's.
void simd_pin_target(const std::string& name);

std::unique_ptr<ForceBackend> make_simd_backend(double alpha, int threads);

}  // namespace jamflow::kernels
