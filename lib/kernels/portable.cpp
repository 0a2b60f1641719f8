// The portable backend: plain C++ that any compiler vectorises for the build's baseline.
//
// Particles are processed in blocks of kBlock (in memory order, which follows the cell order).
// For a block, (1) the listed pairs are measured and the touching ones are gathered into small
// contact buffers without a branch (which pairs touch is unpredictable: a mispredicted branch
// per pair cost more than the pair itself); (2) the pair law, energy and virial run over the
// contiguous buffers as a SIMD loop; (3) the pair forces are added to both particles. The
// buffers of one block stay in L1. Square roots and divisions vectorise only with
// -fno-math-errno (set for the whole build).
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <vector>

#include "lib/kernels/backend.hpp"
#include "lib/kernels/passes.hpp"
#include "lib/potential.hpp"

namespace jamflow::kernels {
namespace {

class PortableBackend final : public ForceBackend {
 public:
  PortableBackend(double alpha, int threads) : alpha_(alpha), threads_(threads) {}
  std::string name() const override { return "portable"; }
  std::string target() const override { return baseline_target(); }
  void compute(const State& state, const NeighbourList& list, ForceResult& out,
               std::uint64_t) override {
    with_pair_law(alpha_, [&](const auto& pair) { pass(pair, state, list, out); });
  }

 private:
  // Contacts of one block of particles, per thread.
  struct Scratch {
    std::vector<std::uint32_t> i, j;
    std::vector<double> rx, ry, rz, r2, a;
    void resize(std::size_t m) {
      if (i.size() >= m)
        return;
      for (auto* v : {&i, &j})
        v->resize(m);
      for (auto* v : {&rx, &ry, &rz, &r2, &a})
        v->resize(m);
    }
  };

  template <class Pair>
  void pass(const Pair& pair, const State& state, const NeighbourList& list, ForceResult& out);

  double alpha_;
  int threads_;
  std::vector<Scratch> scratch_;
  std::vector<std::vector<DeferredForce>> deferred_;
  std::vector<std::size_t> deferred_count_;
};

template <class Pair>
void PortableBackend::pass(const Pair& pair, const State& state, const NeighbourList& list,
                           ForceResult& out) {
  const std::size_t n = state.size();
  out.force.resize(3 * n);
  const int nt = threads_;
  scratch_.resize(std::max<std::size_t>(scratch_.size(), nt));
  deferred_.resize(std::max<std::size_t>(deferred_.size(), nt));
  deferred_count_.assign(nt, 0);

  const Eigen::Matrix3d h = state.box.h();
  const double hxx = h(0, 0), hxy = h(0, 1), hyy = h(1, 1), hzz = h(2, 2);
  const double* sx = state.x();
  const double* sy = state.y();
  const double* sz = state.z();
  const double* d = state.diameter.data();
  const std::uint32_t* start = list.inner_start().data();
  const std::uint32_t* entries = list.inner_entries().data();
  const auto& shift = NeighbourList::shifts();
  const std::size_t capacity = kBlock * std::max<std::size_t>(1, list.max_row());

  ThreadSums sums(nt);
  // Plain references, not a structured binding: clang before 16 cannot capture bindings in
  // the parallel region (the fuzz build, fuzz/, uses Debian's clang 14).
  auto& energy = sums.energy;
  auto& vir = sums.virial;
  auto& contacts = sums.contacts;
  auto& squared = sums.squared;
  auto& drift2 = sums.drift2;
  const bool have_ref = list.inner_reference().size() == state.pos.size();
  const double* ref = list.inner_reference().data();

  double* fx = out.force.data();
  double* fy = fx + n;
  double* fz = fy + n;

#pragma omp parallel num_threads(nt) if (nt > 1)
  {
    const int tid = omp_get_thread_num();
    const int nthr = omp_get_num_threads();  // may be fewer than requested
    // Each thread owns a contiguous range of blocks and the forces of its particles: it
    // zeroes them, adds every pair force on them, and defers a force on a particle of another
    // thread's range (pairs across a range boundary, a thin layer of the cell order) to a
    // list that the owner adds after the barrier, in thread order.
    const auto range = thread_range(start, n, tid, nthr);
    const std::size_t lo = range.first, hi = range.second;
    if (have_ref)
      drift2[tid] = NeighbourList::max_displacement2(state, ref, lo, hi);
    std::fill(fx + lo, fx + hi, 0.0);
    std::fill(fy + lo, fy + hi, 0.0);
    std::fill(fz + lo, fz + hi, 0.0);
    Scratch& cs = scratch_[tid];
    cs.resize(capacity);
    std::vector<DeferredForce>& deferred = deferred_[tid];
    if (nthr > 1)
      deferred.resize(std::max<std::size_t>(deferred.size(), start[hi] - start[lo]));
    std::size_t nd = 0;
    std::uint32_t* ci = cs.i.data();
    std::uint32_t* cj = cs.j.data();
    double* crx = cs.rx.data();
    double* cry = cs.ry.data();
    double* crz = cs.rz.data();
    double* cr2 = cs.r2.data();
    double* ca = cs.a.data();
    double u = 0.0, wxx = 0.0, wyy = 0.0, wzz = 0.0, wxy = 0.0, wxz = 0.0, wyz = 0.0;
    std::size_t nc = 0;
    for (std::size_t i0 = lo; i0 < hi; i0 += kBlock) {  // lo is a multiple of kBlock
      const std::size_t i1 = std::min(hi, i0 + kBlock);
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
      for (std::size_t c = 0; c < m; ++c) {
        const std::uint32_t i = ci[c], j = cj[c];
        fx[i] += crx[c];
        fy[i] += cry[c];
        fz[i] += crz[c];
        if (nthr == 1 || (j >= lo && j < hi)) {
          fx[j] -= crx[c];
          fy[j] -= cry[c];
          fz[j] -= crz[c];
        } else {
          deferred[nd++] = {j, -crx[c], -cry[c], -crz[c]};
        }
      }
      nc += m;
    }
    energy[tid] = u;
    vir[tid] << wxx, wyy, wzz, wxy, wxz, wyz;
    contacts[tid] = nc;
    deferred_count_[tid] = nd;
    if (nthr > 1) {
#pragma omp barrier
      add_deferred(deferred_, deferred_count_, lo, hi,
                   [&](std::uint32_t j, const DeferredForce& df) {
                     fx[j] += df.fx;
                     fy[j] += df.fy;
                     fz[j] += df.fz;
                   });
    }
    // The forces of this range are final: their squared sum.
    double f2 = 0.0;
#pragma omp simd reduction(+ : f2)
    for (std::size_t i = lo; i < hi; ++i)
      f2 += fx[i] * fx[i] + fy[i] * fy[i] + fz[i] * fz[i];
    squared[tid] = f2;
  }
  sums.finish(out, have_ref);
}

}  // namespace

std::unique_ptr<ForceBackend> make_portable_backend(double alpha, int threads) {
  return std::make_unique<PortableBackend>(alpha, threads);
}

}  // namespace jamflow::kernels
