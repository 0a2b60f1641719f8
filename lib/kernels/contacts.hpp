// The contacts of a configuration with their pair stiffnesses, from the neighbour list's inner
// pairs: what a Hessian-vector product over the contacts needs (the equation of motion's
// analytic Jacobian, integrators/motion.hpp), beside the reference backend's all-pairs loops
// (reference.hpp). Stiffnesses are divided by the friction xi, so that they are rates.
#pragma once
#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "lib/neighbour_list.hpp"
#include "lib/potential.hpp"
#include "lib/state.hpp"

namespace jamflow::kernels {

struct ContactStiffness {
  struct Contact {
    std::uint32_t i, j;
    double nx, ny, nz;  // unit vector along r_ij
    double k_par;       // U'' / xi
    double k_perp;      // (f / r) / xi: the tension term -(f/r)(I - n n^T) of the Hessian
  };
  std::vector<Contact> contacts;
  std::vector<double> normal_block;  // 6 per particle: sum_j U'' n n^T / xi (xx yy zz xy xz yz)
  // With `dilation`: g_i = sum_j U''(r_ij) r_ij (SoA, 3N; the force change under an affine
  // dilation is -(dl/l) g), the virial sum r.f and the curvature sum U'' r^2 over the contacts.
  std::vector<double> g;
  double virial = 0.0, curvature = 0.0;
};

// Collects the contacts of `state` over the list's pairs (a valid list for this state).
template <class Pair>
void collect_contacts(const Pair& pair, const State& st, const NeighbourList& list, double xi,
                      bool dilation, ContactStiffness& out) {
  const Eigen::Matrix3d h = st.box.h();
  const double hxx = h(0, 0), hxy = h(0, 1), hyy = h(1, 1), hzz = h(2, 2);
  const auto& shift = NeighbourList::shifts();
  const std::uint32_t* start = list.start().data();
  const std::uint32_t* entries = list.entries().data();
  const double* sx = st.x();
  const double* sy = st.y();
  const double* sz = st.z();
  const double* d = st.diameter.data();
  const std::size_t n = st.size();

  out.contacts.clear();
  out.normal_block.assign(6 * n, 0.0);
  out.g.assign(dilation ? 3 * n : 0, 0.0);
  double virial = 0.0, curvature = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    for (std::uint32_t k = start[i]; k < start[i + 1]; ++k) {
      const std::uint32_t e = entries[k];
      const std::uint32_t j = e >> NeighbourList::kCodeBits;
      const auto& sh = shift[e & NeighbourList::kCodeMask];
      const double dx = sx[i] - sx[j] + sh[0];
      const double dy = sy[i] - sy[j] + sh[1];
      const double dz = sz[i] - sz[j] + sh[2];
      const double rx = hxx * dx + hxy * dy, ry = hyy * dy, rz = hzz * dz;
      const double r2 = rx * rx + ry * ry + rz * rz;
      const double a = 0.5 * (d[i] + d[j]);
      if (r2 >= a * a)
        continue;
      const double r = std::sqrt(r2);
      const PairValue pv = pair(r, a);
      const double kp = pair.stiffness(r, a);
      const double nx = rx / r, ny = ry / r, nz = rz / r;
      out.contacts.push_back(
          ContactStiffness::Contact{std::uint32_t(i), j, nx, ny, nz, kp / xi, pv.f_over_r / xi});
      const std::array<double, 6> nn{nx * nx, ny * ny, nz * nz, nx * ny, nx * nz, ny * nz};
      for (int c = 0; c < 6; ++c) {
        out.normal_block[6 * i + c] += nn[c] * kp / xi;
        out.normal_block[6 * j + c] += nn[c] * kp / xi;
      }
      if (dilation) {
        const double gr[3] = {kp * rx, kp * ry, kp * rz};
        for (int c = 0; c < 3; ++c) {
          out.g[c * n + i] += gr[c];
          out.g[c * n + j] -= gr[c];
        }
        virial += pv.f_over_r * r2;
        curvature += kp * r2;
      }
    }
  }
  out.virial = virial;
  out.curvature = curvature;
}

// jv = -H v / xi over the contacts (SoA, 3N; jv is overwritten): per contact
// K dv = U'' (n.dv) n - (f/r) (dv - (n.dv) n).
inline void contact_hessian_product(const ContactStiffness& k, std::size_t n, const double* v,
                                    double* jv) {
  std::fill(jv, jv + 3 * n, 0.0);
  for (const ContactStiffness::Contact& c : k.contacts) {
    const double dvx = v[c.i] - v[c.j];
    const double dvy = v[n + c.i] - v[n + c.j];
    const double dvz = v[2 * n + c.i] - v[2 * n + c.j];
    const double along = c.nx * dvx + c.ny * dvy + c.nz * dvz;
    const double kx = (c.k_par + c.k_perp) * along * c.nx - c.k_perp * dvx;
    const double ky = (c.k_par + c.k_perp) * along * c.ny - c.k_perp * dvy;
    const double kz = (c.k_par + c.k_perp) * along * c.nz - c.k_perp * dvz;
    jv[c.i] -= kx;
    jv[n + c.i] -= ky;
    jv[2 * n + c.i] -= kz;
    jv[c.j] += kx;
    jv[n + c.j] += ky;
    jv[2 * n + c.j] += kz;
  }
}

}  // namespace jamflow::kernels
