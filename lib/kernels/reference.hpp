// The reference backend's free functions, templated on the pair law (lib/potential.hpp):
// plain loops with no blocking, threads or vectors, for tests and for the integrators' own
// uses of the pair law (CVODE's Hessian-vector products).
#pragma once
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#include "lib/kernels/backend.hpp"
#include "lib/neighbour_list.hpp"
#include "lib/potential.hpp"
#include "lib/state.hpp"

namespace jamflow::kernels {

// Every pair, minimum image, no list: O(N^2).
template <class Pair>
void reference_forces(const Pair& pair, const State& state, ForceResult& out) {
  const std::size_t n = state.size();
  out.force.assign(3 * n, 0.0);
  out.energy = 0.0;
  out.virial.setZero();
  out.contacts = 0;
  const Eigen::Matrix3d h = state.box.h();
  const double t = state.box.tilt_fraction();
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = i + 1; j < n; ++j) {
      double dx = state.x()[i] - state.x()[j];
      double dy = state.y()[i] - state.y()[j];
      double dz = state.z()[i] - state.z()[j];
      // Reduce to [-1/2, 1/2) first: positions may be unwrapped between list rebuilds.
      image_code(dx, dy, dz, t);
      const Eigen::Vector3d r = h * Eigen::Vector3d(dx, dy, dz);
      const double a = 0.5 * (state.diameter[i] + state.diameter[j]);
      const double rn = r.norm();
      if (rn >= a)
        continue;
      const PairValue pv = pair(rn, a);
      const Eigen::Vector3d g = pv.f_over_r * r;
      for (int c = 0; c < 3; ++c) {
        out.force[c * n + i] += g[c];
        out.force[c * n + j] -= g[c];
      }
      out.energy += pv.energy;
      out.virial += r * g.transpose();
      ++out.contacts;
    }
  }
  out.force_squared = 0.0;
  for (double f : out.force)
    out.force_squared += f * f;
  out.max_drift2 = std::numeric_limits<double>::infinity();  // no list, no reference
}

// out = -H v: the change of the forces for a real-space displacement field v (SoA), i.e. the
// Hessian-vector product of the potential energy, over the list's inner pairs.
template <class Pair>
void reference_hessian_product(const Pair& pair, const State& state, const NeighbourList& list,
                               const double* v, double* out) {
  // For a pair, the energy Hessian w.r.t. r_ij is K = U'' rr^T + (U'/r)(I - rr^T) with
  // U'/r = -f/r. The force change on i is -K (v_i - v_j), on j the opposite.
  const std::size_t n = state.size();
  std::fill(out, out + 3 * n, 0.0);
  const Eigen::Matrix3d h = state.box.h();
  const double hxx = h(0, 0), hxy = h(0, 1), hyy = h(1, 1), hzz = h(2, 2);
  const auto& shift = NeighbourList::shifts();
  const auto& start = list.inner_start();
  const auto& entries = list.inner_entries();
  for (std::size_t i = 0; i < n; ++i) {
    for (std::uint32_t k = start[i]; k < start[i + 1]; ++k) {
      const std::uint32_t e = entries[k];
      const std::uint32_t j = e >> NeighbourList::kCodeBits;
      const auto& sh = shift[e & NeighbourList::kCodeMask];
      const double dx = state.x()[i] - state.x()[j] + sh[0];
      const double dy = state.y()[i] - state.y()[j] + sh[1];
      const double dz = state.z()[i] - state.z()[j] + sh[2];
      const Eigen::Vector3d r(hxx * dx + hxy * dy, hyy * dy, hzz * dz);
      const double r2 = r.squaredNorm();
      const double a = 0.5 * (state.diameter[i] + state.diameter[j]);
      if (r2 >= a * a)
        continue;
      const double rn = std::sqrt(r2);
      const Eigen::Vector3d u = r / rn;
      const double f_over_r = pair(rn, a).f_over_r;
      const double k_par = pair.stiffness(rn, a);
      const Eigen::Vector3d dv(v[i] - v[j], v[n + i] - v[n + j], v[2 * n + i] - v[2 * n + j]);
      const double along = u.dot(dv);
      // K dv = U'' (u.dv) u - (f/r) (dv - (u.dv) u)
      const Eigen::Vector3d kdv = k_par * along * u - f_over_r * (dv - along * u);
      for (int c = 0; c < 3; ++c) {
        out[c * n + i] -= kdv[c];
        out[c * n + j] += kdv[c];
      }
    }
  }
}

}  // namespace jamflow::kernels
