// Verlet neighbour list with a skin, built from cell lists, valid under shear, Lees–Edwards
// remaps and volume changes.
//
// Each unordered pair (i, j) within a_ij + skin is stored once (half list, CSR by i) together
// with the periodic image n that was nearest at build time: r_ij = h (s_i - s_j - n). Scaled
// coordinates move continuously between rebuilds, so n stays right. Validity is checked with
// a bound that holds for any affine change of the cell: with M = h h_ref^-1 and d_max the
// largest non-affine displacement since the build, every pair outside the list is still
// farther apart than contact while  sigma_min(M) (a + skin) - 2 d_max >= a  for all a_ij.
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

  explicit NeighbourList(double skin = 0.3);

  double skin() const { return skin_; }
  void set_skin(double skin);

  // Builds the list. The state must be wrapped (scaled coordinates in [0, 1)).
  void build(const State& state);
  // False when a pair outside the list might now be in contact, or the list was never built.
  bool valid(const State& state, int threads = 1) const;
  void invalidate() { built_ = false; }

  const std::vector<std::uint32_t>& start() const { return start_; }      // size n + 1
  const std::vector<std::uint32_t>& entries() const { return entries_; }  // j << 5 | code
  // Scaled shift subtracted for an image code: -n, for n in {-1, 0, 1}^3.
  static const std::array<std::array<double, 3>, 27>& shifts();

  std::size_t builds() const { return builds_; }
  std::size_t max_row() const { return max_row_; }  // longest neighbour row of one particle
  std::size_t pairs() const { return entries_.size(); }

  // Permutation that orders particles by cell (memory locality for the pair loop).
  static std::vector<std::uint32_t> cell_order(const State& state, double cell_size);

 private:
  void build_all_pairs(const State& state);
  double skin_;
  bool built_ = false;
  std::size_t builds_ = 0;
  std::vector<std::uint32_t> start_, entries_;
  std::vector<double> ref_pos_;
  Eigen::Matrix3d h_ref_inv_ = Eigen::Matrix3d::Identity();
  double a_min_ = 0.0, a_max_ = 0.0;
  std::size_t max_row_ = 0;
};

// Nearest image code for scaled separation ds under tilt t, and the image itself.
std::uint32_t image_code(double& dsx, double& dsy, double& dsz, double tilt);

}  // namespace jamflow
