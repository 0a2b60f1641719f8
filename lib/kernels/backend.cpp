// The reference backend and the choice of backend.
#include "lib/kernels/backend.hpp"

#include <cmath>
#include <cstdlib>
#include <string>

#include "lib/error.hpp"
#include "lib/kernels/reference.hpp"
#include "lib/kernels/simd.hpp"
#include "lib/potential.hpp"

namespace jamflow {
namespace kernels {

std::unique_ptr<ForceBackend> make_portable_backend(double alpha, int threads);

namespace {

void apply_drift(State& state, const ForceResult& out, const Drift& drift) {
  const std::size_t n = state.size();
  double* x = state.x();
  double* y = state.y();
  double* z = state.z();
  const double* f = out.force.data();
  for (std::size_t i = 0; i < n; ++i)
    drift.apply(x[i], y[i], z[i], f[i], f[n + i], f[2 * n + i]);
}

class ReferenceBackend final : public ForceBackend {
 public:
  explicit ReferenceBackend(double alpha) : alpha_(alpha) {}
  std::string name() const override { return "reference"; }
  std::string target() const override { return baseline_target(); }
  // The general law even at alpha_r = 2, so that the harmonic one is checked against it.
  void compute(const State& state, const NeighbourList&, ForceResult& out, std::uint64_t) override {
    reference_forces(PowerPair{alpha_}, state, out);
  }
  // Needs no list, so the pass always goes on.
  bool compute_and_drift(State& state, const NeighbourList&, ForceResult& out, const Drift& drift,
                         const Box&, std::uint64_t, std::uint64_t) override {
    reference_forces(PowerPair{alpha_}, state, out);
    apply_drift(state, out, drift);
    return true;
  }

 private:
  double alpha_;
};

}  // namespace
}  // namespace kernels

bool ForceBackend::compute_and_drift(State& state, const NeighbourList& list, ForceResult& out,
                                     const Drift& drift, const Box&, std::uint64_t version,
                                     std::uint64_t) {
  compute(state, list, out, version);
  if (!list.inner_holds(state, std::sqrt(out.max_drift2)))
    return false;
  kernels::apply_drift(state, out, drift);
  return true;
}

std::string baseline_target() {
#if defined(__AVX512F__)
  return "x86-64 with AVX-512 (compiler flags)";
#elif defined(__AVX2__)
  return "x86-64 with AVX2 (compiler flags)";
#elif defined(__x86_64__)
  return "x86-64";
#elif defined(__aarch64__)
  return "aarch64";
#else
  return "generic";
#endif
}

std::unique_ptr<ForceBackend> make_backend(const std::string& requested, double alpha_r,
                                           int threads) {
  std::string kind = requested;
  if (kind == "auto") {
    if (const char* env = std::getenv("JAMFLOW_KERNEL"); env && *env)
      kind = env;
  }
  bool known = false;
  for (const std::string& k : backend_kinds())
    known = known || k == kind;
  if (!known) {
    std::string allowed;
    for (const std::string& k : backend_kinds())
      allowed += (allowed.empty() ? "\"" : ", \"") + k + "\"";
    throw ConfigError("kernel = \"" + kind + "\" (from " +
                      (kind == requested ? std::string("the request") : "JAMFLOW_KERNEL") +
                      "); allowed " + allowed);
  }
  if (kind == "auto")
    kind = kernels::simd_current_target().vector ? "simd" : "portable";
  if (kind == "simd")
    return kernels::make_simd_backend(alpha_r, threads);
  if (kind == "portable")
    return kernels::make_portable_backend(alpha_r, threads);
  return std::make_unique<kernels::ReferenceBackend>(alpha_r);
}

}  // namespace jamflow
