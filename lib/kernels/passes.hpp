// Building blocks shared by the list-based backends (portable, simd): how a pass splits the
// particles between threads and how the per-thread sums are reduced. Internal to lib/kernels.
#pragma once
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include "lib/kernels/backend.hpp"

namespace jamflow::kernels {

// Thread ranges are whole blocks of this many particles.
inline constexpr std::size_t kBlock = 64;

// Thread ranges: contiguous runs of blocks holding equal shares of the listed pairs (the
// work), not of the particles, because the half list stores each pair at its lower index.
// Returns the particles [lo, hi) of thread t of nthr, for the list rows `start` of n particles.
inline std::pair<std::size_t, std::size_t> thread_range(const std::uint32_t* start, std::size_t n,
                                                        int t, int nthr) {
  const std::size_t blocks = (n + kBlock - 1) / kBlock;
  const auto first = [&](int u) -> std::size_t {
    if (u == nthr)
      return blocks;
    const double share = double(start[n]) * double(u) / double(nthr);
    std::size_t lo_b = 0, hi_b = blocks;  // first block whose first entry reaches the share
    while (lo_b < hi_b) {
      const std::size_t mid = (lo_b + hi_b) / 2;
      if (double(start[std::min(n, mid * kBlock)]) < share)
        lo_b = mid + 1;
      else
        hi_b = mid;
    }
    return lo_b;
  };
  return {std::min(n, first(t) * kBlock), std::min(n, first(t + 1) * kBlock)};
}

// A pair force on a particle owned by another thread: added by the owner after the pair loops,
// in thread order, so that one thread count always gives the same bits.
struct DeferredForce {
  std::uint32_t j;
  double fx, fy, fz;
};

// Per-thread partial sums of a force pass, reduced in thread order.
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

// Hands add(j, force) the forces that the threads deferred to particles of [lo, hi), in
// thread order.
template <class Add>
void add_deferred(const std::vector<std::vector<DeferredForce>>& deferred,
                  const std::vector<std::size_t>& counts, std::size_t lo, std::size_t hi,
                  const Add& add) {
  for (std::size_t u = 0; u < counts.size(); ++u) {
    const DeferredForce* d = deferred[u].data();
    for (std::size_t q = 0; q < counts[u]; ++q) {
      if (d[q].j >= lo && d[q].j < hi)
        add(d[q].j, d[q]);
    }
  }
}

}  // namespace jamflow::kernels
