// Force, energy and virial pass (SPEC §3), templated on the pair evaluator.
#include "lib/forces.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

#if defined(__AVX512F__) && defined(__AVX512VL__)
#include <immintrin.h>
#define JAMFLOW_VECTOR_KERNEL 1
#else
#define JAMFLOW_VECTOR_KERNEL 0
#endif

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

// Spare rows per thread after the n particle rows of the vector kernel: the idle row (padding
// lanes) and three more, so that a thread's spare rows fill whole cache lines.
constexpr std::size_t kSpareRows = 4;

bool ForceField::vector_kernel(std::size_t n) const {
  // Row byte offsets (row << 5) must fit 32 bits, spare rows included.
  return JAMFLOW_VECTOR_KERNEL && harmonic_ && !portable_ &&
         n + kSpareRows * std::size_t(threads_) < (std::size_t(1) << 27);
}

void ForceField::compute(const State& state, const NeighbourList& list, ForceResult& out) const {
  ahead_.valid = false;  // only the vector kernel's drifting pass lays out rows ahead
  if (vector_kernel(state.size())) {
    compute_harmonic_vector(state, list, out);
  } else if (harmonic_) {
    compute_impl(HarmonicPair{}, state, list, out);
  } else {
    compute_impl(PowerPair{alpha_}, state, list, out);
  }
}

bool ForceField::compute_and_drift(State& state, const NeighbourList& list, ForceResult& out,
                                   const Drift& drift, const Eigen::Matrix3d& next,
                                   bool untouched) const {
  bool done = false;
  if (vector_kernel(state.size())) {
    done = compute_harmonic_vector(state, list, out, &drift, state.pos.data(), &next, untouched);
  } else {
    compute(state, list, out);
    if (list.inner_holds(state, std::sqrt(out.max_drift2))) {
      const std::size_t n = state.size();
      double* x = state.x();
      double* y = state.y();
      double* z = state.z();
      const double* f = out.force.data();
#pragma omp parallel for schedule(static) num_threads(threads_) if (threads_ > 1)
      for (std::size_t i = 0; i < n; ++i)
        drift.apply(x[i], y[i], z[i], f[i], f[n + i], f[2 * n + i]);
      done = true;
    }
  }
  if (done)
    out.force.clear();
  return done;
}

// Particles are processed in blocks of kBlock (in memory order, which follows the cell order).
// For a block, (1) the listed pairs are measured and the touching ones are gathered into small
// contact buffers without a branch (which pairs touch is unpredictable: a mispredicted branch
// per pair cost more than the pair itself); (2) the pair law, energy and virial run over the
// contiguous buffers as a SIMD loop; (3) the pair forces are added to both particles. The
// buffers of one block stay in L1. Square roots and divisions vectorise only with
// -fno-math-errno (set for the whole build); scalar, they cost about 6 ns per contact.
constexpr std::size_t kBlock = 64;

namespace {

// Thread ranges: contiguous runs of blocks holding equal shares of the listed pairs (the
// work), not of the particles, because the half list stores each pair at its lower index.
// Returns the first block of thread t of nthr (t = nthr gives the end).
std::size_t first_block(const std::uint32_t* start, std::size_t n, std::size_t blocks, int t,
                        int nthr) {
  if (t == nthr)
    return blocks;
  const double share = double(start[n]) * double(t) / double(nthr);
  std::size_t lo_b = 0, hi_b = blocks;  // first block whose first entry reaches the share
  while (lo_b < hi_b) {
    const std::size_t mid = (lo_b + hi_b) / 2;
    if (double(start[std::min(n, mid * kBlock)]) < share)
      lo_b = mid + 1;
    else
      hi_b = mid;
  }
  return lo_b;
}

// The particles [lo, hi) of thread t of nthr, for the list rows `start` of n particles.
std::pair<std::size_t, std::size_t> thread_range(const std::uint32_t* start, std::size_t n, int t,
                                                 int nthr) {
  const std::size_t nblocks = (n + kBlock - 1) / kBlock;
  return {std::min(n, first_block(start, n, nblocks, t, nthr) * kBlock),
          std::min(n, first_block(start, n, nblocks, t + 1, nthr) * kBlock)};
}

// Per-thread partial sums of a force pass, reduced in thread order so that one thread count
// is deterministic.
struct ThreadSums {
  explicit ThreadSums(int nt)
      : energy(nt, 0.0),
        virial(nt, Eigen::Matrix<double, 6, 1>::Zero()),
        contacts(nt, 0),
        squared(nt, 0.0),
        drift2(nt, 0.0) {}
  std::vector<double> energy;
  std::vector<Eigen::Matrix<double, 6, 1>> virial;  // xx yy zz xy xz yz
  std::vector<std::size_t> contacts;
  std::vector<double> squared, drift2;

  void finish(ForceResult& out, bool have_ref) const {
    out.energy = 0.0;
    out.contacts = 0;
    out.force_squared = 0.0;
    out.max_drift2 = have_ref ? 0.0 : std::numeric_limits<double>::infinity();
    Eigen::Matrix<double, 6, 1> w = Eigen::Matrix<double, 6, 1>::Zero();
    for (std::size_t t = 0; t < energy.size(); ++t) {
      out.energy += energy[t];
      w += virial[t];
      out.contacts += contacts[t];
      out.force_squared += squared[t];
      if (have_ref && !std::isnan(out.max_drift2))  // NaN wins
        out.max_drift2 = std::isnan(drift2[t]) ? drift2[t] : std::max(out.max_drift2, drift2[t]);
    }
    // Central forces: the virial is symmetric.
    out.virial << w[0], w[3], w[4], w[3], w[1], w[5], w[4], w[5], w[2];
  }
};

// 64-byte aligned view of a vector of at least `count` doubles.
[[maybe_unused]] double* aligned_rows(std::vector<double>& v, std::size_t count) {
  if (v.size() < count + 8)
    v.resize(count + 8);
  const auto p = reinterpret_cast<std::uintptr_t>(v.data());
  return reinterpret_cast<double*>((p + 63) & ~std::uintptr_t(63));
}

}  // namespace

void ForceField::ContactScratch::ghost_lists(const NeighbourList& list, int tid, int nthr) {
  if (ghost_generation == list.inner_generation() && ghost_threads == nthr)
    return;
  const std::uint32_t* start = list.inner_start().data();
  const std::uint32_t* entries = list.inner_entries().data();
  const std::size_t n = list.inner_start().size() - 1;
  const auto range = [&](int t) { return thread_range(start, n, t, nthr); };
  const auto [lo, hi] = range(tid);
  // The half list keeps each pair at its lower index, so a partner never lies in an earlier
  // range: the ghosts of thread t belong to later threads only. Checked, as a force written to a
  // ghost row that no thread adds would be lost.
  written.clear();
  for (std::uint32_t k = start[lo]; k < start[hi]; ++k) {
    const std::uint32_t j = entries[k] >> NeighbourList::kCodeBits;
    if (j < lo)
      throw std::logic_error("neighbour list: a partner precedes its owner's range");
    if (j >= hi)
      written.push_back(j);
  }
  std::sort(written.begin(), written.end());
  written.erase(std::unique(written.begin(), written.end()), written.end());
  ghost_rows.clear();
  ghost_start.assign(1, 0);
  for (int t = 0; t < tid; ++t) {
    const auto [tlo, thi] = range(t);
    const std::size_t first = ghost_rows.size();
    for (std::uint32_t k = start[tlo]; k < start[thi]; ++k) {
      const std::uint32_t j = entries[k] >> NeighbourList::kCodeBits;
      if (j >= lo && j < hi)
        ghost_rows.push_back(j);
    }
    std::sort(ghost_rows.begin() + first, ghost_rows.end());
    ghost_rows.erase(std::unique(ghost_rows.begin() + first, ghost_rows.end()), ghost_rows.end());
    ghost_start.push_back(std::uint32_t(ghost_rows.size()));
  }
  ghost_blocks.assign((hi - lo + 3) / 4, 0);
  for (const std::uint32_t j : ghost_rows)
    ghost_blocks[(j - lo) / 4] = 1;
  ghost_generation = list.inner_generation();
  ghost_threads = nthr;
}

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
  const std::uint32_t* start = list.inner_start().data();
  const std::uint32_t* entries = list.inner_entries().data();
  const auto& shift = NeighbourList::shifts();
  const std::size_t capacity = kBlock * std::max<std::size_t>(1, list.max_row());

  ThreadSums sums(nt);
  auto& [energy, vir, contacts, squared, drift2] = sums;
  const bool have_ref = list.inner_reference().size() == state.pos.size();
  const double* ref = list.inner_reference().data();

  double* fx = out.force.data();
  double* fy = fx + n;
  double* fz = fy + n;

#pragma omp parallel num_threads(nt)
  {
    const int tid = omp_get_thread_num();
    const int nthr = omp_get_num_threads();  // may be fewer than requested
    // Each thread owns a contiguous range of blocks and the forces of its particles: it
    // zeroes them, adds every pair force on them, and defers a force on a particle of another
    // thread's range (pairs across a range boundary, a thin layer of the cell order) to a
    // list that the owner adds after the barrier, in thread order: no races, no full-size
    // per-thread buffers, and a fixed summation order for a given thread count.
    const auto [lo, hi] = thread_range(start, n, tid, nthr);
    if (have_ref)
      drift2[tid] = NeighbourList::max_displacement2(state, ref, lo, hi);
    std::fill(fx + lo, fx + hi, 0.0);
    std::fill(fy + lo, fy + hi, 0.0);
    std::fill(fz + lo, fz + hi, 0.0);
    ContactScratch& cs = scratch_[tid];
    cs.resize(capacity);
    cs.reserve_deferred(start[hi] - start[lo]);  // at most one per listed pair
    Deferred* deferred = cs.deferred_rows.get();
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
            deferred[nd++] = {j, -crx[c], -cry[c], -crz[c]};
          }
        }
      }
      nc += m;
    }
    energy[tid] = u;
    vir[tid] << wxx, wyy, wzz, wxy, wxz, wyz;
    contacts[tid] = nc;
    cs.deferred = nd;
    if (nthr > 1) {
#pragma omp barrier
      // Every thread's forces on this range's particles, in thread order.
      for (int u = 0; u < nthr; ++u) {
        const ContactScratch& other = scratch_[u];
        for (std::size_t q = 0; q < other.deferred; ++q) {
          const Deferred& df = other.deferred_rows[q];
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

  sums.finish(out, have_ref);
}

// The vector kernel (alpha_r = 2, AVX-512VL). It walks the inner list as flat pairs, four at a
// time; the inner list is ~85 % contacts near jamming, so no gathering into contact buffers is
// needed. Positions and radii are first laid out as one 32-byte row per particle in real space
// (x, y, z, a_i), so a pair's data is one load per particle and a 4x4 transpose; the real-space
// image shifts h n of the 27 codes are a small table. Forces go to rows of the same shape, one
// add per particle per pair, and are copied to the SoA result at the end. Threads own ranges
// as in compute_impl; padding lanes point at an idle row of their thread.
#if JAMFLOW_VECTOR_KERNEL
namespace {

inline void transpose4(const __m256d* q, __m256d& x, __m256d& y, __m256d& z, __m256d& w) {
  const __m256d t0 = _mm256_unpacklo_pd(q[0], q[1]);  // x0 x1 z0 z1
  const __m256d t1 = _mm256_unpackhi_pd(q[0], q[1]);  // y0 y1 w0 w1
  const __m256d t2 = _mm256_unpacklo_pd(q[2], q[3]);  // x2 x3 z2 z3
  const __m256d t3 = _mm256_unpackhi_pd(q[2], q[3]);  // y2 y3 w2 w3
  x = _mm256_permute2f128_pd(t0, t2, 0x20);
  z = _mm256_permute2f128_pd(t0, t2, 0x31);
  y = _mm256_permute2f128_pd(t1, t3, 0x20);
  w = _mm256_permute2f128_pd(t1, t3, 0x31);
}

inline double lane_sum(__m256d v) {
  alignas(32) double t[4];
  _mm256_store_pd(t, v);
  return (t[0] + t[1]) + (t[2] + t[3]);
}

struct VectorSums {
  __m256d u, wxx, wyy, wzz, wxy, wxz, wyz;
  std::size_t contacts;
};

// A particle's row (h s, a) and its squared real-space displacement |h (s - ref)|^2 in a cell
// h, four particles at a time (rows transposed) or one. Every loop that writes rows or measures
// displacements goes through these, so a row has the same bits whichever loop made it.
struct CellMap {
  double xx, xy, yy, zz;
  __m256d vxx, vxy, vyy, vzz;
  explicit CellMap(const Eigen::Matrix3d& h)
      : xx(h(0, 0)),
        xy(h(0, 1)),
        yy(h(1, 1)),
        zz(h(2, 2)),
        vxx(_mm256_set1_pd(xx)),
        vxy(_mm256_set1_pd(xy)),
        vyy(_mm256_set1_pd(yy)),
        vzz(_mm256_set1_pd(zz)) {}
  // The rows of particles i..i+3 at (x, y, z), r[k] for particle i + k.
  void rows4(__m256d x, __m256d y, __m256d z, const double* diameter, std::size_t i,
             __m256d* r) const {
    const __m256d q[4] = {_mm256_fmadd_pd(vxy, y, _mm256_mul_pd(vxx, x)), _mm256_mul_pd(vyy, y),
                          _mm256_mul_pd(vzz, z),
                          _mm256_mul_pd(_mm256_set1_pd(0.5), _mm256_loadu_pd(diameter + i))};
    transpose4(q, r[0], r[1], r[2], r[3]);
  }
  __m256d displacement4(__m256d x, __m256d y, __m256d z, const double* ref, std::size_t n,
                        std::size_t i) const {
    const __m256d ux = _mm256_sub_pd(x, _mm256_loadu_pd(ref + i)),
                  uy = _mm256_sub_pd(y, _mm256_loadu_pd(ref + n + i)),
                  uz = _mm256_sub_pd(z, _mm256_loadu_pd(ref + 2 * n + i));
    const __m256d rx = _mm256_fmadd_pd(vxy, uy, _mm256_mul_pd(vxx, ux)),
                  ry = _mm256_mul_pd(vyy, uy), rz = _mm256_mul_pd(vzz, uz);
    return _mm256_fmadd_pd(rz, rz, _mm256_fmadd_pd(ry, ry, _mm256_mul_pd(rx, rx)));
  }
  void row1(double x, double y, double z, double diameter, double* row) const {
    row[0] = std::fma(xy, y, xx * x);
    row[1] = yy * y;
    row[2] = zz * z;
    row[3] = 0.5 * diameter;
  }
  double displacement1(double x, double y, double z, const double* ref, std::size_t n,
                       std::size_t i) const {
    const double ux = x - ref[i], uy = y - ref[n + i], uz = z - ref[2 * n + i];
    const double rx = std::fma(xy, uy, xx * ux), ry = yy * uy, rz = zz * uz;
    return std::fma(rz, rz, std::fma(ry, ry, rx * rx));
  }
};

// The rows of particles [lo, hi): (h s, a) from the scaled SoA positions s, four particles per
// transpose, with their force rows zeroed; in the same pass, the largest squared real-space
// displacement since `ref` (SoA scaled), NaN if a position is not finite (as
// NeighbourList::max_displacement2). One pass over the positions instead of three loops.
double lay_out_rows(const double* s, const double* ref, const double* diameter, std::size_t n,
                    const Eigen::Matrix3d& h, std::size_t lo, std::size_t hi, double* pos,
                    double* frc) {
  const CellMap cell(h);
  const __m256d zero = _mm256_setzero_pd();
  __m256d m = zero, sum = zero;
  std::size_t i = lo;
  for (; i + 4 <= hi; i += 4) {
    const __m256d x = _mm256_loadu_pd(s + i), y = _mm256_loadu_pd(s + n + i),
                  z = _mm256_loadu_pd(s + 2 * n + i);
    __m256d r[4];
    cell.rows4(x, y, z, diameter, i, r);
    for (int k = 0; k < 4; ++k) {
      _mm256_store_pd(pos + 4 * i + 4 * k, r[k]);
      _mm256_store_pd(frc + 4 * i + 4 * k, zero);
    }
    const __m256d d2 = cell.displacement4(x, y, z, ref, n, i);
    m = _mm256_max_pd(d2, m);  // a NaN never wins the max, but it poisons the sum
    sum = _mm256_add_pd(sum, d2);
  }
  alignas(32) double lanes[4];
  _mm256_store_pd(lanes, m);
  double mx = std::max(std::max(lanes[0], lanes[1]), std::max(lanes[2], lanes[3]));
  double total = lane_sum(sum);
  for (; i < hi; ++i) {
    const double x = s[i], y = s[n + i], z = s[2 * n + i];
    cell.row1(x, y, z, diameter[i], pos + 4 * i);
    std::fill(frc + 4 * i, frc + 4 * i + 4, 0.0);
    const double d2 = cell.displacement1(x, y, z, ref, n, i);
    mx = d2 > mx ? d2 : mx;
    total += d2;
  }
  return std::isfinite(total) ? mx : std::nan("");
}

// |F|^2 of four force rows transposed to (x, y, z) lanes, and of one row: the same expression,
// so that every loop over final forces gives the same sum (four lanes, then the rest).
inline __m256d squared4(__m256d x, __m256d y, __m256d z) {
  return _mm256_fmadd_pd(z, z, _mm256_fmadd_pd(y, y, _mm256_mul_pd(x, x)));
}
inline double squared1(const double* f) {
  return std::fma(f[2], f[2], std::fma(f[1], f[1], f[0] * f[0]));
}

// The final force rows of particles [lo, hi) into the SoA result f (n per component); returns
// sum |F|^2 over them.
double copy_force_rows(const double* frc, double* f, std::size_t n, std::size_t lo,
                       std::size_t hi) {
  __m256d acc = _mm256_setzero_pd();
  std::size_t i = lo;
  for (; i + 4 <= hi; i += 4) {
    const __m256d q[4] = {_mm256_load_pd(frc + 4 * i), _mm256_load_pd(frc + 4 * i + 4),
                          _mm256_load_pd(frc + 4 * i + 8), _mm256_load_pd(frc + 4 * i + 12)};
    __m256d x, y, z, w;
    transpose4(q, x, y, z, w);
    _mm256_storeu_pd(f + i, x);
    _mm256_storeu_pd(f + n + i, y);
    _mm256_storeu_pd(f + 2 * n + i, z);
    acc = _mm256_add_pd(acc, squared4(x, y, z));
  }
  double rest = 0.0;
  for (; i < hi; ++i) {
    for (int c = 0; c < 3; ++c)
      f[c * n + i] = frc[4 * i + c];
    rest += squared1(frc + 4 * i);
  }
  return lane_sum(acc) + rest;
}

// Which particles of a range drift_and_lay_out moves.
enum class DriftSet {
  kAll,
  kOthers,  // the blocks with no earlier thread's ghost: their forces are final first
  kGhosts,  // the rest, once the earlier threads' ghost rows have been added
};

// Explicit Euler for particles [lo, hi) with their final force rows, s += D F (Drift::apply's
// bits), fused with the next pass's layout: the rows (h s, a) of the moved particles in the
// cell h they move to, their force rows zeroed, and their largest squared displacement since
// `ref` in that cell (lay_out_rows's bits). Returns that displacement, NaN if a position is
// not finite; f2 gets sum |F|^2 (with kAll, copy_force_rows's bits). kOthers and kGhosts take
// the blocks of four particles from lo whose flag in `ghost` is clear or set.
//
// kGhosts writes its rows with streaming stores. An earlier thread's pair loop reads them (they
// are its partners' rows), so its core holds copies of their cache lines: an ordinary store
// would wait for that core to give each line up, and the stores queued behind it would stall
// the loop (this cost the later thread as much as its whole drift again). A streaming store
// does not wait for the line; both threads' next reads fetch it from memory, prefetched at the
// start of their pass (see compute_harmonic_vector).
template <DriftSet Set>
double drift_and_lay_out(const Drift& d, double* s, const double* ref, const double* diameter,
                         std::size_t n, const Eigen::Matrix3d& h, std::size_t lo, std::size_t hi,
                         double* pos, double* frc, double& f2, const std::uint8_t* ghost) {
  const auto takes = [&](std::size_t i) {
    if constexpr (Set == DriftSet::kAll)
      return true;
    else
      return (ghost[(i - lo) / 4] != 0) == (Set == DriftSet::kGhosts);
  };
  const CellMap cell(h);
  const __m256d zero = _mm256_setzero_pd();
  const __m256d dxx = _mm256_set1_pd(d.xx), dxy = _mm256_set1_pd(d.xy), dyy = _mm256_set1_pd(d.yy),
                dzz = _mm256_set1_pd(d.zz);
  __m256d m = zero, sum = zero, acc = zero;
  std::size_t i = lo;
  for (; i + 4 <= hi; i += 4) {
    if (!takes(i))
      continue;
    const __m256d g[4] = {_mm256_load_pd(frc + 4 * i), _mm256_load_pd(frc + 4 * i + 4),
                          _mm256_load_pd(frc + 4 * i + 8), _mm256_load_pd(frc + 4 * i + 12)};
    __m256d fx, fy, fz, fw;
    transpose4(g, fx, fy, fz, fw);
    const __m256d x =
        _mm256_add_pd(_mm256_loadu_pd(s + i), _mm256_fmadd_pd(dxx, fx, _mm256_mul_pd(dxy, fy)));
    const __m256d y = _mm256_fmadd_pd(dyy, fy, _mm256_loadu_pd(s + n + i));
    const __m256d z = _mm256_fmadd_pd(dzz, fz, _mm256_loadu_pd(s + 2 * n + i));
    __m256d r[4];
    cell.rows4(x, y, z, diameter, i, r);
    const __m256d d2 = cell.displacement4(x, y, z, ref, n, i);
    acc = _mm256_add_pd(acc, squared4(fx, fy, fz));
    for (int k = 0; k < 4; ++k)
      _mm256_store_pd(frc + 4 * i + 4 * k, zero);
    _mm256_storeu_pd(s + i, x);
    _mm256_storeu_pd(s + n + i, y);
    _mm256_storeu_pd(s + 2 * n + i, z);
    for (int k = 0; k < 4; ++k) {
      if constexpr (Set == DriftSet::kGhosts)
        _mm256_stream_pd(pos + 4 * i + 4 * k, r[k]);
      else
        _mm256_store_pd(pos + 4 * i + 4 * k, r[k]);
    }
    m = _mm256_max_pd(d2, m);  // a NaN never wins the max, but it poisons the sum
    sum = _mm256_add_pd(sum, d2);
  }
  if constexpr (Set == DriftSet::kGhosts)
    _mm_sfence();  // the streamed rows are in memory before the pass ends
  alignas(32) double lanes[4];
  _mm256_store_pd(lanes, m);
  double mx = std::max(std::max(lanes[0], lanes[1]), std::max(lanes[2], lanes[3]));
  double total = lane_sum(sum), rest = 0.0;
  // The last, partial block.
  const std::size_t tail_end = i < hi && takes(i) ? hi : i;
  for (; i < tail_end; ++i) {
    double* f = frc + 4 * i;
    rest += squared1(f);
    double x = s[i], y = s[n + i], z = s[2 * n + i];
    d.apply(x, y, z, f[0], f[1], f[2]);
    std::fill(f, f + 4, 0.0);
    s[i] = x;
    s[n + i] = y;
    s[2 * n + i] = z;
    cell.row1(x, y, z, diameter[i], pos + 4 * i);
    const double d2 = cell.displacement1(x, y, z, ref, n, i);
    mx = d2 > mx ? d2 : mx;
    total += d2;
  }
  f2 = lane_sum(acc) + rest;
  return std::isfinite(total) ? mx : std::nan("");
}

// Which forces a pass over pairs applies (see compute_harmonic_vector).
enum class PairMode {
  kAll,    // one thread: both forces of every pair
  kOwned,  // the pairs of owners in [lo, hi); a partner outside gets its force in a ghost row
};

// Pairs [k0, k1) of `owner`/`entries`: pair law, energy, virial and forces into the rows (kOwned:
// a partner outside [lo, hi) into the same row of `ghost` instead). Padding lanes use the
// thread's idle row, whose radius is 0, so a padding pair never touches.
//
// The loop is latency-bound (a chunk's loads, square root and division form a chain of about
// a hundred cycles), so it is software-pipelined: the rows of chunk c + 1 are loaded while
// chunk c is evaluated, and 1/r comes from a 14-bit estimate refined by two Newton steps
// (relative error ~1e-16) rather than a square root followed by a division.
template <PairMode Mode>
VectorSums vector_pairs(const double* pos, const double* shift, double* frc, double* ghost,
                        const std::uint32_t* owner, const std::uint32_t* entries, std::size_t k0,
                        std::size_t k1, std::size_t lo, std::size_t hi, std::size_t idle) {
  constexpr unsigned kBits = NeighbourList::kCodeBits;
  constexpr std::size_t kCode = NeighbourList::kCodeMask;
  constexpr std::size_t kZeroShift = 13;  // image code of n = (0, 0, 0)
  const char* prow = reinterpret_cast<const char*>(pos);
  const char* srow = reinterpret_cast<const char*>(shift);
  char* frow = reinterpret_cast<char*>(frc);
  char* grow = reinterpret_cast<char*>(ghost);
  const std::size_t lo_off = lo << kBits, span = (hi - lo) << kBits;
  const std::size_t idle_off = idle << kBits;
  const __m256d one = _mm256_set1_pd(1.0), half = _mm256_set1_pd(0.5),
                three_halves = _mm256_set1_pd(1.5), zero = _mm256_setzero_pd();
  __m256d u = zero, wxx = zero, wyy = zero, wzz = zero, wxy = zero, wxz = zero, wyz = zero;
  std::size_t nc = 0;

  // A chunk is four pairs, given by their owners and entries. Its rows, one per pair:
  // (r_ij, a_i + a_j) = row_i + h n - row_j * (1, 1, 1, -1), where r_ij = x_i - (x_j - h n).
  // The byte offsets are recomputed where they are used rather than kept across the pipeline
  // stages, which would take more general registers than there are.
  const __m256d sign = _mm256_setr_pd(1.0, 1.0, 1.0, -1.0);
  const auto load = [&](const std::uint32_t* own, const std::uint32_t* ent, __m256d* d) {
    for (int l = 0; l < 4; ++l) {
      const std::size_t e = ent[l];
      const __m256d qi = _mm256_add_pd(
          _mm256_load_pd(reinterpret_cast<const double*>(prow + (std::size_t(own[l]) << kBits))),
          _mm256_load_pd(reinterpret_cast<const double*>(srow + ((e & kCode) << 5))));
      d[l] = _mm256_fnmadd_pd(_mm256_load_pd(reinterpret_cast<const double*>(prow + (e & ~kCode))),
                              sign, qi);
    }
  };
  const auto evaluate = [&](const std::uint32_t* own, const std::uint32_t* ent, const __m256d* d) {
    __m256d rx, ry, rz, a;
    transpose4(d, rx, ry, rz, a);
    const __m256d r2 = _mm256_fmadd_pd(rz, rz, _mm256_fmadd_pd(ry, ry, _mm256_mul_pd(rx, rx)));
    const __mmask8 touch = _mm256_cmp_pd_mask(r2, _mm256_mul_pd(a, a), _CMP_LT_OQ);
    nc += std::size_t(__builtin_popcount(touch));
    // 1/r for every lane (padding lanes give inf or NaN, masked below).
    const __m256d h = _mm256_mul_pd(half, r2);
    __m256d s = _mm256_rsqrt14_pd(r2);
    s = _mm256_mul_pd(s, _mm256_fnmadd_pd(h, _mm256_mul_pd(s, s), three_halves));
    s = _mm256_mul_pd(s, _mm256_fnmadd_pd(h, _mm256_mul_pd(s, s), three_halves));
    const __m256d inv_a = _mm256_div_pd(one, a);
    // HarmonicPair: delta = 1 - r/a, |f| = delta / a; zero on the lanes that do not touch.
    const __m256d delta =
        _mm256_maskz_mov_pd(touch, _mm256_fnmadd_pd(_mm256_mul_pd(r2, s), inv_a, one));
    const __m256d f_over_r = _mm256_maskz_mul_pd(touch, _mm256_mul_pd(delta, inv_a), s);
    const __m256d gx = _mm256_mul_pd(f_over_r, rx), gy = _mm256_mul_pd(f_over_r, ry),
                  gz = _mm256_mul_pd(f_over_r, rz);
    u = _mm256_fmadd_pd(delta, delta, u);
    wxx = _mm256_fmadd_pd(rx, gx, wxx);
    wyy = _mm256_fmadd_pd(ry, gy, wyy);
    wzz = _mm256_fmadd_pd(rz, gz, wzz);
    wxy = _mm256_fmadd_pd(rx, gy, wxy);
    wxz = _mm256_fmadd_pd(rx, gz, wxz);
    wyz = _mm256_fmadd_pd(ry, gz, wyz);
    // Pair forces as rows: f/r times the pair's row, its fourth entry masked to 0.
    const __m256d g[4] = {_mm256_maskz_mul_pd(0x7, _mm256_permute4x64_pd(f_over_r, 0x00), d[0]),
                          _mm256_maskz_mul_pd(0x7, _mm256_permute4x64_pd(f_over_r, 0x55), d[1]),
                          _mm256_maskz_mul_pd(0x7, _mm256_permute4x64_pd(f_over_r, 0xAA), d[2]),
                          _mm256_maskz_mul_pd(0x7, _mm256_permute4x64_pd(f_over_r, 0xFF), d[3])};
    for (int l = 0; l < 4; ++l) {
      const std::size_t io = std::size_t(own[l]) << kBits, jo = ent[l] & ~kCode;
      double* fi = reinterpret_cast<double*>(frow + io);
      _mm256_store_pd(fi, _mm256_add_pd(_mm256_load_pd(fi), g[l]));
      char* base = frow;
      if constexpr (Mode == PairMode::kOwned)  // a select, not a branch
        base = jo - lo_off < span ? frow : grow;
      double* fj = reinterpret_cast<double*>(base + jo);
      _mm256_store_pd(fj, _mm256_sub_pd(_mm256_load_pd(fj), g[l]));
    }
  };

  // Full chunks, pipelined one deep (unrolled twice so that both stages stay in registers).
  const std::size_t full = k0 + (k1 - k0) / 4 * 4;
  if (k0 < full) {
    __m256d da[4], db[4];
    load(owner + k0, entries + k0, da);
    std::size_t k = k0 + 4;
    for (; k + 4 < full; k += 8) {
      load(owner + k, entries + k, db);
      evaluate(owner + k - 4, entries + k - 4, da);
      load(owner + k + 4, entries + k + 4, da);
      evaluate(owner + k, entries + k, db);
    }
    if (k < full) {
      load(owner + k, entries + k, db);
      evaluate(owner + k - 4, entries + k - 4, da);
      evaluate(owner + k, entries + k, db);
    } else {
      evaluate(owner + k - 4, entries + k - 4, da);
    }
  }
  if (full < k1) {  // the last, partial chunk; padding pairs are (idle, idle)
    std::uint32_t own[4], ent[4];
    for (std::size_t l = 0; l < 4; ++l) {
      const bool real = full + l < k1;
      own[l] = real ? owner[full + l] : std::uint32_t(idle);
      ent[l] = real ? entries[full + l] : std::uint32_t(idle_off | kZeroShift);
    }
    __m256d d[4];
    load(own, ent, d);
    evaluate(own, ent, d);
  }
  return {u, wxx, wyy, wzz, wxy, wxz, wyz, nc};
}

}  // namespace

// Waits for each earlier thread's pair loop (its flag) and adds its ghost rows for this
// thread's range to the force rows, in thread order; then raises this thread's `added_` flag.
void ForceField::add_ghost_rows(int tid, std::uint64_t pass, std::size_t rows, double* ghosts,
                                double* frc) const {
  if (!ghosts)  // one thread
    return;
  const ContactScratch& cs = scratch_[tid];
  for (int t = 0; t < tid; ++t) {
    while (done_.flags[t].pass.load(std::memory_order_acquire) != pass)
      _mm_pause();
    double* theirs = ghosts + std::size_t(t) * 4 * rows;
    for (std::uint32_t q = cs.ghost_start[t]; q < cs.ghost_start[t + 1]; ++q) {
      const std::size_t j = 4 * std::size_t(cs.ghost_rows[q]);
      _mm256_store_pd(frc + j, _mm256_add_pd(_mm256_load_pd(frc + j), _mm256_load_pd(theirs + j)));
    }
  }
  added_.flags[tid].pass.store(pass, std::memory_order_release);
}

bool ForceField::compute_harmonic_vector(const State& state, const NeighbourList& list,
                                         ForceResult& out, const Drift* drift, double* moved,
                                         const Eigen::Matrix3d* next, bool untouched) const {
  const std::size_t n = state.size();
  // A drifting pass keeps no forces: sizing the result would zero 24 bytes per particle for
  // nothing (its caller leaves it empty).
  if (!drift)
    out.force.resize(3 * n);
  const int nt = threads_;
  if (int(scratch_.size()) < nt)
    scratch_.resize(nt);
  const std::size_t rows = n + kSpareRows * std::size_t(nt);
  // Position and force rows in one buffer, the force rows half a page (2 KiB) further on, modulo
  // 4 KiB, than the position rows: a load of a particle's position and a store to a nearby
  // particle's force then never share their address bits below 4 KiB, which the processor may
  // take for a dependence (4K aliasing). A precaution: no difference was measurable here.
  const std::size_t page = 512, span = (4 * rows + page - 1) / page * page;  // in doubles
  double* pos = aligned_rows(rows_, span + page / 2 + 4 * rows + page);
  pos += (page - (reinterpret_cast<std::uintptr_t>(pos) / sizeof(double)) % page) % page;
  double* frc = pos + span + page / 2;
  // Ghost rows (several threads): zero between passes (see below).
  double* ghosts = nullptr;
  if (nt > 1) {
    if (ghosts_.size() != std::size_t(nt) * 4 * rows + 8)
      ghosts_.assign(std::size_t(nt) * 4 * rows + 8, 0.0);
    ghosts = aligned_rows(ghosts_, std::size_t(nt) * 4 * rows);
    if (done_.count < nt) {
      done_.flags = std::make_unique<PassFlag[]>(nt);
      done_.count = nt;
      added_.flags = std::make_unique<PassFlag[]>(nt);
      added_.count = nt;
    }
  }
  const std::uint64_t pass = ++passes_;

  const Eigen::Matrix3d h = state.box.h();
  const double hxx = h(0, 0), hxy = h(0, 1), hyy = h(1, 1), hzz = h(2, 2);
  alignas(64) double shift[27 * 4];
  for (int c = 0; c < 27; ++c) {
    const auto& sh = NeighbourList::shifts()[c];
    shift[4 * c] = hxx * sh[0] + hxy * sh[1];
    shift[4 * c + 1] = hyy * sh[1];
    shift[4 * c + 2] = hzz * sh[2];
    shift[4 * c + 3] = 0.0;
  }
  const std::uint32_t* start = list.inner_start().data();
  const std::uint32_t* entries = list.inner_entries().data();
  const std::uint32_t* owner = list.inner_owner().data();

  ThreadSums sums(nt);
  auto& [energy, vir, contacts, squared, drift2] = sums;
  const bool have_ref = list.inner_reference().size() == state.pos.size();
  const double* ref = list.inner_reference().data();
  double* fx = out.force.data();  // empty with a drift
  // With a drift, the pass goes on only if the list holds; every thread decides the same.
  const double allowed = drift ? list.inner_drift_allowed(state) : 0.0;
  bool holds = true;
  // The rows the previous pass laid out ahead, if they are this state's (see
  // compute_and_drift); then the list check needs only their displacements. Any pass uses
  // them up: a pass that does not drift leaves forces in the rows.
  const bool reuse = drift && untouched && have_ref && ahead_.valid &&
                     ahead_.generation == list.inner_generation() && ahead_.n == n &&
                     ahead_.threads == nt && ahead_.h[0] == hxx && ahead_.h[1] == hxy &&
                     ahead_.h[2] == hyy && ahead_.h[3] == hzz;
  ahead_.valid = false;
  // Whether the list holds, from each thread's largest displacement (NaN: a position is not
  // finite), as NeighbourList::inner_holds decides.
  const auto list_holds = [&] {
    double m = 0.0;
    bool finite = true;
    for (const double d2 : drift2) {
      finite = finite && !std::isnan(d2);
      m = std::max(m, d2);
    }
    return have_ref && finite && std::sqrt(m) <= allowed;
  };
  if (reuse) {
    ++reused_;
    drift2 = ahead_.drift2;
    holds = list_holds();
    if (!holds) {
      sums.finish(out, have_ref);
      return false;
    }
  }
  if (next)
    ahead_.drift2.assign(nt, 0.0);

#pragma omp parallel num_threads(nt)
  {
    const int tid = omp_get_thread_num();
    const int nthr = omp_get_num_threads();
    const auto [lo, hi] = thread_range(start, n, tid, nthr);
    const std::size_t idle = n + kSpareRows * std::size_t(tid);
    if (!reuse) {
      // Without a reference the displacement is not used (finish() reports it as infinite).
      drift2[tid] = lay_out_rows(state.pos.data(), have_ref ? ref : state.pos.data(),
                                 state.diameter.data(), n, h, lo, hi, pos, frc);
      // The idle row: radius 0 at the origin, so a padding pair (idle, idle) never touches.
      std::fill(pos + 4 * idle, pos + 4 * (idle + kSpareRows), 0.0);
      std::fill(frc + 4 * idle, frc + 4 * (idle + kSpareRows), 0.0);
    }
    ContactScratch& cs = scratch_[tid];
    if (nthr > 1)
      cs.ghost_lists(list, tid, nthr);
    // Reused rows were written before the previous pass ended. Fresh ones: every row is written
    // before any thread reads its neighbours (a barrier in a branch every thread takes alike).
    if (!reuse) {
#pragma omp barrier
    }
    bool go = true;
    if (drift && !reuse) {
      go = list_holds();
      if (tid == 0)
        holds = go;  // every thread decides the same; if not, the caller renews the list
    }
    if (go) {
      // With several threads, a pair whose partner lies in a later thread's range puts the
      // partner's force in a ghost row of the owner's thread. Once that thread's pair loop is
      // done (its flag), the partner's thread adds the ghost rows of its particles to their
      // force rows, in thread order. Only later threads wait for earlier ones, so there is no
      // second barrier; the first thread waits for none.
      const std::uint32_t k0 = start[lo], k1 = start[hi];
      VectorSums lanes;
      // Once a particle's force is final: its part of the squared sum, and its copy to the
      // result or its drift. The drift also lays out the rows of the next pass: no later thread
      // reads this range's rows, and every earlier one that does has finished its pair loop.
      const auto drift_set = [&]<DriftSet Set>(double& f2) {
        return drift_and_lay_out<Set>(*drift, moved, ref, state.diameter.data(), n, *next, lo, hi,
                                      pos, frc, f2, cs.ghost_blocks.data());
      };
      // This thread's ghost rows (several threads).
      double* mine = nthr > 1 ? ghosts + std::size_t(tid) * 4 * rows : nullptr;
      if (nthr == 1) {
        lanes = vector_pairs<PairMode::kAll>(pos, shift, frc, nullptr, owner, entries, k0, k1, lo,
                                             hi, idle);
      } else {
        // Reused rows that the previous pass streamed to memory (see drift_and_lay_out): this
        // thread's partners in later ranges and its own blocks that earlier threads read.
        // Requested all at once, their loads overlap; met one by one, each would stall the loop.
        if (reuse) {
          const auto fetch = [&](std::size_t j) {
            _mm_prefetch(reinterpret_cast<const char*>(pos + 4 * j), _MM_HINT_T0);
          };
          for (const std::uint32_t j : cs.written)
            fetch(j);
          for (std::size_t b = 0; b < cs.ghost_blocks.size(); ++b) {
            if (cs.ghost_blocks[b]) {
              for (std::size_t j = lo + 4 * b; j < std::min(lo + 4 * b + 4, hi); ++j)
                fetch(j);
            }
          }
        }
        lanes = vector_pairs<PairMode::kOwned>(pos, shift, frc, mine, owner, entries, k0, k1, lo,
                                               hi, idle);
        done_.flags[tid].pass.store(pass, std::memory_order_release);
      }
      if (drift && tid > 0) {
        // A later thread first moves the particles that no earlier thread's pair touches, then
        // waits for the earlier threads and adds their ghost rows, then moves the rest. The
        // wait thus overlaps most of the drift.
        double f2a = 0.0, f2b = 0.0;
        const double d2a = drift_set.template operator()<DriftSet::kOthers>(f2a);
        add_ghost_rows(tid, pass, rows, ghosts, frc);
        const double d2b = drift_set.template operator()<DriftSet::kGhosts>(f2b);
        squared[tid] = f2a + f2b;
        ahead_.drift2[tid] = std::isnan(d2a) || std::isnan(d2b) ? d2a + d2b : std::max(d2a, d2b);
      } else {
        add_ghost_rows(tid, pass, rows, ghosts, frc);
        if (drift)
          ahead_.drift2[tid] = drift_set.template operator()<DriftSet::kAll>(squared[tid]);
        else
          squared[tid] = copy_force_rows(frc, fx, n, lo, hi);
      }
      energy[tid] = 0.5 * lane_sum(lanes.u);
      vir[tid] << lane_sum(lanes.wxx), lane_sum(lanes.wyy), lane_sum(lanes.wzz),
          lane_sum(lanes.wxy), lane_sum(lanes.wxz), lane_sum(lanes.wyz);
      contacts[tid] = lanes.contacts;
      if (tid + 1 < nthr) {
        // This thread's ghost rows start the next pass at zero. Zeroed by their writer once
        // their readers are done, rather than by their readers after adding them: a cache line
        // then changes core twice per pass, not three or four times. And at the end of the pass
        // rather than before the pair loop: the stores wait for the readers' cores to give the
        // lines up, which now overlaps the later threads' drift.
        for (int u = tid + 1; u < nthr; ++u) {
          while (added_.flags[u].pass.load(std::memory_order_acquire) != pass)
            _mm_pause();
        }
        for (const std::uint32_t j : cs.written)
          _mm256_store_pd(mine + 4 * std::size_t(j), _mm256_setzero_pd());
      }
    }
  }

  sums.finish(out, have_ref);
  if (drift && holds) {
    ahead_.valid = true;
    ahead_.generation = list.inner_generation();
    ahead_.n = n;
    ahead_.threads = nt;
    const double hn[4] = {(*next)(0, 0), (*next)(0, 1), (*next)(1, 1), (*next)(2, 2)};
    std::copy(hn, hn + 4, ahead_.h);
  }
  return holds;
}
#else
bool ForceField::compute_harmonic_vector(const State& state, const NeighbourList& list,
                                         ForceResult& out, const Drift*, double*,
                                         const Eigen::Matrix3d*, bool) const {
  compute_impl(HarmonicPair{}, state, list, out);  // not reached: vector_kernel() is false
  return true;
}
#endif

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
  out.max_drift2 = std::numeric_limits<double>::infinity();  // no list, no reference
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

}  // namespace jamflow
