// Force, energy and virial pass (SPEC §3), templated on the pair evaluator.
#include "lib/forces.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "lib/error.hpp"

namespace jamflow {

ForceField::ForceField(double alpha_r, int threads)
    : alpha_(alpha_r), harmonic_(alpha_r == 2.0), threads_(threads) {
  if (!(alpha_r >= kAlphaMin && alpha_r <= kAlphaMax)) {
    throw ConfigError("[system] alpha = " + std::to_string(alpha_r) +
                      " is out of range; allowed [" + std::to_string(kAlphaMin) + ", " +
                      std::to_string(kAlphaMax) + "]");
  }
  if (threads_ <= 0)
    threads_ = omp_get_max_threads();
}

void ForceField::compute(const State& state, const NeighbourList& list, ForceResult& out) const {
  if (harmonic_) {
    compute_impl(HarmonicPair{}, state, list, out);
  } else {
    compute_impl(PowerPair{alpha_}, state, list, out);
  }
}

template <class Pair>
void ForceField::compute_impl(const Pair& pair, const State& state, const NeighbourList& list,
                              ForceResult& out) const {
  const std::size_t n = state.size();
  out.force.resize(3 * n);
  const int nt = threads_;
  if (int(buffers_.size()) < nt)
    buffers_.resize(nt);

  const Eigen::Matrix3d h = state.box.h();
  const double hxx = h(0, 0), hxy = h(0, 1), hyy = h(1, 1), hzz = h(2, 2);
  const double* sx = state.x();
  const double* sy = state.y();
  const double* sz = state.z();
  const double* d = state.diameter.data();
  const std::uint32_t* start = list.start().data();
  const std::uint32_t* entries = list.entries().data();
  const auto& shift = NeighbourList::shifts();

  // Per-thread partial sums, reduced in thread order so one thread count is deterministic.
  std::vector<double> energy(nt, 0.0);
  std::vector<Eigen::Matrix<double, 6, 1>> vir(nt, Eigen::Matrix<double, 6, 1>::Zero());
  std::vector<std::size_t> contacts(nt, 0);

#pragma omp parallel num_threads(nt)
  {
    const int tid = omp_get_thread_num();
    const int nthr = omp_get_num_threads();  // may be fewer than requested
    // Thread 0 accumulates straight into the output; others into their own buffers.
    double* f = (tid == 0) ? out.force.data() : (buffers_[tid].resize(3 * n), buffers_[tid].data());
    std::fill(f, f + 3 * n, 0.0);
    double* fx = f;
    double* fy = f + n;
    double* fz = f + 2 * n;
    double u = 0.0, wxx = 0.0, wyy = 0.0, wzz = 0.0, wxy = 0.0, wxz = 0.0, wyz = 0.0;
    std::size_t nc = 0;
    // Contacts of one particle, gathered without a branch: which listed pairs touch is
    // unpredictable, and a mispredicted branch per pair cost more than the pair itself.
    const std::size_t row = list.max_row();
    std::vector<std::uint32_t> cj(row);
    std::vector<double> crx(row), cry(row), crz(row), cr2(row), ca(row);
#pragma omp for schedule(static)
    for (std::size_t i = 0; i < n; ++i) {
      const double xi = sx[i], yi = sy[i], zi = sz[i], di = d[i];
      std::size_t m = 0;
      for (std::uint32_t k = start[i]; k < start[i + 1]; ++k) {
        const std::uint32_t e = entries[k];
        const std::uint32_t j = e >> NeighbourList::kCodeBits;
        const auto& sh = shift[e & NeighbourList::kCodeMask];
        const double dx = xi - sx[j] + sh[0];
        const double dy = yi - sy[j] + sh[1];
        const double dz = zi - sz[j] + sh[2];
        const double rx = hxx * dx + hxy * dy, ry = hyy * dy, rz = hzz * dz;
        const double r2 = rx * rx + ry * ry + rz * rz;
        const double a = 0.5 * (di + d[j]);
        cj[m] = j;
        crx[m] = rx;
        cry[m] = ry;
        crz[m] = rz;
        cr2[m] = r2;
        ca[m] = a;
        m += (r2 < a * a) ? 1 : 0;
      }
      double fxi = 0.0, fyi = 0.0, fzi = 0.0;
      for (std::size_t c = 0; c < m; ++c) {
        const double rx = crx[c], ry = cry[c], rz = crz[c];
        const PairValue pv = pair(std::sqrt(cr2[c]), ca[c]);
        const double gx = pv.f_over_r * rx, gy = pv.f_over_r * ry, gz = pv.f_over_r * rz;
        const std::uint32_t j = cj[c];
        fxi += gx;
        fyi += gy;
        fzi += gz;
        fx[j] -= gx;
        fy[j] -= gy;
        fz[j] -= gz;
        u += pv.energy;
        wxx += rx * gx;
        wyy += ry * gy;
        wzz += rz * gz;
        wxy += rx * gy;
        wxz += rx * gz;
        wyz += ry * gz;
      }
      nc += m;
      fx[i] += fxi;
      fy[i] += fyi;
      fz[i] += fzi;
    }
    energy[tid] = u;
    vir[tid] << wxx, wyy, wzz, wxy, wxz, wyz;
    contacts[tid] = nc;
    if (nthr > 1) {
      // The implicit barrier of the pair loop has completed every buffer.
#pragma omp for schedule(static)
      for (std::size_t k = 0; k < 3 * n; ++k) {
        double s = out.force[k];
        for (int t = 1; t < nthr; ++t)
          s += buffers_[t][k];
        out.force[k] = s;
      }
    }
  }

  out.energy = 0.0;
  out.contacts = 0;
  Eigen::Matrix<double, 6, 1> w = Eigen::Matrix<double, 6, 1>::Zero();
  for (int t = 0; t < nt; ++t) {
    out.energy += energy[t];
    w += vir[t];
    out.contacts += contacts[t];
  }
  // Central forces: the virial is symmetric.
  out.virial << w[0], w[3], w[4], w[3], w[1], w[5], w[4], w[5], w[2];
}

void ForceField::compute_all_pairs(const State& state, ForceResult& out) const {
  const std::size_t n = state.size();
  out.force.assign(3 * n, 0.0);
  out.energy = 0.0;
  out.virial.setZero();
  out.contacts = 0;
  const Eigen::Matrix3d h = state.box.h();
  const double t = state.box.tilt();
  const PowerPair general{alpha_};
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
      const PairValue pv = general(rn, a);
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
}

void ForceField::hessian_product(const State& state, const NeighbourList& list, const double* v,
                                 double* out) const {
  if (harmonic_) {
    hessian_impl(HarmonicPair{}, state, list, v, out);
  } else {
    hessian_impl(PowerPair{alpha_}, state, list, v, out);
  }
}

template <class Pair>
void ForceField::hessian_impl(const Pair& pair, const State& state, const NeighbourList& list,
                              const double* v, double* out) const {
  // For a pair, the energy Hessian w.r.t. r_ij is K = U'' rr^T + (U'/r)(I - rr^T) with
  // U'/r = -f/r. The force change on i is -K (v_i - v_j), on j the opposite.
  const std::size_t n = state.size();
  std::fill(out, out + 3 * n, 0.0);
  const Eigen::Matrix3d h = state.box.h();
  const double hxx = h(0, 0), hxy = h(0, 1), hyy = h(1, 1), hzz = h(2, 2);
  const auto& shift = NeighbourList::shifts();
  const auto& start = list.start();
  const auto& entries = list.entries();
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

}  // namespace jamflow
