// The force field: one force pass over contacts that yields forces, potential energy and the
// virial tensor (SPEC §3), W_ab = sum_{i<j} r_ij,a f_ij,b. Then Pi = W / V,
// P_hat = tr(Pi) / 3, sigma_xy = -Pi_xy. The pass itself is a backend (lib/kernels/).
#pragma once
#include <Eigen/Dense>
#include <memory>
#include <string>

#include "lib/kernels/backend.hpp"
#include "lib/neighbour_list.hpp"
#include "lib/potential.hpp"
#include "lib/state.hpp"

namespace jamflow {

class ForceField {
 public:
  // alpha_r in [1.2, 3]; threads <= 0 means all OpenMP threads available; kernel is one of
  // backend_kinds() ("auto": the simd backend where this CPU has a vector target for it).
  explicit ForceField(double alpha_r, int threads = 0, const std::string& kernel = "auto");
  ForceField(const ForceField& other);
  ForceField& operator=(const ForceField& other);

  double alpha() const { return alpha_; }
  int threads() const { return threads_; }
  // The backend's name ("simd", "portable", "reference") and the instruction-set target it
  // runs on (e.g. "AVX3", "AVX2").
  std::string kernel() const { return backend_->name(); }
  std::string target() const { return backend_->target(); }
  // Passes that started from data the previous pass prepared (see ForceBackend).
  std::size_t prepared_passes() const { return backend_->prepared_passes(); }

  // One pass over the neighbour list's inner list (which must be valid for the state);
  // `version` numbers the state (lib/kernels/backend.hpp), 0 if unknown.
  void compute(const State& state, const NeighbourList& list, ForceResult& out,
               std::uint64_t version = 0) const;
  // compute() and an explicit Euler drift of every particle in one pass, where the backend can
  // (see ForceBackend::compute_and_drift): false, with the state untouched, when the inner list
  // does not hold for the state.
  bool compute_and_drift(State& state, const NeighbourList& list, ForceResult& out,
                         const Drift& drift, const Box& next, std::uint64_t version = 0,
                         std::uint64_t next_version = 0) const;
  // Reference path: every pair, minimum image, no list. O(N^2), for tests.
  void compute_all_pairs(const State& state, ForceResult& out) const;

  // out = -H v: the change of the forces for a real-space displacement field v (SoA), i.e.
  // the Hessian-vector product of the potential energy, over the neighbour list.
  void hessian_product(const State& state, const NeighbourList& list, const double* v,
                       double* out) const;

 private:
  double alpha_;
  int threads_;
  std::string requested_;
  std::unique_ptr<ForceBackend> backend_;
};

}  // namespace jamflow
