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

// Particles are processed in blocks of kBlock (in memory order, which follows the cell order).
// For a block, (1) the listed pairs are measured and the touching ones are gathered into small
// contact buffers without a branch (which pairs touch is unpredictable: a mispredicted branch
// per pair cost more than the pair itself); (2) the pair law, energy and virial run over the
// contiguous buffers as a SIMD loop; (3) the pair forces are added to both particles. The
// buffers of one block stay in L1. Square roots and divisions vectorise only with
// -fno-math-errno (set for the whole build); scalar, they cost about 6 ns per contact.
constexpr std::size_t kBlock = 64;

template <class Pair>
void ForceField::compute_impl(const Pair& pair, const State& state, const NeighbourList& list,
                              ForceResult& out) const {
  const std::size_t n = state.size();
  out.force.resize(3 * n);
  const int nt = threads_;
  if (int(scratch_.size()) < nt)
    scratch_.resize(nt);

  const Eigen::Matrix3d h = state.box.h();
  const double hxx = h(0, 0), hxy = h(0, 1), hyy = h(1, 1), hzz = h(2, 2);
  const double* sx = state.x();
  const double* sy = state.y();
  const double* sz = state.z();
  const double* d = state.diameter.data();
  const std::uint32_t* start = list.start().data();
  const std::uint32_t* entries = list.entries().data();
  const auto& shift = NeighbourList::shifts();
  const std::size_t capacity = kBlock * std::max<std::size_t>(1, list.max_row());

  // Per-thread partial sums, reduced in thread order so one thread count is deterministic.
  std::vector<double> energy(nt, 0.0);
  std::vector<Eigen::Matrix<double, 6, 1>> vir(nt, Eigen::Matrix<double, 6, 1>::Zero());
  std::vector<std::size_t> contacts(nt, 0);
  std::vector<double> squared(nt, 0.0);

  double* fx = out.force.data();
  double* fy = fx + n;
  double* fz = fy + n;
  const std::size_t blocks = (n + kBlock - 1) / kBlock;

#pragma omp parallel num_threads(nt)
  {
    const int tid = omp_get_thread_num();
    const int nthr = omp_get_num_threads();  // may be fewer than requested
    // Each thread owns a contiguous range of blocks and the forces of its particles: it
    // zeroes them, adds every pair force on them, and defers a force on a particle of another
    // thread's range (pairs across a range boundary, a thin layer of the cell order) to a
    // list that the owner adds after the barrier, in thread order: no races, no full-size
    // per-thread buffers, and a fixed summation order for a given thread count.
    // Ranges hold equal shares of the listed pairs (the work), not of the particles.
    auto split = [&](int t) {
      const double share = double(start[n]) * double(t) / double(nthr);
      std::size_t lo_b = 0, hi_b = blocks;  // first block whose first entry reaches the share
      while (lo_b < hi_b) {
        const std::size_t mid = (lo_b + hi_b) / 2;
        if (double(start[std::min(n, mid * kBlock)]) < share)
          lo_b = mid + 1;
        else
          hi_b = mid;
      }
      return t == nthr ? blocks : lo_b;
    };
    const std::size_t b0 = split(tid);
    const std::size_t b1 = split(tid + 1);
    const std::size_t lo = std::min(n, b0 * kBlock), hi = std::min(n, b1 * kBlock);
    std::fill(fx + lo, fx + hi, 0.0);
    std::fill(fy + lo, fy + hi, 0.0);
    std::fill(fz + lo, fz + hi, 0.0);
    ContactScratch& cs = scratch_[tid];
    cs.resize(capacity);
    cs.deferred.clear();
    std::uint32_t* ci = cs.i.data();
    std::uint32_t* cj = cs.j.data();
    double* crx = cs.rx.data();
    double* cry = cs.ry.data();
    double* crz = cs.rz.data();
    double* cr2 = cs.r2.data();
    double* ca = cs.a.data();
    double u = 0.0, wxx = 0.0, wyy = 0.0, wzz = 0.0, wxy = 0.0, wxz = 0.0, wyz = 0.0;
    std::size_t nc = 0;
    for (std::size_t b = b0; b < b1; ++b) {
      const std::size_t i0 = b * kBlock, i1 = std::min(n, i0 + kBlock);
      // (1) Geometry and branch-free gathering of the contacts.
      std::size_t m = 0;
      for (std::size_t i = i0; i < i1; ++i) {
        const double xi = sx[i], yi = sy[i], zi = sz[i], di = d[i];
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
          ci[m] = std::uint32_t(i);
          cj[m] = j;
          crx[m] = rx;
          cry[m] = ry;
          crz[m] = rz;
          cr2[m] = r2;
          ca[m] = a;
          m += (r2 < a * a) ? 1 : 0;
        }
      }
      // (2) Pair law, energy and virial; the buffers then hold the pair forces on i.
#pragma omp simd reduction(+ : u, wxx, wyy, wzz, wxy, wxz, wyz)
      for (std::size_t c = 0; c < m; ++c) {
        const double rx = crx[c], ry = cry[c], rz = crz[c];
        const PairValue pv = pair(std::sqrt(cr2[c]), ca[c]);
        const double gx = pv.f_over_r * rx, gy = pv.f_over_r * ry, gz = pv.f_over_r * rz;
        u += pv.energy;
        wxx += rx * gx;
        wyy += ry * gy;
        wzz += rz * gz;
        wxy += rx * gy;
        wxz += rx * gz;
        wyz += ry * gz;
        crx[c] = gx;
        cry[c] = gy;
        crz[c] = gz;
      }
      // (3) Newton's third law.
      if (nthr == 1) {
        for (std::size_t c = 0; c < m; ++c) {
          const std::uint32_t i = ci[c], j = cj[c];
          fx[i] += crx[c];
          fy[i] += cry[c];
          fz[i] += crz[c];
          fx[j] -= crx[c];
          fy[j] -= cry[c];
          fz[j] -= crz[c];
        }
      } else {
        for (std::size_t c = 0; c < m; ++c) {
          const std::uint32_t i = ci[c], j = cj[c];
          fx[i] += crx[c];
          fy[i] += cry[c];
          fz[i] += crz[c];
          if (j >= lo && j < hi) {
            fx[j] -= crx[c];
            fy[j] -= cry[c];
            fz[j] -= crz[c];
          } else {
            cs.deferred.push_back({j, -crx[c], -cry[c], -crz[c]});
          }
        }
      }
      nc += m;
    }
    energy[tid] = u;
    vir[tid] << wxx, wyy, wzz, wxy, wxz, wyz;
    contacts[tid] = nc;
    if (nthr > 1) {
#pragma omp barrier
      for (int t = 0; t < nthr; ++t) {
        for (const Deferred& df : scratch_[t].deferred) {
          if (df.j >= lo && df.j < hi) {
            fx[df.j] += df.fx;
            fy[df.j] += df.fy;
            fz[df.j] += df.fz;
          }
        }
      }
    }
    // The forces of this range are final: their squared sum, here rather than in a second
    // parallel region.
    double f2 = 0.0;
#pragma omp simd reduction(+ : f2)
    for (std::size_t i = lo; i < hi; ++i)
      f2 += fx[i] * fx[i] + fy[i] * fy[i] + fz[i] * fz[i];
    squared[tid] = f2;
  }

  out.energy = 0.0;
  out.contacts = 0;
  out.force_squared = 0.0;
  Eigen::Matrix<double, 6, 1> w = Eigen::Matrix<double, 6, 1>::Zero();
  for (int t = 0; t < nt; ++t) {
    out.energy += energy[t];
    w += vir[t];
    out.contacts += contacts[t];
    out.force_squared += squared[t];
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
  out.force_squared = 0.0;
  for (double f : out.force)
    out.force_squared += f * f;
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
