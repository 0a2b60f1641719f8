// The simd backend: one pair loop, written once with Google Highway and compiled for every
// x86-64 target Highway knows (AVX-512, AVX2, SSE4, ...); the best target this CPU runs is
// picked at run time (HWY_DYNAMIC_DISPATCH), so one binary runs anywhere.
//
// The pass. Each thread lays out its particles as 32-byte rows (x, y, z, a_i) in real space
// (one load per particle per pair), then walks its share of the inner list as flat pairs,
// four at a time: the rows of the four i, the four j and the four image shifts are loaded and
// transposed to coordinate vectors, the pair law (lib/potential.hpp, the same template the
// other backends use) runs on them, and the four pair forces are transposed back and added to
// force rows of the same shape. Targets narrower than 256 bits run the same loop one pair at a
// time.
//
// Threads. Each thread owns a contiguous range of particles and the pairs stored at them. A
// partner in another thread's range is a ghost: the thread copies its row into a ghost row of
// its own at the start of the pass, its pair forces go to that ghost's force row, and after the
// pair loops the owner adds the ghost force rows of the other threads, in thread order; so a
// given thread count always gives the same bits. Rows are shared between cores only in these
// two contiguous copies: a cache line that moves between cores costs about 0.2 us on the
// machines this runs on, too much to pay inside the pair loop.
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "lib/error.hpp"
#include "lib/kernels/backend.hpp"
#include "lib/kernels/passes.hpp"
#include "lib/kernels/simd.hpp"
#include "lib/potential.hpp"

// One pair loop: the pairs [k0, k1) of the thread that owns the particles [lo, hi).
namespace jamflow::kernels::simd_detail {
#ifndef JAMFLOW_SIMD_DETAIL_ONCE
#define JAMFLOW_SIMD_DETAIL_ONCE
struct PairLoop {
  const double* pos;             // rows (x, y, z, a_i), 4 doubles per particle, 32-byte aligned
  double* frc;                   // force rows, same layout
  const double* shift;           // real-space image shifts, one row per image code
  const std::uint32_t* owner;    // the pairs' owners' rows
  const std::uint32_t* entries;  // their partners' rows << kCodeBits | image code
  std::size_t k0, k1;
  std::uint32_t idle;  // a row of this thread's at the origin with radius 0 (padding lanes)
  double alpha;
  // Results.
  double energy, virial[6];  // xx yy zz xy xz yz
  std::size_t contacts;
};
// A thread's rows: particles [lo, hi) of n, laid out in the cell h (xx, xy, yy, zz).
struct Rows {
  const double* s;    // scaled SoA positions
  const double* ref;  // the inner list's reference positions (same layout)
  const double* diameter;
  std::size_t n, lo, hi;
  double hxx, hxy, hyy, hzz;
  double* pos;
  double* frc;
};
#endif
}  // namespace jamflow::kernels::simd_detail

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "lib/kernels/simd.cpp"
// clang-format off
#include <hwy/foreach_target.h>  // must come before highway.h: re-includes this file per target
#include <hwy/highway.h>
#include <hwy/contrib/math/math-inl.h>
#include <hwy/aligned_allocator.h>
// clang-format on

HWY_BEFORE_NAMESPACE();
namespace jamflow::kernels::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;
using simd_detail::PairLoop;

// The pair laws, compiled for this target (see lib/pair_laws.inl).
#include "lib/pair_laws.inl"

// The law of an evaluator from lib/potential.hpp, on this target's arithmetic.
template <class Math, class V>
HWY_INLINE V Law(const HarmonicPair&, const Math& m, V r2, V a, V& f_over_r) {
  return HarmonicLaw::eval(m, r2, a, f_over_r);
}
template <class Math, class V>
HWY_INLINE V Law(const PowerPair& pair, const Math& m, V r2, V a, V& f_over_r) {
  return PowerLaw::eval(m, r2, a, f_over_r, pair.alpha_r);
}

const char* TargetName() {
  return hwy::TargetName(HWY_TARGET);
}

// One particle at a time from `from` on: the rows and displacements of LayOut (the largest and
// the sum of the squared displacements are updated), and CopyOut's forces and drift (returns
// the sum of |F|^2). The vector loops end with these for their last few particles; targets
// narrower than 256 bits use them throughout.
void LayOutFrom(const simd_detail::Rows& a, std::size_t from, double& mx, double& total) {
  const std::size_t n = a.n;
  for (std::size_t i = from; i < a.hi; ++i) {
    const double x = a.s[i], y = a.s[n + i], z = a.s[2 * n + i];
    double* r = a.pos + 4 * i;
    r[0] = a.hxx * x + a.hxy * y;
    r[1] = a.hyy * y;
    r[2] = a.hzz * z;
    r[3] = 0.5 * a.diameter[i];
    std::fill(a.frc + 4 * i, a.frc + 4 * i + 4, 0.0);
    const double ux = x - a.ref[i], uy = y - a.ref[n + i], uz = z - a.ref[2 * n + i];
    const double rx = a.hxx * ux + a.hxy * uy, ry = a.hyy * uy, rz = a.hzz * uz;
    const double d2 = rx * rx + ry * ry + rz * rz;
    mx = d2 > mx ? d2 : mx;
    total += d2;
  }
}

double CopyOutFrom(const double* frc, double* f, std::size_t n, std::size_t from, std::size_t hi,
                   const double* drift, double* s) {
  double f2 = 0.0;
  for (std::size_t i = from; i < hi; ++i) {
    for (int c = 0; c < 3; ++c) {
      f[c * n + i] = frc[4 * i + c];
      f2 += frc[4 * i + c] * frc[4 * i + c];
    }
    if (drift) {
      const Drift dr{drift[0], drift[1], drift[2], drift[3]};
      dr.apply(s[i], s[n + i], s[2 * n + i], f[i], f[n + i], f[2 * n + i]);
    }
  }
  return f2;
}

#if HWY_ARCH_X86 && HWY_TARGET <= HWY_AVX2
constexpr bool kVector = true;
using D = hn::Full256<double>;
using V = hn::Vec<D>;

// The arithmetic of lib/potential.hpp's laws on vectors of four pairs.
struct VecMath {
  D d;
  V splat(double c) const { return hn::Set(d, c); }
  V sqrt(V x) const { return hn::Sqrt(x); }
  // x^p for x in (0, 1]: exact shortcuts for the exponents the studies use (alpha_r = 1.5, 2.5,
  // 3), exp(p log x) otherwise.
  V pow(V x, double p) const {
    if (p == 0.5)
      return hn::Sqrt(x);
    if (p == 1.5)
      return hn::Mul(x, hn::Sqrt(x));
    if (p == 2.0)
      return hn::Mul(x, x);
    return hn::Exp(d, hn::Mul(hn::Log(d, x), hn::Set(d, p)));
  }
};

// Rows q0..q3 (four lanes each) to columns x, y, z, w.
HWY_INLINE void Transpose(D d, V q0, V q1, V q2, V q3, V& x, V& y, V& z, V& w) {
  const V t0 = hn::InterleaveLower(d, q0, q1);  // x0 x1 | z0 z1
  const V t1 = hn::InterleaveUpper(d, q0, q1);  // y0 y1 | w0 w1
  const V t2 = hn::InterleaveLower(d, q2, q3);
  const V t3 = hn::InterleaveUpper(d, q2, q3);
  x = hn::ConcatLowerLower(d, t2, t0);
  y = hn::ConcatLowerLower(d, t3, t1);
  z = hn::ConcatUpperUpper(d, t2, t0);
  w = hn::ConcatUpperUpper(d, t3, t1);
}

HWY_INLINE double LaneSum(D d, V v) {
  return hn::GetLane(hn::SumOfLanes(d, v));
}

// Four pairs: their rows d_l = (r_ij, a_i + a_j) = (row_i + h n) - row_j * (1, 1, 1, -1), as
// four lanes each, and their owners' and partners' row offsets (in doubles).
struct Chunk {
  V d[4];
  std::size_t io[4], jo[4];
};

// The chunk of the pairs given by their owners and entries; j's entry is j << 5 | code, and a row
// is four doubles, so (entry >> 5) << 2 is the partner's row offset.
HWY_INLINE void LoadChunk(D d, const double* pos, const double* shift, V sign,
                          const std::uint32_t* own, const std::uint32_t* ent, Chunk& c) {
  for (int l = 0; l < 4; ++l) {
    const std::uint32_t e = ent[l];
    c.io[l] = std::size_t(own[l]) << 2;
    c.jo[l] = std::size_t(e >> NeighbourList::kCodeBits) << 2;
    const V qi = hn::Add(hn::Load(d, pos + c.io[l]),
                         hn::Load(d, shift + (std::size_t(e & NeighbourList::kCodeMask) << 2)));
    c.d[l] = hn::NegMulAdd(hn::Load(d, pos + c.jo[l]), sign, qi);
  }
}

struct Sums {
  V u, wxx, wyy, wzz, wxy, wxz, wyz;
  std::size_t contacts = 0;
  hn::Indices256<double> lane[4];  // permutations that spread lane l over all four
};

// The pair law on a chunk, and its pair forces added to the rows of both particles.
template <class Pair>
HWY_INLINE void EvaluateChunk(D d, const Pair& pair, const Chunk& c, double* frc, Sums& s) {
  const VecMath m{d};
  V rx, ry, rz, a;
  Transpose(d, c.d[0], c.d[1], c.d[2], c.d[3], rx, ry, rz, a);
  const V r2 = hn::MulAdd(rz, rz, hn::MulAdd(ry, ry, hn::Mul(rx, rx)));
  const auto touch = hn::Lt(r2, hn::Mul(a, a));
  s.contacts += hn::CountTrue(d, touch);
  // Lanes that do not touch compute nonsense (even NaN) that the mask drops.
  V f_over_r;
  const V e = Law(pair, m, r2, a, f_over_r);
  f_over_r = hn::IfThenElseZero(touch, f_over_r);
  s.u = hn::Add(s.u, hn::IfThenElseZero(touch, e));
  const V gx = hn::Mul(f_over_r, rx), gy = hn::Mul(f_over_r, ry), gz = hn::Mul(f_over_r, rz);
  s.wxx = hn::MulAdd(rx, gx, s.wxx);
  s.wyy = hn::MulAdd(ry, gy, s.wyy);
  s.wzz = hn::MulAdd(rz, gz, s.wzz);
  s.wxy = hn::MulAdd(rx, gy, s.wxy);
  s.wxz = hn::MulAdd(rx, gz, s.wxz);
  s.wyz = hn::MulAdd(ry, gz, s.wyz);
  // Pair force rows: f/r times the pair's row. The fourth lane (f/r times a_ij) is never read.
  // Lane l of f/r is spread by a permutation in registers: a store and four reloads of its
  // lanes would wait for store forwarding.
  const V fr[4] = {
      hn::TableLookupLanes(f_over_r, s.lane[0]), hn::TableLookupLanes(f_over_r, s.lane[1]),
      hn::TableLookupLanes(f_over_r, s.lane[2]), hn::TableLookupLanes(f_over_r, s.lane[3])};
  for (int l = 0; l < 4; ++l) {
    const V g = hn::Mul(fr[l], c.d[l]);
    double* fi = frc + c.io[l];
    hn::Store(hn::Add(hn::Load(d, fi), g), d, fi);
    double* fj = frc + c.jo[l];
    hn::Store(hn::Sub(hn::Load(d, fj), g), d, fj);
  }
}

template <class Pair>
HWY_INLINE void Loop(const Pair& pair, PairLoop& p) {
  const D d;
  alignas(32) static constexpr double kSign[4] = {1.0, 1.0, 1.0, -1.0};
  const V zero = hn::Zero(d), sign = hn::Load(d, kSign);
  Sums s{zero, zero, zero, zero, zero, zero, zero, 0, {}};
  for (int l = 0; l < 4; ++l) {
    const std::int64_t idx[4] = {l, l, l, l};
    s.lane[l] = hn::SetTableIndices(d, idx);
  }
  const double* pos = p.pos;
  const double* shift = p.shift;
  double* frc = p.frc;
  const std::uint32_t* owner = p.owner;
  const std::uint32_t* entries = p.entries;
  const std::size_t k0 = p.k0, k1 = p.k1, full = k0 + (k1 - k0) / 4 * 4;
  // Full chunks. With 32 vector registers (AVX-512) the next chunk's rows are loaded while the
  // current one is evaluated; with 16 (AVX2) that would spill, and one chunk at a time is faster.
  if (HWY_TARGET == HWY_AVX2) {
    for (std::size_t k = k0; k < full; k += 4) {
      Chunk a;
      LoadChunk(d, pos, shift, sign, owner + k, entries + k, a);
      EvaluateChunk(d, pair, a, frc, s);
    }
  } else if (k0 < full) {
    Chunk a, b;
    LoadChunk(d, pos, shift, sign, owner + k0, entries + k0, a);
    std::size_t k = k0 + 4;
    for (; k + 4 < full; k += 8) {
      LoadChunk(d, pos, shift, sign, owner + k, entries + k, b);
      EvaluateChunk(d, pair, a, frc, s);
      LoadChunk(d, pos, shift, sign, owner + k + 4, entries + k + 4, a);
      EvaluateChunk(d, pair, b, frc, s);
    }
    if (k < full) {
      LoadChunk(d, pos, shift, sign, owner + k, entries + k, b);
      EvaluateChunk(d, pair, a, frc, s);
      EvaluateChunk(d, pair, b, frc, s);
    } else {
      EvaluateChunk(d, pair, a, frc, s);
    }
  }
  if (full < k1) {  // the last, partial chunk: padding pairs are (idle, idle) with no shift
    std::uint32_t own[4], ent[4];
    for (std::size_t l = 0; l < 4; ++l) {
      const bool real = full + l < k1;
      own[l] = real ? owner[full + l] : p.idle;
      ent[l] = real ? entries[full + l] : (p.idle << NeighbourList::kCodeBits) | 13u;
    }
    Chunk c;
    LoadChunk(d, pos, shift, sign, own, ent, c);
    // Padding pairs join the idle row to itself: their forces are zero.
    EvaluateChunk(d, pair, c, frc, s);
  }
  p.energy = LaneSum(d, s.u);
  const V w[6] = {s.wxx, s.wyy, s.wzz, s.wxy, s.wxz, s.wyz};
  for (int c = 0; c < 6; ++c)
    p.virial[c] = LaneSum(d, w[c]);
  p.contacts = s.contacts;
}

// The cell of a layout, h (xx, xy, yy, zz), as vectors.
struct Cell {
  V xx, xy, yy, zz;
  explicit Cell(D d, const simd_detail::Rows& a)
      : xx(hn::Set(d, a.hxx)),
        xy(hn::Set(d, a.hxy)),
        yy(hn::Set(d, a.hyy)),
        zz(hn::Set(d, a.hzz)) {}
};
// The rows of particles i..i+3 at the scaled positions (x, y, z) (lanes), (h s, a), with their
// force rows zeroed, and their squared real-space displacements since `ref` folded into m (the
// largest) and sum.
HWY_INLINE void LayOutBlock(D d, const simd_detail::Rows& a, const Cell& c, std::size_t i, V x, V y,
                            V z, V& m, V& sum) {
  const std::size_t n = a.n;
  const double* ref = a.ref;
  const V zero = hn::Zero(d);
  V r[4];
  Transpose(d, hn::MulAdd(c.xy, y, hn::Mul(c.xx, x)), hn::Mul(c.yy, y), hn::Mul(c.zz, z),
            hn::Mul(hn::Set(d, 0.5), hn::LoadU(d, a.diameter + i)), r[0], r[1], r[2], r[3]);
  for (std::size_t k = 0; k < 4; ++k) {
    hn::Store(r[k], d, a.pos + 4 * (i + k));
    hn::Store(zero, d, a.frc + 4 * (i + k));
  }
  const V ux = hn::Sub(x, hn::LoadU(d, ref + i)), uy = hn::Sub(y, hn::LoadU(d, ref + n + i)),
          uz = hn::Sub(z, hn::LoadU(d, ref + 2 * n + i));
  const V rx = hn::MulAdd(c.xy, uy, hn::Mul(c.xx, ux)), ry = hn::Mul(c.yy, uy),
          rz = hn::Mul(c.zz, uz);
  const V d2 = hn::MulAdd(rz, rz, hn::MulAdd(ry, ry, hn::Mul(rx, rx)));
  m = hn::Max(m, d2);  // a NaN never wins the max, but it poisons the sum
  sum = hn::Add(sum, d2);
}

// The largest squared displacement of LayOut's lanes m and sum and the particles from i on.
HWY_INLINE double LayOutRest(D d, const simd_detail::Rows& a, std::size_t i, V m, V sum) {
  double mx = hn::GetLane(hn::MaxOfLanes(d, m)), total = LaneSum(d, sum);
  LayOutFrom(a, i, mx, total);
  return std::isfinite(total) ? mx : std::nan("");
}

// The rows of particles [lo, hi): (h s, a) from the scaled SoA positions s, four particles per
// transpose, with their force rows zeroed; in the same pass, the largest squared real-space
// displacement since `ref` (NaN if a position is not finite), as
// NeighbourList::max_displacement2 measures it.
double LayOut(const simd_detail::Rows& a) {
  const D d;
  const Cell c(d, a);
  const std::size_t n = a.n;
  const double* s = a.s;
  V m = hn::Zero(d), sum = hn::Zero(d);
  std::size_t i = a.lo;
  for (; i + 4 <= a.hi; i += 4) {
    LayOutBlock(d, a, c, i, hn::LoadU(d, s + i), hn::LoadU(d, s + n + i),
                hn::LoadU(d, s + 2 * n + i), m, sum);
  }
  return LayOutRest(d, a, i, m, sum);
}

// The final force rows of particles [lo, hi) into the SoA result f (n per component); returns
// sum |F|^2 over them. With a drift (xx, xy, yy, zz of lib/kernels/backend.hpp's Drift), each
// particle's scaled position in s then moves by it, in Drift::apply's order of operations; with
// `next` too (its positions are s, its range [lo, hi)), the moved particles' rows are laid out
// in the same loop, as LayOut(*next) would lay them out afterwards, and *next_drift2 gets what
// it would return.
double CopyOut(const double* frc, double* f, std::size_t n, std::size_t lo, std::size_t hi,
               const double* drift, double* s, const simd_detail::Rows* next, double* next_drift2) {
  const D d;
  V acc = hn::Zero(d), m = hn::Zero(d), sum = hn::Zero(d);
  const Cell c(d, next ? *next : simd_detail::Rows{});
  std::size_t i = lo;
  for (; i + 4 <= hi; i += 4) {
    V x, y, z, w;
    Transpose(d, hn::Load(d, frc + 4 * i), hn::Load(d, frc + 4 * i + 4),
              hn::Load(d, frc + 4 * i + 8), hn::Load(d, frc + 4 * i + 12), x, y, z, w);
    hn::StoreU(x, d, f + i);
    hn::StoreU(y, d, f + n + i);
    hn::StoreU(z, d, f + 2 * n + i);
    acc = hn::MulAdd(z, z, hn::MulAdd(y, y, hn::MulAdd(x, x, acc)));
    if (drift) {
      const V sx = hn::Add(hn::LoadU(d, s + i), hn::Add(hn::Mul(hn::Set(d, drift[0]), x),
                                                        hn::Mul(hn::Set(d, drift[1]), y)));
      const V sy = hn::Add(hn::LoadU(d, s + n + i), hn::Mul(hn::Set(d, drift[2]), y));
      const V sz = hn::Add(hn::LoadU(d, s + 2 * n + i), hn::Mul(hn::Set(d, drift[3]), z));
      hn::StoreU(sx, d, s + i);
      hn::StoreU(sy, d, s + n + i);
      hn::StoreU(sz, d, s + 2 * n + i);
      if (next)
        LayOutBlock(d, *next, c, i, sx, sy, sz, m, sum);
    }
  }
  const double rest = CopyOutFrom(frc, f, n, i, hi, drift, s);
  if (next)
    *next_drift2 = LayOutRest(d, *next, i, m, sum);
  return LaneSum(d, acc) + rest;
}
#else
constexpr bool kVector = false;

// Narrower targets: the same loop, one pair at a time.
template <class Pair>
HWY_INLINE void Loop(const Pair& pair, PairLoop& p) {
  double u = 0.0, w[6] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
  std::size_t contacts = 0;
  for (std::size_t k = p.k0; k < p.k1; ++k) {
    const std::uint32_t e = p.entries[k];
    const std::size_t i = p.owner[k], j = e >> NeighbourList::kCodeBits;
    const double* ri = p.pos + 4 * i;
    const double* rj = p.pos + 4 * j;
    const double* sh = p.shift + 4 * (e & NeighbourList::kCodeMask);
    const double dx = ri[0] - rj[0] + sh[0], dy = ri[1] - rj[1] + sh[1], dz = ri[2] - rj[2] + sh[2],
                 a = ri[3] + rj[3];
    const double r2 = dx * dx + dy * dy + dz * dz;
    if (!(r2 < a * a))
      continue;
    double f_over_r;
    u += Law(pair, ScalarMath{}, r2, a, f_over_r);
    const double g[3] = {f_over_r * dx, f_over_r * dy, f_over_r * dz};
    w[0] += dx * g[0];
    w[1] += dy * g[1];
    w[2] += dz * g[2];
    w[3] += dx * g[1];
    w[4] += dx * g[2];
    w[5] += dy * g[2];
    ++contacts;
    for (int c = 0; c < 3; ++c) {
      p.frc[4 * i + c] += g[c];
      p.frc[4 * j + c] -= g[c];
    }
  }
  p.energy = u;
  std::copy(w, w + 6, p.virial);
  p.contacts = contacts;
}

double LayOut(const simd_detail::Rows& a) {
  double mx = 0.0, total = 0.0;
  LayOutFrom(a, a.lo, mx, total);
  return std::isfinite(total) ? mx : std::nan("");
}

double CopyOut(const double* frc, double* f, std::size_t n, std::size_t lo, std::size_t hi,
               const double* drift, double* s, const simd_detail::Rows* next, double* next_drift2) {
  const double f2 = CopyOutFrom(frc, f, n, lo, hi, drift, s);
  if (next)
    *next_drift2 = LayOut(*next);
  return f2;
}
#endif

bool VectorLoop() {
  return kVector;
}

void Pairs(PairLoop& p) {
  with_pair_law(p.alpha, [&](const auto& pair) { Loop(pair, p); });
}

}  // namespace jamflow::kernels::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace jamflow::kernels {

HWY_EXPORT(TargetName);
HWY_EXPORT(VectorLoop);
HWY_EXPORT(Pairs);
HWY_EXPORT(LayOut);
HWY_EXPORT(CopyOut);

namespace {

// The targets compiled into HWY_EXPORT's table, best first.
std::vector<std::int64_t> compiled_targets() {
  std::vector<std::int64_t> out;
  for (std::int64_t t = HWY_TARGETS; t != 0; t &= t - 1)
    out.push_back(t & -t);
  return out;
}

SimdTarget describe(std::int64_t bits) {
  return {bits, hwy::TargetName(bits), (hwy::SupportedTargets() & bits) != 0, false};
}

std::int64_t pinned = 0;  // 0: no restriction

void apply_pin() {
  hwy::SetSupportedTargetsForTest(pinned);
}

// The environment's pin, applied once.
// The environment's pin (JAMFLOW_SIMD_TARGET), or "" for none.
std::string environment_pin() {
  const char* name = std::getenv("JAMFLOW_SIMD_TARGET");
  return name ? std::string(name) : std::string();
}

// Applies the environment's pin before the first dispatch, unless an explicit pin came first.
bool pin_settled = false;
void pin_from_environment() {
  if (pin_settled)
    return;
  pin_settled = true;
  if (const std::string name = environment_pin(); !name.empty())
    simd_pin_target(name);
}

void pin_exactly(const std::string& name);

class SimdBackend final : public ForceBackend {
 public:
  SimdBackend(double alpha, int threads) : alpha_(alpha), threads_(threads) {}
  std::string name() const override { return "simd"; }
  std::string target() const override { return HWY_DYNAMIC_DISPATCH(TargetName)(); }
  void compute(const State& state, const NeighbourList& list, ForceResult& out,
               std::uint64_t version) override {
    pass(state, list, out, version, nullptr, nullptr, nullptr, 0);
  }
  // The drift is fused into the pass: a particle moves as soon as its force is final, and its
  // row for the next pass is laid out in the next cell right away.
  bool compute_and_drift(State& state, const NeighbourList& list, ForceResult& out,
                         const Drift& drift, const Box& next, std::uint64_t version,
                         std::uint64_t next_version) override {
    const Eigen::Matrix3d h_next = next.h();
    return pass(state, list, out, version, &drift, state.pos.data(), &h_next, next_version);
  }

 private:
  // With a drift, only if the inner list holds for the state (else false, state untouched);
  // `moving` is the state's own positions. With a next cell and a next version, the rows of
  // the drifted state are laid out for the pass that state gets.
  bool pass(const State& state, const NeighbourList& list, ForceResult& out, std::uint64_t version,
            const Drift* drift, double* moving, const Eigen::Matrix3d* h_next,
            std::uint64_t next_version);

  // Rows laid out ahead by a drifting pass: for the state numbered `version` (0: none), with the
  // inner list `generation`, n particles, `threads` threads and the cell h (xx, xy, yy, zz);
  // the force rows zeroed and each thread's displacement measured. A pass for any other state,
  // list, size, split or cell lays its rows out afresh.
  struct Ahead {
    std::uint64_t version = 0, generation = 0;
    std::size_t n = 0;
    int threads = 0;
    double h[4] = {0.0, 0.0, 0.0, 0.0};
    std::vector<double> drift2;
  };
  Ahead ahead_;
  std::size_t reused_ = 0;

 public:
  std::size_t prepared_passes() const override { return reused_; }

 private:
  double alpha_;
  int threads_;
  hwy::AlignedFreeUniquePtr<double[]> rows_;  // position rows, then force rows
  std::size_t row_capacity_ = 0;              // position rows allocated; the force rows follow them

  // The ghosts of a split of one inner list among threads (see the top of this file).
  struct Halo {
    std::uint64_t generation = 0;  // the inner list's (0: none)
    std::size_t n = 0;
    int threads = 0;
    std::size_t rows = 0;  // particles, idle rows and every thread's ghost rows
    struct Part {
      std::vector<std::uint32_t> entries;  // the thread's pairs, partners renumbered to rows
      std::vector<std::uint32_t> source;   // ghost g's particle, ascending
      std::size_t first = 0;               // the row of ghost 0
    };
    std::vector<Part> part;
  };
  Halo halo_;

  // Ensures room for `rows` position rows and as many force rows; a new allocation drops the
  // rows laid out ahead.
  void reserve_rows(std::size_t rows) {
    if (row_capacity_ >= rows)
      return;
    row_capacity_ = rows + rows / 8;
    rows_ = hwy::AllocateAligned<double>(8 * row_capacity_);
    ahead_.version = 0;
  }
};

// The ghosts of a thread that owns the particles [lo, hi) and the pairs [k0, k1) of the inner
// list: the partners outside [lo, hi), ascending, each once.
void find_ghosts(const NeighbourList& list, std::size_t k0, std::size_t k1, std::size_t lo,
                 std::size_t hi, std::vector<std::uint32_t>& source) {
  constexpr unsigned bits = NeighbourList::kCodeBits;
  const std::uint32_t* entries = list.inner_entries().data();
  source.clear();
  for (std::size_t k = k0; k < k1; ++k) {
    const std::size_t j = entries[k] >> bits;
    if (j < lo || j >= hi)
      source.push_back(std::uint32_t(j));
  }
  std::sort(source.begin(), source.end());
  source.erase(std::unique(source.begin(), source.end()), source.end());
}

// The entries of the pairs [k0, k1) with each ghost partner's number replaced by its row
// (`first` + its place in `source`); own partners keep theirs.
void renumber_pairs(const NeighbourList& list, std::size_t k0, std::size_t k1, std::size_t lo,
                    std::size_t hi, const std::vector<std::uint32_t>& source, std::size_t first,
                    std::vector<std::uint32_t>& out) {
  constexpr unsigned bits = NeighbourList::kCodeBits;
  const std::uint32_t* entries = list.inner_entries().data();
  out.resize(k1 - k0);
  for (std::size_t k = k0; k < k1; ++k) {
    const std::uint32_t e = entries[k];
    const std::size_t j = e >> bits;
    if (j >= lo && j < hi) {
      out[k - k0] = e;
    } else {
      const std::size_t g = std::size_t(
          std::lower_bound(source.begin(), source.end(), std::uint32_t(j)) - source.begin());
      out[k - k0] = std::uint32_t((first + g) << bits) | (e & NeighbourList::kCodeMask);
    }
  }
}

bool SimdBackend::pass(const State& state, const NeighbourList& list, ForceResult& out,
                       std::uint64_t version, const Drift* drift, double* moving,
                       const Eigen::Matrix3d* h_next, std::uint64_t next_version) {
  const std::size_t n = state.size();
  out.force.resize(3 * n);
  const int nt = threads_;
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
  ThreadSums sums(nt);
  const bool have_ref = list.inner_reference().size() == state.pos.size();
  const double* ref = list.inner_reference().data();
  double* fx = out.force.data();
  const auto pairs = HWY_DYNAMIC_DISPATCH(Pairs);
  const auto lay_out = HWY_DYNAMIC_DISPATCH(LayOut);
  const auto copy_out = HWY_DYNAMIC_DISPATCH(CopyOut);
  // With a drift the pass goes on only if the list holds, from every thread's largest
  // displacement (NaN: a position is not finite), as NeighbourList::inner_holds decides.
  const double allowed = drift ? list.inner_drift_allowed(state) : 0.0;
  const auto list_holds = [&] {
    double m = 0.0;
    bool finite = true;
    for (const double d2 : sums.drift2) {
      finite = finite && !std::isnan(d2);
      m = std::max(m, d2);
    }
    return have_ref && finite && std::sqrt(m) <= allowed;
  };
  const double dmat[4] = {drift ? drift->xx : 0.0, drift ? drift->xy : 0.0, drift ? drift->yy : 0.0,
                          drift ? drift->zz : 0.0};
  bool holds = true;
  // The ghosts of this list and size, if they were found before (for `halo_threads` threads).
  const int halo_threads = halo_.generation == list.inner_generation() && halo_.n == n &&
                                   have_ref && list.inner_generation() != 0
                               ? halo_.threads
                               : 0;
  // Rows: particles, one idle row per thread, then the ghosts (known once the split is); at
  // most one ghost per pair, and a list entry must be able to name every row.
  if (n + 2 * std::size_t(nt) + list.inner_pairs() > std::size_t(NeighbourList::kMaxParticles))
    throw std::length_error("simd backend: " + std::to_string(n) + " particles and " +
                            std::to_string(list.inner_pairs()) +
                            " pairs may need more rows than a list entry can name");
  reserve_rows(halo_threads == nt ? halo_.rows : n + std::size_t(nt));
  // The rows laid out ahead, if they are this state's; any pass uses them up.
  const bool ahead = version != 0 && ahead_.version == version && have_ref &&
                     ahead_.generation == list.inner_generation() && ahead_.n == n &&
                     ahead_.h[0] == hxx && ahead_.h[1] == hxy && ahead_.h[2] == hyy &&
                     ahead_.h[3] == hzz;
  const int ahead_threads = ahead_.threads;
  ahead_.version = 0;
  if (ahead)
    sums.drift2 = ahead_.drift2;
  std::vector<double> next_drift2(nt, 0.0);
  int used_threads = 1;
  double* pos = rows_.get();
  double* frc = pos + 4 * row_capacity_;

#pragma omp parallel num_threads(nt) if (nt > 1)
  {
    const int tid = omp_get_thread_num();
    const int nthr = omp_get_num_threads();
    const auto range = thread_range(start, n, tid, nthr);  // no binding: see portable.cpp
    const std::size_t lo = range.first, hi = range.second;
    const std::size_t k0 = start[lo], k1 = start[hi];
    // Every thread decides the same.
    const bool split = nthr > 1 && nthr != halo_threads;
    if (split) {
      // A new list, size or team: find each thread's ghosts, then their rows (each thread's
      // from a fresh cache line), then renumber the pairs.
#pragma omp single
      {
        halo_.generation = 0;
        halo_.part.resize(nthr);
      }
      Halo::Part& own = halo_.part[tid];
      find_ghosts(list, k0, k1, lo, hi, own.source);
#pragma omp barrier
#pragma omp single
      {
        std::size_t row = n + std::size_t(nthr);
        for (Halo::Part& part : halo_.part) {
          row = (row + 1) / 2 * 2;  // two rows to a cache line
          part.first = row;
          row += part.source.size();
        }
        reserve_rows(row);
        pos = rows_.get();
        frc = pos + 4 * row_capacity_;
        halo_.generation = list.inner_generation();
        halo_.n = n;
        halo_.threads = nthr;
        halo_.rows = row;
      }
      renumber_pairs(list, k0, k1, lo, hi, own.source, own.first, own.entries);
    }
    // A new allocation or a new split drops the rows laid out ahead.
    const bool reuse = ahead && nthr == ahead_threads && !split;
    if (tid == 0) {
      used_threads = nthr;
      reused_ += reuse ? 1 : 0;
    }
    // Without a reference the displacement is not used (finish() reports it as infinite).
    const simd_detail::Rows rows_of{state.pos.data(),
                                    have_ref ? ref : state.pos.data(),
                                    state.diameter.data(),
                                    n,
                                    lo,
                                    hi,
                                    hxx,
                                    hxy,
                                    hyy,
                                    hzz,
                                    pos,
                                    frc};
    if (!reuse)
      sums.drift2[tid] = lay_out(rows_of);
    const std::size_t idle = n + std::size_t(tid);
    std::fill(pos + 4 * idle, pos + 4 * idle + 4, 0.0);
    std::fill(frc + 4 * idle, frc + 4 * idle + 4, 0.0);
    const Halo::Part* own = nthr > 1 ? &halo_.part[tid] : nullptr;
    if (own) {
      // Every row is written before any thread copies its ghosts' (rows laid out ahead were
      // written before the previous pass ended; a branch every thread takes alike).
      if (!reuse) {
#pragma omp barrier
      }
      const std::size_t g0 = own->first, ng = own->source.size();
      for (std::size_t g = 0; g < ng; ++g) {
        std::copy_n(pos + 4 * std::size_t(own->source[g]), 4, pos + 4 * (g0 + g));
        std::fill_n(frc + 4 * (g0 + g), 4, 0.0);
      }
    }
    // Every thread decides the same (they read the same displacements after the barrier; with
    // one thread there is nothing to wait for).
    const bool go = !drift || list_holds();
    if (tid == 0)
      holds = go;
    if (go) {
      simd_detail::PairLoop p{};
      p.pos = pos;
      p.frc = frc;
      p.shift = shift;
      p.owner = list.inner_owner().data() + k0;
      p.entries = own ? own->entries.data() : list.inner_entries().data() + k0;
      p.k0 = 0;
      p.k1 = k1 - k0;
      p.idle = std::uint32_t(idle);
      p.alpha = alpha_;
      pairs(p);
      sums.energy[tid] = p.energy;
      sums.virial[tid] << p.virial[0], p.virial[1], p.virial[2], p.virial[3], p.virial[4],
          p.virial[5];
      sums.contacts[tid] = p.contacts;
      if (own) {
#pragma omp barrier
        // The other threads' ghost forces on this range, in thread order.
        for (const Halo::Part& part : halo_.part) {
          if (&part == own)
            continue;
          const auto first =
              std::lower_bound(part.source.begin(), part.source.end(), std::uint32_t(lo));
          for (auto g = first; g != part.source.end() && *g < hi; ++g) {
            const double* gf = frc + 4 * (part.first + std::size_t(g - part.source.begin()));
            double* row = frc + 4 * std::size_t(*g);
            row[0] += gf[0];
            row[1] += gf[1];
            row[2] += gf[2];
          }
        }
      }
      // With a next cell, no thread reads this range's rows any more: the next pass's are laid
      // out as each particle moves.
      simd_detail::Rows next_rows{};
      if (drift && h_next) {
        const Eigen::Matrix3d& hn = *h_next;
        next_rows = {moving,
                     have_ref ? ref : moving,
                     state.diameter.data(),
                     n,
                     lo,
                     hi,
                     hn(0, 0),
                     hn(0, 1),
                     hn(1, 1),
                     hn(2, 2),
                     pos,
                     frc};
      }
      sums.squared[tid] = copy_out(frc, fx, n, lo, hi, drift ? dmat : nullptr, moving,
                                   drift && h_next ? &next_rows : nullptr, &next_drift2[tid]);
    }
  }
  sums.finish(out, have_ref);
  if (drift && h_next && holds && next_version != 0 && have_ref) {
    ahead_.version = next_version;
    ahead_.generation = list.inner_generation();
    ahead_.n = n;
    ahead_.threads = used_threads;
    const double hn[4] = {(*h_next)(0, 0), (*h_next)(0, 1), (*h_next)(1, 1), (*h_next)(2, 2)};
    std::copy(hn, hn + 4, ahead_.h);
    ahead_.drift2 = next_drift2;
  }
  return holds;
}

}  // namespace

std::vector<SimdTarget> simd_targets() {
  // What the CPU supports, with no pin in the way; then each supported target is asked itself
  // whether it runs the vector loop.
  hwy::SetSupportedTargetsForTest(0);
  std::vector<SimdTarget> out;
  for (const std::int64_t bits : compiled_targets())
    out.push_back(describe(bits));
  for (SimdTarget& t : out) {
    if (t.supported) {
      hwy::SetSupportedTargetsForTest(t.bits);
      t.vector = HWY_DYNAMIC_DISPATCH(VectorLoop)();
    } else {
      // Not runnable here; the vector loop is compiled for x86 targets of 256 bits and more.
      t.vector = (t.bits & (HWY_AVX2 | HWY_AVX3 | HWY_AVX3_DL)) != 0;
    }
  }
  apply_pin();
  return out;
}

SimdTarget simd_current_target() {
  pin_from_environment();
  for (const SimdTarget& t : simd_targets()) {
    if (t.name == HWY_DYNAMIC_DISPATCH(TargetName)())
      return t;
  }
  return {0, HWY_DYNAMIC_DISPATCH(TargetName)(), true, HWY_DYNAMIC_DISPATCH(VectorLoop)()};
}

void simd_pin_target(const std::string& name) {
  pin_settled = true;
  pin_exactly(name.empty() ? environment_pin() : name);
}

namespace {

void pin_exactly(const std::string& name) {
  if (name.empty()) {
    pinned = 0;
    apply_pin();
    return;
  }
  const std::int64_t before = pinned;  // kept if the name is refused
  pinned = 0;                          // describe() sees every target the CPU supports
  apply_pin();
  std::string names;
  for (const std::int64_t bits : compiled_targets()) {
    const SimdTarget t = describe(bits);
    names += (names.empty() ? "" : ", ") + t.name + (t.supported ? "" : " (not on this CPU)");
  }
  for (const std::int64_t bits : compiled_targets()) {
    const SimdTarget t = describe(bits);
    if (t.name == name) {
      if (!t.supported) {
        pinned = before;
        apply_pin();
        throw ConfigError("JAMFLOW_SIMD_TARGET = \"" + name + "\": this CPU cannot run it; " +
                          "allowed: " + names);
      }
      pinned = bits;
      apply_pin();
      return;
    }
  }
  pinned = before;
  apply_pin();
  throw ConfigError("JAMFLOW_SIMD_TARGET = \"" + name +
                    "\" is not a compiled target; allowed: " + names);
}

}  // namespace

std::unique_ptr<ForceBackend> make_simd_backend(double alpha, int threads) {
  pin_from_environment();
  return std::make_unique<SimdBackend>(alpha, threads);
}

}  // namespace jamflow::kernels
#endif  // HWY_ONCE
