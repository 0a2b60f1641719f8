// Force backends: interchangeable implementations of one force pass (SPEC §3). A pass takes
// the state and the neighbour list's inner pairs and yields forces, potential energy and the
// virial W_ab = sum_{i<j} r_ij,a f_ij,b (r_ij = r_i - r_j, minimum image; f_ij the force on i
// from j). Backends exchange whole passes, never single pairs:
//   reference  every pair, minimum image, no list: O(N^2), the yardstick of the tests;
//   portable   blocked loops that any compiler vectorises (lib/kernels/portable.cpp);
//   simd       one Highway kernel compiled for several instruction sets, the best one picked
//              at run time (lib/kernels/simd.cpp).
// All three evaluate the same pair law (lib/potential.hpp) for every alpha_r.
#pragma once
#include <Eigen/Dense>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "lib/neighbour_list.hpp"
#include "lib/state.hpp"

namespace jamflow {

struct ForceResult {
  std::vector<double> force;  // real-space forces, SoA like State::pos
  double energy = 0.0;
  Eigen::Matrix3d virial = Eigen::Matrix3d::Zero();
  std::size_t contacts = 0;
  double force_squared = 0.0;  // sum_i |F_i|^2 (the dissipation times xi_s)
  // Largest squared displacement since the list's inner reference (real space, current cell),
  // taken in the same pass so that checking the list costs no pass of its own; infinite
  // when the list has no reference for this state (and always for the reference backend).
  // NaN when a position is not finite.
  double max_drift2 = 0.0;
};

// States are numbered by their owner (lib/model.hpp): every change of positions, cell or
// particle order gets a new number, so that a backend may keep data derived from a state
// between passes and know, by its number, whether it still belongs to the state it is given.
// 0 means unknown: nothing is reused.

// The particle drift of an explicit Euler step in scaled coordinates, s += D F, with
// D = h_new^-1 dt / xi_s (upper triangular, as h is). Every loop that applies it evaluates
// x + ((xx fx) + (xy fy)), y + yy fy, z + zz fz in that order, so that all give the same bits.
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

class ForceBackend {
 public:
  virtual ~ForceBackend() = default;
  // "reference", "portable" or "simd".
  virtual std::string name() const = 0;
  // The instruction set the pass runs on: for simd the Highway target chosen at run time
  // (e.g. "AVX3", "AVX2"); for the others the build's baseline.
  virtual std::string target() const = 0;
  // One force pass. The list must be valid for the state (the reference backend ignores it).
  // `version` numbers the state (see StateVersion); 0 means unknown.
  virtual void compute(const State& state, const NeighbourList& list, ForceResult& out,
                       std::uint64_t version) = 0;
  // A capability an integrator may ask for: compute() and then drift.apply() to every particle
  // with its force, the same state bit for bit; the caller then gives the state the cell `next`
  // and the number `next_version`. Returns false, with the state untouched and out.max_drift2
  // set, when the inner list does not hold for the state (renew it and call again). This default
  // does exactly that sequence; a backend may fuse the drift into its pass, and prepare the next
  // pass for the state it leaves.
  virtual bool compute_and_drift(State& state, const NeighbourList& list, ForceResult& out,
                                 const Drift& drift, const Box& next, std::uint64_t version,
                                 std::uint64_t next_version);
  // Passes that started from data the previous pass prepared for their state (0 if the backend
  // keeps none); for tests and benchmarks.
  virtual std::size_t prepared_passes() const { return 0; }
};

// The backends a user can ask for, and "auto" (simd where the CPU has a vector target for it,
// else portable).
inline const std::vector<std::string>& backend_kinds() {
  static const std::vector<std::string> kinds = {"auto", "simd", "portable", "reference"};
  return kinds;
}

// alpha_r in [1.2, 3]; threads >= 1. An unknown kind is a ConfigError. The environment
// variable JAMFLOW_KERNEL, when set, overrides "auto" (for forcing the portable path in a test
// run); JAMFLOW_SIMD_TARGET (e.g. "AVX2") restricts the simd backend to one target.
std::unique_ptr<ForceBackend> make_backend(const std::string& kind, double alpha_r, int threads);

// The instruction set the build's baseline code is compiled for (e.g. "x86-64").
std::string baseline_target();

}  // namespace jamflow
