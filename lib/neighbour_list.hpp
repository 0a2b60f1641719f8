// Verlet neighbour list with a skin, built from cell lists, valid under shear, Lees–Edwards
// remaps and volume changes.
//
// Each unordered pair (i, j) within a_ij + skin is stored once (half list, CSR by i) together
// with the periodic image n that was nearest at build time: r_ij = h (s_i - s_j - n). Scaled
// coordinates move continuously between rebuilds, so n stays right. Validity is checked with
// a bound that holds for any affine change of the cell: with M = h h_ref^-1 and d_max the
// largest non-affine displacement since the build, every pair outside the list is still
// farther apart than contact while  sigma_min(M) (a + skin) - 2 d_max >= a  for all a_ij.
//
// Two levels. The force pass reads an inner list: the pairs of the outer list within
// a_ij + inner_skin (0.05 by default), with its own reference positions and the same bound.
// Near jamming it holds ~3.7 pairs per particle, 3.1 of them touching, against 5.3 in the
// outer list. When the inner bound fails, the inner list is re-selected from the outer one,
// which is cheap, provided the outer list still holds every pair within a_ij + inner_skin:
// sigma_min(M_outer) (a + skin) - 2 d_outer >= a + inner_skin. Otherwise both are rebuilt.
// (GROMACS's dynamic pruning of its pair list works the same way.)
#pragma once
#include <Eigen/Dense>
#include <array>
#include <cstdint>
#include <vector>

#include "lib/state.hpp"

namespace jamflow {

class NeighbourList {
 public:
  // Entries pack j (high bits) and the image code (low 5 bits, 27 images).
  static constexpr unsigned kCodeBits = 5;
  static constexpr std::uint32_t kCodeMask = (1u << kCodeBits) - 1;
  static constexpr std::uint32_t kMaxParticles = (1u << (32 - kCodeBits)) - 1;
  // What image_code() returns for an image no entry can name (|n| > 1 in some direction).
  static constexpr std::uint32_t kNoImage = kCodeMask;
  // The largest |xy / Lx| a build accepts: remaps keep it within 1/2 between steps, a step may
  // take it somewhat past (Model remaps before a build beyond Model::kRemapAtBuild), and up to
  // here the nearest image of every pair has a code (|dsx + t dsy| < 1 + 3/8 rounds to |n_x| <= 1).
  static constexpr double kMaxBuildTilt = 0.75;

  // Inner skin of the list the force pass reads (see above); at most half the skin.
  static constexpr double kInnerSkin = 0.05;

  explicit NeighbourList(double skin = 0.3);

  double skin() const { return skin_; }
  double inner_skin() const { return inner_skin_; }
  void set_skin(double skin);

  // Builds both lists. The state must be wrapped (scaled coordinates in [0, 1)) and its cell
  // tilted by at most kMaxBuildTilt; otherwise std::invalid_argument (IntegrationError for a
  // non-finite position). The lists do not depend on the number of threads.
  void build(const State& state, int threads = 1);

  enum class Status {
    kValid,       // the inner list holds every pair in contact
    kInnerStale,  // re-select the inner list from the outer one (refresh_inner)
    kStale,       // rebuild both (build), or never built
  };
  Status status(const State& state, int threads = 1) const;
  // True when the inner list (and so the outer one) holds every pair in contact.
  bool valid(const State& state, int threads = 1) const {
    return status(state, threads) == Status::kValid;
  }
  // The inner bound for a known largest displacement since inner_reference() (e.g. measured
  // by the force pass); false also for a non-finite one, or when never built.
  bool inner_holds(const State& state, double max_drift) const;
  // The largest displacement since inner_reference() for which the inner list still holds in
  // the current cell (-inf when never built for this state): inner_holds(state, d) is
  // d <= inner_drift_allowed(state).
  double inner_drift_allowed(const State& state) const;
  const std::vector<double>& inner_reference() const { return inner_ref_pos_; }
  // Largest squared displacement of particles [lo, hi) since `ref` (SoA scaled, as State::pos),
  // in real space of the current cell; NaN if a position is not finite. Both list checks and
  // the force pass's own measurement use it.
  static double max_displacement2(const State& state, const double* ref, std::size_t lo,
                                  std::size_t hi);
  bool built() const { return built_; }
  // Re-selects the inner list from the outer one; only after status() said kInnerStale.
  void refresh_inner(const State& state, int threads = 1);
  void invalidate() { built_ = false; }

  // Outer list, CSR by i: all pairs within a_ij + skin at the last build.
  const std::vector<std::uint32_t>& start() const { return start_; }      // size n + 1
  const std::vector<std::uint32_t>& entries() const { return entries_; }  // j << 5 | code
  // Inner list, the same layout, and the i of each entry (for loops over flat pairs).
  const std::vector<std::uint32_t>& inner_start() const { return inner_start_; }
  const std::vector<std::uint32_t>& inner_entries() const { return inner_entries_; }
  const std::vector<std::uint32_t>& inner_owner() const { return inner_owner_; }
  // Scaled shift subtracted for an image code: -n, for n in {-1, 0, 1}^3.
  static const std::array<std::array<double, 3>, 27>& shifts();

  std::size_t builds() const { return builds_; }              // outer (full) builds
  std::size_t inner_builds() const { return inner_builds_; }  // inner selections, all
  // Identifies the current inner list among all lists of the process (new at every selection),
  // so that data derived from it can be cached.
  std::uint64_t inner_generation() const { return inner_generation_; }
  std::size_t max_row() const { return max_row_; }  // longest inner row of one particle
  std::size_t pairs() const { return entries_.size(); }
  std::size_t inner_pairs() const { return inner_entries_.size(); }

  // Everything the lists are, as plain values: a checkpoint saves it, and from() gives back a
  // list that selects, and so sums, exactly the same pairs in the same order.
  struct Snapshot {
    double skin = 0.0, inner_skin = 0.0;
    bool built = false;
    std::size_t builds = 0, inner_builds = 0;
    std::vector<std::uint32_t> start, entries, inner_start, inner_entries;
    std::vector<double> ref_pos, inner_ref_pos;
    Eigen::Matrix3d h_ref_inv = Eigen::Matrix3d::Identity();
    Eigen::Matrix3d inner_h_ref_inv = Eigen::Matrix3d::Identity();
    double a_min = 0.0, a_max = 0.0;
  };
  Snapshot snapshot() const;
  // The list of a snapshot, with a new inner_generation(); a snapshot that is not
  // self-consistent (row starts, entry codes, sizes) is a std::invalid_argument.
  static NeighbourList from(const Snapshot& snapshot);

  // Permutation that orders particles by cell (memory locality for the pair loop).
  static std::vector<std::uint32_t> cell_order(const State& state, double cell_size);

 private:
  void build_all_pairs(const State& state);
  // Largest displacement since `ref` (real space, current cell) and sigma_min(h h_ref^-1).
  struct Drift {
    double d_max, sigma_min;
  };
  Drift drift(const State& state, const std::vector<double>& ref, const Eigen::Matrix3d& h_ref_inv,
              int threads) const;
  // Every pair farther than a + margin when listed at `skin` still is beyond a + margin.
  bool holds(const Drift& d, double skin, double margin) const;
  // The largest d_max for which holds() is true, given sigma_min.
  double allowed_drift(double sigma_min, double skin, double margin) const;
  void set_inner_owner();  // inner_owner_ and max_row_ from inner_start_

  double skin_, inner_skin_;
  bool built_ = false;
  std::size_t builds_ = 0, inner_builds_ = 0;
  std::uint64_t inner_generation_ = 0;
  std::vector<std::uint32_t> start_, entries_;
  std::vector<std::uint32_t> inner_start_, inner_entries_, inner_owner_;
  std::vector<double> ref_pos_, inner_ref_pos_;
  Eigen::Matrix3d h_ref_inv_ = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d inner_h_ref_inv_ = Eigen::Matrix3d::Identity();
  double a_min_ = 0.0, a_max_ = 0.0;
  std::size_t max_row_ = 0;
};

// Nearest image of scaled separation ds in a cell whose +y image sits xy / Lx = tilt_fraction
// (Box::tilt_fraction) along x: ds is reduced to it, and its code returned, or
// NeighbourList::kNoImage if it is not one of the 27 codes (only for |ds| >= 1 in some direction
// or a tilt beyond NeighbourList::kMaxBuildTilt).
std::uint32_t image_code(double& dsx, double& dsy, double& dsz, double tilt_fraction);

}  // namespace jamflow
