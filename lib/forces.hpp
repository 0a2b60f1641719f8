// One pass over contacts that yields forces, potential energy and the virial tensor
// (SPEC §3): W_ab = sum_{i<j} r_ij,a f_ij,b with r_ij = r_i - r_j (minimum image) and f_ij the
// force on i from j. Then Pi = W / V, P_hat = tr(Pi) / 3, sigma_xy = -Pi_xy.
#pragma once
#include <Eigen/Dense>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "lib/neighbour_list.hpp"
#include "lib/potential.hpp"
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
  // when the list has no reference for this state.
  double max_drift2 = 0.0;
};

// A pair force on a particle owned by another thread (see ForceField::compute_impl).
struct DeferredForce {
  std::uint32_t j;
  double fx, fy, fz;
};

// The particle drift of an explicit Euler step in scaled coordinates, s += D F, with
// D = h_new^-1 dt / xi_s (upper triangular, as h is). One definition, so that the drift fused
// into the force pass and the separate one give the same bits.
struct Drift {
  double xx, xy, yy, zz;
  static Drift of(const Eigen::Matrix3d& h_inv, double dt_over_xi) {
    return {h_inv(0, 0) * dt_over_xi, h_inv(0, 1) * dt_over_xi, h_inv(1, 1) * dt_over_xi,
            h_inv(2, 2) * dt_over_xi};
  }
  // The products are fused explicitly, so that a vector loop can give the same bits whatever the
  // compiler contracts (these are the bits GCC gave the plain expressions).
  void apply(double& x, double& y, double& z, double fx, double fy, double fz) const {
    x += std::fma(xx, fx, xy * fy);
    y = std::fma(yy, fy, y);
    z = std::fma(zz, fz, z);
  }
};

class ForceField {
 public:
  // alpha_r in [1.2, 3]; threads <= 0 means all OpenMP threads available.
  explicit ForceField(double alpha_r, int threads = 0);

  double alpha() const { return alpha_; }
  int threads() const { return threads_; }

  // Fast path: over the neighbour list's inner list (which must be valid for the state).
  // With AVX-512VL at build time and alpha_r = 2, a 4-lane vector kernel; otherwise, or after
  // use_portable_kernel(true), the portable blocked kernel. Both give the same forces up to
  // round-off (tested).
  void compute(const State& state, const NeighbourList& list, ForceResult& out) const;
  // compute() and then, in the same pass, drift.apply() to every particle with its force
  // (explicit Euler), provided the inner list holds for the state; the forces themselves are
  // not kept (out.force is left empty). Returns false, with the state untouched and
  // out.max_drift2 set, when the list no longer holds: renew it and call again.
  //
  // `next` is the cell the caller gives the state right after the pass (the one the drift is
  // mapped with). The vector kernel then also lays out, in the same loop, the rows of the
  // drifted particles in that cell and measures their displacement, which is what the next pass
  // would start with. The next pass skips that work if the caller passes `untouched`: nothing
  // but this call and that cell change has altered the state since. The rows are also checked
  // against the list generation, the cell and the thread count, and any other pass drops them.
  bool compute_and_drift(State& state, const NeighbourList& list, ForceResult& out,
                         const Drift& drift, const Eigen::Matrix3d& next,
                         bool untouched = false) const;
  // Passes that reused the rows laid out by the previous one (see compute_and_drift).
  std::size_t reused_layouts() const { return reused_; }
  // True when compute() takes the vector kernel for a system of n particles.
  bool vector_kernel(std::size_t n) const;
  void use_portable_kernel(bool portable) { portable_ = portable; }
  // Reference path: every pair, minimum image, no list. O(N^2), for tests.
  void compute_all_pairs(const State& state, ForceResult& out) const;

  // out = -H v: the change of the forces for a real-space displacement field v (SoA), i.e.
  // the Hessian-vector product of the potential energy, over the neighbour list.
  void hessian_product(const State& state, const NeighbourList& list, const double* v,
                       double* out) const;

 private:
  template <class Pair>
  void compute_impl(const Pair& pair, const State& state, const NeighbourList& list,
                    ForceResult& out) const;
  // With `drift` (and `moved`, the state's own positions, and `next`), only if the inner list
  // holds for the state: then drifts the particles, lays out their rows ahead and returns
  // true; see compute_and_drift.
  bool compute_harmonic_vector(const State& state, const NeighbourList& list, ForceResult& out,
                               const Drift* drift = nullptr, double* moved = nullptr,
                               const Eigen::Matrix3d* next = nullptr, bool untouched = false) const;
#if defined(__AVX512F__) && defined(__AVX512VL__)
  void add_ghost_rows(int tid, std::uint64_t pass, std::size_t rows, double* ghosts,
                      double* frc) const;
#endif
  template <class Pair>
  void hessian_impl(const Pair& pair, const State& state, const NeighbourList& list,
                    const double* v, double* out) const;

  using Deferred = DeferredForce;
  // Contacts of one block of particles (see compute_impl), per thread.
  struct ContactScratch {
    std::vector<std::uint32_t> i, j;
    std::vector<double> rx, ry, rz, r2, a;
    // Forces on particles of other threads' ranges, `deferred` of them: a plain buffer with
    // room for one per pair of the range, so that no call (which would spill the vector
    // kernel's accumulators) sits in a pair loop.
    std::unique_ptr<Deferred[]> deferred_rows;
    std::size_t deferred_capacity = 0, deferred = 0;
    void reserve_deferred(std::size_t m) {
      if (deferred_capacity < m) {
        deferred_rows = std::make_unique_for_overwrite<Deferred[]>(m);
        deferred_capacity = m;
      }
      deferred = 0;
    }
    // The vector kernel's ghost rows for this thread's range: for each earlier thread t, the
    // particles of the range that are partners of t's pairs, in increasing order, at
    // [ghost_start[t], ghost_start[t + 1]); kept until the list or the thread count changes.
    std::vector<std::uint32_t> ghost_rows, ghost_start;
    // Per block of four particles from the start of the range: 1 if the block holds one of them.
    std::vector<std::uint8_t> ghost_blocks;
    // The partners of this thread's pairs that later threads own: its ghost rows, sorted.
    std::vector<std::uint32_t> written;
    std::uint64_t ghost_generation = 0;
    int ghost_threads = 0;
    void ghost_lists(const NeighbourList& list, int tid, int nthr);
    void resize(std::size_t m) {
      if (i.size() >= m)
        return;
      for (auto* v : {&i, &j})
        v->resize(m);
      for (auto* v : {&rx, &ry, &rz, &r2, &a})
        v->resize(m);
    }
  };

  double alpha_;
  bool harmonic_;
  int threads_;
  bool portable_ = false;
  mutable std::vector<ContactScratch> scratch_;
  // Vector kernel: rows of 4 doubles per particle (position, radius / force), plus the spare
  // rows of each thread; position and force rows share this buffer (see
  // compute_harmonic_vector).
  mutable std::vector<double> rows_;
  // Vector kernel on several threads: per thread, force rows for the partners of its pairs that
  // other threads own (its ghosts, zero between passes), and two flags per thread, set to the
  // pass number: `done_` once its pair loop is done, after which later threads add its ghosts to
  // theirs, and `added_` once it has added every earlier thread's ghosts, after which those
  // threads zero them again.
  mutable std::vector<double> ghosts_;
  struct alignas(64) PassFlag {
    std::atomic<std::uint64_t> pass{0};
  };
  struct PassFlags {  // a copied ForceField gets flags of its own
    std::unique_ptr<PassFlag[]> flags;
    int count = 0;
    PassFlags() = default;
    PassFlags(const PassFlags&) {}
    PassFlags& operator=(const PassFlags&) { return *this; }
  };
  mutable PassFlags done_, added_;
  mutable std::uint64_t passes_ = 0;
  // Rows laid out ahead by a drifting pass, for the state it left in the cell `h` (xx, xy, yy,
  // zz), with the force rows zeroed and each thread's displacement measured (see
  // compute_and_drift).
  struct RowsAhead {
    bool valid = false;
    std::uint64_t generation = 0;  // of the inner list
    std::size_t n = 0;
    int threads = 0;
    double h[4] = {0.0, 0.0, 0.0, 0.0};
    std::vector<double> drift2;
  };
  mutable RowsAhead ahead_;
  mutable std::size_t reused_ = 0;
};

}  // namespace jamflow
