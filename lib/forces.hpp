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

// The particle drift of an explicit Euler step in scaled coordinates, s += D F, with
// D = h_new^-1 dt / xi_s (upper triangular, as h is).
struct Drift {
  double xx, xy, yy, zz;
  static Drift of(const Eigen::Matrix3d& h_inv, double dt_over_xi) {
    return {h_inv(0, 0) * dt_over_xi, h_inv(0, 1) * dt_over_xi, h_inv(1, 1) * dt_over_xi,
            h_inv(2, 2) * dt_over_xi};
  }
  void apply(double& x, double& y, double& z, double fx, double fy, double fz) const {
    x += xx * fx + xy * fy;
    y += yy * fy;
    z += zz * fz;
  }
};

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

  // One pass over the neighbour list's inner list (which must be valid for the state).
  void compute(const State& state, const NeighbourList& list, ForceResult& out) const;
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
