// Trajectories in H5MD 1.1 (https://www.nongnu.org/h5md/), the HDF5 layout MDAnalysis and other
// tools read: /h5md (version, author, creator) and /particles/all with
//   box        dimension 3, boundary periodic x3, edges {step, time, value: frames x 3 x 3}
//              (rows = the lattice vectors; the Lees–Edwards tilt is b = (xy, Ly, 0))
//   position   {step, time, value: frames x N x 3}, real space, wrapped into the cell
//   species    N (0 = small, 1 = large), diameter N (time-independent)
// and /observables/strain {step, time, value: frames}, the total strain (the tilt is only
// known modulo remaps), and /parameters with the attributes scene (the run's scene, TOML, as
// the run file's /scene) and seed (the replica's seed), so the file says how it was made. Particles
// are in id order. Frames are appended as the run goes and flushed to disk on flush(), so that a
// checkpoint can name how many frames are safe.
#pragma once
#include <hdf5.h>

#include <cstdint>
#include <string>

#include "lib/state.hpp"

namespace jamflow {

class H5mdTrajectory {
 public:
  // Creates `path` for the particles of `state` (replacing any file there), with `scene` and
  // `seed` in /parameters. With keep_frames >= 0, opens the existing file instead and keeps its
  // first keep_frames frames (a run continued from a checkpoint; /parameters is written anew).
  // Throws IoError.
  H5mdTrajectory(const std::string& path, const State& state, const std::string& scene,
                 std::uint64_t seed, std::int64_t keep_frames = -1);
  ~H5mdTrajectory();
  H5mdTrajectory(const H5mdTrajectory&) = delete;
  H5mdTrajectory& operator=(const H5mdTrajectory&) = delete;

  // One frame at integer `step` (the run's sample index) and time `time`.
  void append(const State& state, std::int64_t step, double time);
  // Writes everything appended so far to disk.
  void flush();
  // Flushes and closes the file (also done by the destructor, which ignores errors).
  void close();
  std::int64_t frames() const { return frames_; }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  hid_t file_ = -1;
  std::int64_t n_ = 0, frames_ = 0;
};

}  // namespace jamflow
