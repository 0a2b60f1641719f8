// The force field: checks its parameters and hands each pass to its backend.
#include "lib/forces.hpp"

#include <omp.h>

#include <string>

#include "lib/error.hpp"
#include "lib/kernels/reference.hpp"

namespace jamflow {

ForceField::ForceField(double alpha_r, int threads, const std::string& kernel)
    : alpha_(alpha_r), threads_(threads), requested_(kernel) {
  if (!(alpha_r >= kAlphaMin && alpha_r <= kAlphaMax)) {
    throw ConfigError("[system] alpha = " + std::to_string(alpha_r) +
                      " is out of range; allowed [" + std::to_string(kAlphaMin) + ", " +
                      std::to_string(kAlphaMax) + "]");
  }
  if (threads_ <= 0)
    threads_ = omp_get_max_threads();
  backend_ = make_backend(requested_, alpha_, threads_);
}

ForceField::ForceField(const ForceField& other)
    : alpha_(other.alpha_),
      threads_(other.threads_),
      requested_(other.requested_),
      backend_(make_backend(other.requested_, other.alpha_, other.threads_)) {}

ForceField& ForceField::operator=(const ForceField& other) {
  if (this != &other) {
    alpha_ = other.alpha_;
    threads_ = other.threads_;
    requested_ = other.requested_;
    backend_ = make_backend(requested_, alpha_, threads_);
  }
  return *this;
}

void ForceField::compute(const State& state, const NeighbourList& list, ForceResult& out,
                         std::uint64_t version) const {
  backend_->compute(state, list, out, version);
}

bool ForceField::compute_and_drift(State& state, const NeighbourList& list, ForceResult& out,
                                   const Drift& drift, const Box& next, std::uint64_t version,
                                   std::uint64_t next_version) const {
  return backend_->compute_and_drift(state, list, out, drift, next, version, next_version);
}

void ForceField::compute_all_pairs(const State& state, ForceResult& out) const {
  // The general law even at alpha_r = 2, so that the harmonic one is checked against it.
  kernels::reference_forces(PowerPair{alpha_}, state, out);
}

void ForceField::hessian_product(const State& state, const NeighbourList& list, const double* v,
                                 double* out) const {
  with_pair_law(alpha_, [&](const auto& pair) {
    kernels::reference_hessian_product(pair, state, list, v, out);
  });
}

}  // namespace jamflow
