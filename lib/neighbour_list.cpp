// Verlet neighbour list from cell lists; see neighbour_list.hpp for the validity bound.
#include "lib/neighbour_list.hpp"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <memory>
#include <numeric>
#include <stdexcept>
#include <string>

#include "lib/error.hpp"

namespace jamflow {

namespace {

// Numbers every inner list of the process (lib/kernels caches data derived from one).
std::uint64_t next_generation() {
  static std::atomic<std::uint64_t> generations{0};
  return ++generations;
}

std::array<std::array<double, 3>, 27> make_shifts() {
  std::array<std::array<double, 3>, 27> s{};
  for (int nx = -1; nx <= 1; ++nx)
    for (int ny = -1; ny <= 1; ++ny)
      for (int nz = -1; nz <= 1; ++nz) {
        const int code = (nx + 1) * 9 + (ny + 1) * 3 + (nz + 1);
        s[code] = {-double(nx), -double(ny), -double(nz)};
      }
  return s;
}

// The most skewed cell a list built in `box` is checked against: |tilt| = 1/2 (the most skewed
// between remaps) or the cell's own tilt where that is larger (a build within a step that
// sheared past 1/2, up to NeighbourList::kMaxBuildTilt).
Box most_skewed(const Box& box) {
  Box worst = box;
  worst.flips = 0;
  worst.strain = std::max(0.5, std::abs(box.tilt_fraction())) * box.lx / box.ly;
  return worst;
}

// Bins per scaled direction so that a sphere of radius `reach` spans at most one bin on each
// side. The widths are evaluated in the most skewed cell (above). A dilute
// cell (phi = 1e-9 asks for 1e11 bins of reach) gets fewer, wider bins: at most 2 n + 27, which
// keeps the grid's memory proportional to the particles and its indices within 32 bits.
Eigen::Vector3i bins_for(const Box& box, double reach, std::size_t n) {
  const Eigen::Vector3d w = most_skewed(box).perpendicular_widths();
  Eigen::Vector3d fit;
  for (int d = 0; d < 3; ++d)
    fit[d] = std::max(1.0, std::floor(std::min(w[d] / reach, 1e9)));
  const double cap = 2.0 * double(n) + 27.0;
  if (fit.prod() > cap) {
    const double shrink = std::cbrt(fit.prod() / cap);
    for (int d = 0; d < 3; ++d)
      fit[d] = std::max(1.0, std::floor(fit[d] / shrink));
  }
  return fit.cast<int>();
}

// Fills a CSR list row by row: row(i, dst) writes the entries of row i to dst, at most
// bound(i) of them, and returns their count. Threads take contiguous ranges of rows into their
// own buffers, joined in order afterwards, so the result does not depend on the thread count.
// A row writes through a plain pointer, not push_back: the vector's end pointer, stored at
// every entry, would otherwise make the compiler reload every captured pointer per candidate
// (they may alias), which cost several times the distance test itself.
template <class Bound, class Row>
void fill_rows(std::size_t n, int threads, std::vector<std::uint32_t>& start,
               std::vector<std::uint32_t>& entries, const Bound& bound, const Row& row) {
  start.assign(n + 1, 0);
  const int nt = std::max(1, std::min(threads, int(n / 1024) + 1));  // small n: one thread
  std::vector<std::unique_ptr<std::uint32_t[]>> parts(nt);
  std::vector<std::size_t> used(nt, 0);
#pragma omp parallel num_threads(nt) if (nt > 1)
  {
    const std::size_t t = std::size_t(omp_get_thread_num());
    const std::size_t m = std::size_t(omp_get_num_threads());
    const std::size_t lo = n * t / m, hi = n * (t + 1) / m;
    std::size_t capacity = 8 * (hi - lo) + 64, size = 0;
    auto out = std::make_unique_for_overwrite<std::uint32_t[]>(capacity);
    for (std::size_t i = lo; i < hi; ++i) {
      const std::size_t b = bound(i);
      if (capacity < size + b) {
        capacity = std::max(2 * capacity, size + b);
        auto grown = std::make_unique_for_overwrite<std::uint32_t[]>(capacity);
        std::copy(out.get(), out.get() + size, grown.get());
        out = std::move(grown);
      }
      const std::size_t count = row(i, out.get() + size);
      start[i + 1] = static_cast<std::uint32_t>(count);
      size += count;
    }
    parts[t] = std::move(out);
    used[t] = size;
  }
  std::partial_sum(start.begin(), start.end(), start.begin());
  entries.resize(start[n]);
  std::uint32_t* dst = entries.data();
  for (int t = 0; t < nt; ++t)
    dst = std::copy(parts[t].get(), parts[t].get() + used[t], dst);
}

// sigma_min(m): the least a unit vector can be stretched by the affine map m.
double smallest_stretch(const Eigen::Matrix3d& m) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(m.transpose() * m,
                                                           Eigen::EigenvaluesOnly);
  return std::sqrt(std::max(0.0, eig.eigenvalues().minCoeff()));
}

}  // namespace

const std::array<std::array<double, 3>, 27>& NeighbourList::shifts() {
  static const auto table = make_shifts();
  return table;
}

std::uint32_t image_code(double& dsx, double& dsy, double& dsz, double tilt_fraction) {
  const double nz = std::nearbyint(dsz);
  const double ny = std::nearbyint(dsy);
  dsz -= nz;
  dsy -= ny;
  // Nearest x image in real space given the chosen y image: r_x = Lx (dsx + (xy / Lx) dsy).
  const double nx = std::nearbyint(dsx + tilt_fraction * dsy);
  dsx -= nx;
  const bool nameable = std::abs(nx) <= 1.0 && std::abs(ny) <= 1.0 && std::abs(nz) <= 1.0;
  return nameable ? static_cast<std::uint32_t>((nx + 1) * 9 + (ny + 1) * 3 + (nz + 1))
                  : NeighbourList::kNoImage;
}

NeighbourList::NeighbourList(double skin) {
  set_skin(skin);
}

void NeighbourList::set_skin(double skin) {
  if (!(skin > 0.0) || !std::isfinite(skin)) {
    throw ConfigError("neighbour skin = " + std::to_string(skin) + " must be > 0");
  }
  skin_ = skin;
  inner_skin_ = std::min(kInnerSkin, 0.5 * skin);
  built_ = false;
}

void NeighbourList::build(const State& state, int threads) {
  const std::size_t n = state.size();
  if (n > kMaxParticles)
    throw ConfigError("N = " + std::to_string(n) + " exceeds the list limit");
  // The image codes name n_x in {-1, 0, 1} only: with scaled separations below 1 (wrapped
  // positions) and |xy / Lx| <= kMaxBuildTilt, the nearest image is one of them (see
  // image_code). Anything else would write codes that name no image, and so indices out of
  // range, so it is refused here (Model remaps and wraps before it builds).
  const double tilt = state.box.tilt_fraction();
  if (!(std::abs(tilt) <= kMaxBuildTilt)) {
    throw std::invalid_argument(
        "neighbour list: a build in a cell of tilt xy / Lx = " + std::to_string(tilt) +
        "; allowed at most " + std::to_string(kMaxBuildTilt) + " (remap first)");
  }
  for (double s : state.pos) {
    if (!(s >= 0.0 && s < 1.0)) {
      if (!std::isfinite(s))
        throw IntegrationError("particle positions became non-finite");
      throw std::invalid_argument(
          "neighbour list: a build needs wrapped positions in [0, 1), got " + std::to_string(s));
    }
  }
  a_min_ = *std::min_element(state.diameter.begin(), state.diameter.end());
  a_max_ = *std::max_element(state.diameter.begin(), state.diameter.end());
  const double reach = a_max_ + skin_;

  // A pair must see at most one periodic image of a partner within reach.
  {
    const double wmin = most_skewed(state.box).perpendicular_widths().minCoeff();
    if (2.0 * reach >= wmin) {
      throw ConfigError("cell too small: narrowest width " + std::to_string(wmin) +
                        " must exceed twice the list reach " + std::to_string(reach) +
                        " (largest diameter + skin); increase N");
    }
  }

  const Eigen::Vector3i nb = bins_for(state.box, reach, n);
  start_.assign(n + 1, 0);
  entries_.clear();
  entries_.reserve(n * 8);

  if (nb.minCoeff() < 3) {
    build_all_pairs(state);
  } else {
    const std::size_t ncell = std::size_t(nb[0]) * nb[1] * nb[2];
    std::vector<std::uint32_t> cell_of(n), cell_start(ncell + 1, 0), members(n);
    const double* sx = state.x();
    const double* sy = state.y();
    const double* sz = state.z();
    for (std::size_t i = 0; i < n; ++i) {
      const int cx = std::min(nb[0] - 1, static_cast<int>(sx[i] * nb[0]));
      const int cy = std::min(nb[1] - 1, static_cast<int>(sy[i] * nb[1]));
      const int cz = std::min(nb[2] - 1, static_cast<int>(sz[i] * nb[2]));
      cell_of[i] = static_cast<std::uint32_t>((cx * nb[1] + cy) * nb[2] + cz);
      ++cell_start[cell_of[i] + 1];
    }
    std::partial_sum(cell_start.begin(), cell_start.end(), cell_start.begin());
    {
      std::vector<std::uint32_t> fill(cell_start.begin(), cell_start.end() - 1);
      for (std::size_t i = 0; i < n; ++i)
        members[fill[cell_of[i]]++] = std::uint32_t(i);
    }
    const Eigen::Matrix3d h = state.box.h();
    const double hxx = h(0, 0), hxy = h(0, 1), hyy = h(1, 1), hzz = h(2, 2);
    const double t = tilt;
    const double* d = state.diameter.data();
    const std::uint32_t* cs = cell_start.data();
    const std::uint32_t* mem = members.data();
    const std::uint32_t* cell_index = cell_of.data();
    const int nbx = nb[0], nby = nb[1], nbz = nb[2];
    const double skin = skin_;
    // A row holds at most every member of 27 bins: one bound for all rows, so that the bins
    // around a particle are found once.
    std::uint32_t fullest = 0;
    for (std::size_t c = 0; c < ncell; ++c)
      fullest = std::max(fullest, cell_start[c + 1] - cell_start[c]);
    const auto bound = [=](std::size_t) { return 27 * std::size_t(fullest); };
    const auto row = [=](std::size_t i, std::uint32_t* dst) {
      // Scaled coordinates are periodic in the unit cube whatever the tilt (the Lees–Edwards
      // offset lives in h), so the 27 surrounding bins hold every partner within reach.
      std::uint32_t cells[27];
      const int c = int(cell_index[i]);
      const int cz = c % nbz, cy = (c / nbz) % nby, cx = c / (nbz * nby);
      int nc = 0;
      for (int dx = -1; dx <= 1; ++dx) {
        const int xw = (cx + dx + nbx) % nbx;
        for (int dy = -1; dy <= 1; ++dy) {
          const int yw = (cy + dy + nby) % nby;
          for (int dz = -1; dz <= 1; ++dz) {
            const int zw = (cz + dz + nbz) % nbz;
            cells[nc++] = std::uint32_t((xw * nby + yw) * nbz + zw);
          }
        }
      }
      const double xi = sx[i], yi = sy[i], zi = sz[i], di = d[i];
      std::size_t m = 0;
      for (std::uint32_t cell : cells) {
        // Members of a bin are in increasing order: a bin with none above i is skipped whole
        // (with the cell-ordered memory layout, a fixed pattern the branch predictor learns).
        const std::uint32_t k0 = cs[cell], k1 = cs[cell + 1];
        if (k0 == k1 || mem[k1 - 1] <= i)
          continue;
        for (std::uint32_t k = k0; k < k1; ++k) {
          const std::uint32_t j = mem[k];
          double dx = xi - sx[j], dy = yi - sy[j], dz = zi - sz[j];
          const std::uint32_t code = image_code(dx, dy, dz, t);
          const double rx = hxx * dx + hxy * dy, ry = hyy * dy, rz = hzz * dz;
          const double cut = 0.5 * (di + d[j]) + skin;
          dst[m] = (j << kCodeBits) | code;  // kept only if it counts (no branch)
          m += (j > i && rx * rx + ry * ry + rz * rz < cut * cut) ? 1 : 0;
        }
      }
      return m;
    };
    fill_rows(n, threads, start_, entries_, bound, row);
  }

  ref_pos_ = state.pos;
  h_ref_inv_ = state.box.h_inv();
  built_ = true;
  ++builds_;
  refresh_inner(state, threads);
}

void NeighbourList::refresh_inner(const State& state, int threads) {
  const std::size_t n = state.size();
  const Eigen::Matrix3d h = state.box.h();
  const double hxx = h(0, 0), hxy = h(0, 1), hyy = h(1, 1), hzz = h(2, 2);
  const double* sx = state.x();
  const double* sy = state.y();
  const double* sz = state.z();
  const double* d = state.diameter.data();
  const std::uint32_t* outer_start = start_.data();
  const std::uint32_t* outer = entries_.data();
  const std::array<double, 3>* shift = shifts().data();
  const double inner_skin = inner_skin_;
  const auto bound = [=](std::size_t i) { return outer_start[i + 1] - outer_start[i]; };
  const auto row = [=](std::size_t i, std::uint32_t* dst) {
    const double xi = sx[i], yi = sy[i], zi = sz[i], di = d[i];
    std::size_t m = 0;
    for (std::uint32_t k = outer_start[i]; k < outer_start[i + 1]; ++k) {
      const std::uint32_t e = outer[k];
      const std::uint32_t j = e >> kCodeBits;
      const auto& sh = shift[e & kCodeMask];
      const double dx = xi - sx[j] + sh[0];
      const double dy = yi - sy[j] + sh[1];
      const double dz = zi - sz[j] + sh[2];
      const double rx = hxx * dx + hxy * dy, ry = hyy * dy, rz = hzz * dz;
      const double cut = 0.5 * (di + d[j]) + inner_skin;
      dst[m] = e;
      m += (rx * rx + ry * ry + rz * rz < cut * cut) ? 1 : 0;
    }
    return m;
  };
  fill_rows(n, threads, inner_start_, inner_entries_, bound, row);
  set_inner_owner();
  inner_ref_pos_ = state.pos;
  inner_h_ref_inv_ = state.box.h_inv();
  ++inner_builds_;
  inner_generation_ = next_generation();
}

void NeighbourList::set_inner_owner() {
  const std::size_t n = inner_start_.empty() ? 0 : inner_start_.size() - 1;
  inner_owner_.resize(inner_entries_.size());
  max_row_ = 0;
  for (std::size_t i = 0; i < n; ++i) {
    std::fill(inner_owner_.begin() + inner_start_[i], inner_owner_.begin() + inner_start_[i + 1],
              std::uint32_t(i));
    max_row_ = std::max<std::size_t>(max_row_, inner_start_[i + 1] - inner_start_[i]);
  }
}

NeighbourList::Snapshot NeighbourList::snapshot() const {
  Snapshot s;
  s.skin = skin_;
  s.inner_skin = inner_skin_;
  s.built = built_;
  s.builds = builds_;
  s.inner_builds = inner_builds_;
  s.start = start_;
  s.entries = entries_;
  s.inner_start = inner_start_;
  s.inner_entries = inner_entries_;
  s.ref_pos = ref_pos_;
  s.inner_ref_pos = inner_ref_pos_;
  s.h_ref_inv = h_ref_inv_;
  s.inner_h_ref_inv = inner_h_ref_inv_;
  s.a_min = a_min_;
  s.a_max = a_max_;
  return s;
}

namespace {

// A CSR list over n rows whose entries name particles below n.
void check_rows(const std::vector<std::uint32_t>& start, const std::vector<std::uint32_t>& entries,
                std::size_t n, const char* what) {
  const auto bad = [&](const std::string& why) {
    throw std::invalid_argument(std::string("neighbour list snapshot: ") + what + ": " + why);
  };
  if (start.size() != n + 1 || start.front() != 0 || start.back() != entries.size())
    bad("row starts do not match " + std::to_string(n) + " rows of " +
        std::to_string(entries.size()) + " entries");
  for (std::size_t i = 0; i < n; ++i)
    if (start[i] > start[i + 1])
      bad("row starts decrease at row " + std::to_string(i));
  for (std::uint32_t e : entries)
    if ((e >> NeighbourList::kCodeBits) >= n || (e & NeighbourList::kCodeMask) >= 27)
      bad("an entry names particle " + std::to_string(e >> NeighbourList::kCodeBits) +
          " or image " + std::to_string(e & NeighbourList::kCodeMask));
}

}  // namespace

NeighbourList NeighbourList::from(const Snapshot& s) {
  NeighbourList l(s.skin);
  l.inner_skin_ = s.inner_skin;
  l.built_ = s.built;
  l.builds_ = s.builds;
  l.inner_builds_ = s.inner_builds;
  if (s.built) {
    const std::size_t n = s.ref_pos.size() / 3;
    if (s.ref_pos.size() != 3 * n || s.inner_ref_pos.size() != 3 * n)
      throw std::invalid_argument("neighbour list snapshot: reference positions of " +
                                  std::to_string(s.ref_pos.size()) + " and " +
                                  std::to_string(s.inner_ref_pos.size()) + " values");
    check_rows(s.start, s.entries, n, "outer list");
    check_rows(s.inner_start, s.inner_entries, n, "inner list");
    l.start_ = s.start;
    l.entries_ = s.entries;
    l.inner_start_ = s.inner_start;
    l.inner_entries_ = s.inner_entries;
    l.ref_pos_ = s.ref_pos;
    l.inner_ref_pos_ = s.inner_ref_pos;
    l.h_ref_inv_ = s.h_ref_inv;
    l.inner_h_ref_inv_ = s.inner_h_ref_inv;
    l.a_min_ = s.a_min;
    l.a_max_ = s.a_max;
    l.set_inner_owner();
    l.inner_generation_ = next_generation();
  }
  return l;
}

void NeighbourList::build_all_pairs(const State& state) {
  const std::size_t n = state.size();
  const Eigen::Matrix3d h = state.box.h();
  const double t = state.box.tilt_fraction();
  const double* d = state.diameter.data();
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = i + 1; j < n; ++j) {
      double dx = state.x()[i] - state.x()[j], dy = state.y()[i] - state.y()[j],
             dz = state.z()[i] - state.z()[j];
      const std::uint32_t code = image_code(dx, dy, dz, t);
      const Eigen::Vector3d r = h * Eigen::Vector3d(dx, dy, dz);
      const double cut = 0.5 * (d[i] + d[j]) + skin_;
      if (r.squaredNorm() < cut * cut) {
        entries_.push_back((std::uint32_t(j) << kCodeBits) | code);
      }
    }
    start_[i + 1] = static_cast<std::uint32_t>(entries_.size());
  }
}

double NeighbourList::max_displacement2(const State& state, const double* ref, std::size_t lo,
                                        std::size_t hi) {
  const std::size_t n = state.size();
  const Eigen::Matrix3d h = state.box.h();
  const double hxx = h(0, 0), hxy = h(0, 1), hyy = h(1, 1), hzz = h(2, 2);
  const double* p = state.pos.data();
  const double* q = ref;
  double m = 0.0, sum = 0.0;
#pragma omp simd reduction(max : m) reduction(+ : sum)
  for (std::size_t i = lo; i < hi; ++i) {
    const double ux = p[i] - q[i], uy = p[n + i] - q[n + i], uz = p[2 * n + i] - q[2 * n + i];
    const double rx = hxx * ux + hxy * uy, ry = hyy * uy, rz = hzz * uz;
    const double d2 = rx * rx + ry * ry + rz * rz;
    m = d2 > m ? d2 : m;
    sum += d2;  // a NaN never wins the max, but it poisons the sum
  }
  return std::isfinite(sum) ? m : std::nan("");
}

NeighbourList::Drift NeighbourList::drift(const State& state, const std::vector<double>& ref,
                                          const Eigen::Matrix3d& h_ref_inv, int threads) const {
  const std::size_t n = state.size();
  double d2max = 0.0;
  bool finite = true;
#pragma omp parallel num_threads(threads) if (threads > 1) reduction(max : d2max) \
    reduction(&& : finite)
  {
    const std::size_t t = std::size_t(omp_get_thread_num());
    const std::size_t m = std::size_t(omp_get_num_threads());
    const double d2 = max_displacement2(state, ref.data(), n * t / m, n * (t + 1) / m);
    finite = !std::isnan(d2);
    d2max = finite ? d2 : 0.0;
  }
  if (!finite)
    throw IntegrationError("particle positions became non-finite");
  return {std::sqrt(d2max), smallest_stretch(state.box.h() * h_ref_inv)};
}

double NeighbourList::allowed_drift(double sigma_min, double skin, double margin) const {
  // sigma_min (a + skin) - 2 d_max >= a + margin is linear in a: the extreme diameters decide.
  double allowed = std::numeric_limits<double>::infinity();
  for (double a : {a_min_, a_max_})
    allowed = std::min(allowed, 0.5 * (sigma_min * (a + skin) - a - margin));
  return allowed;
}

bool NeighbourList::holds(const Drift& d, double skin, double margin) const {
  // True for a NaN displacement, as the bound cannot be decided: the force pass that follows
  // reports the non-finite state (rebuilding from NaN positions could not).
  return !(d.d_max > allowed_drift(d.sigma_min, skin, margin));
}

double NeighbourList::inner_drift_allowed(const State& state) const {
  if (!built_ || inner_ref_pos_.size() != state.pos.size())
    return -std::numeric_limits<double>::infinity();
  return allowed_drift(smallest_stretch(state.box.h() * inner_h_ref_inv_), inner_skin_, 0.0);
}

bool NeighbourList::inner_holds(const State& state, double max_drift) const {
  return std::isfinite(max_drift) && max_drift <= inner_drift_allowed(state);
}

NeighbourList::Status NeighbourList::status(const State& state, int threads) const {
  if (!built_ || ref_pos_.size() != state.pos.size())
    return Status::kStale;
  if (holds(drift(state, inner_ref_pos_, inner_h_ref_inv_, threads), inner_skin_, 0.0))
    return Status::kValid;
  if (holds(drift(state, ref_pos_, h_ref_inv_, threads), skin_, inner_skin_))
    return Status::kInnerStale;
  return Status::kStale;
}

std::vector<std::uint32_t> NeighbourList::cell_order(const State& state, double cell_size) {
  const std::size_t n = state.size();
  const Eigen::Vector3i nb = bins_for(state.box, cell_size, n);
  std::vector<std::uint64_t> key(n);
  for (std::size_t i = 0; i < n; ++i) {
    const auto c = [&](double s, int m) {
      return std::uint64_t(std::clamp(static_cast<int>(s * m), 0, m - 1));
    };
    key[i] =
        (c(state.x()[i], nb[0]) * nb[1] + c(state.y()[i], nb[1])) * nb[2] + c(state.z()[i], nb[2]);
  }
  std::vector<std::uint32_t> order(n);
  std::iota(order.begin(), order.end(), 0u);
  std::stable_sort(order.begin(), order.end(),
                   [&](std::uint32_t a, std::uint32_t b) { return key[a] < key[b]; });
  return order;
}

}  // namespace jamflow
