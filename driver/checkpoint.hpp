// Checkpoints: everything a run needs to continue, stored in the run's own HDF5 file under
// /checkpoint (the .part file while the run goes, the finished file afterwards, so that a
// finished run can be extended). See README "Checkpoints and restarts".
//
//   /checkpoint                      attrs: format, replicas
//   /checkpoint/replicas/<k>         attrs: seed, status, wall_seconds, cpu_seconds,
//                                           cpu_from_wall, trajectory_bytes, kernel,
//                                           kernel_target, threads, resumes, history,
//                                           t_start, horizon, step_cross, step_norm,
//                                           step_pairs (a checkpoint without cpu_seconds, written
//                                           before CPU time was recorded, is read with its
//                                           wall seconds in its place and cpu_from_wall set)
//     series/<field>                 the samples so far (time, strain, volume, ...)
//     integrator                     attrs: the integrator's counters
//     model                          attrs: evaluations, builds_at_last_sort, sorted_once,
//                                           evaluated, particle_volume
//     model/state                    pos, image, diameter, species, id; attrs: box, time
//     model/list                     the neighbour lists (lib/neighbour_list.hpp Snapshot)
#pragma once
#include <string>
#include <vector>

#include "driver/run.hpp"

namespace jamflow {

class H5Writer;
class H5Reader;

inline constexpr std::int64_t kCheckpointFormat = 1;

// Writes the replicas' checkpoints (finished and running alike) under /checkpoint.
void write_checkpoint(H5Writer& w, const std::vector<ReplicaResult>& replicas);

// Reads them back; an IoError names what is missing or inconsistent.
std::vector<ReplicaResult> read_checkpoint(const H5Reader& r);

// A run file read back (what `jamflow run` and every sweep point write): the one reader of run
// files for the sweep's collect and the studies. Each replica has its own summary (values,
// verdicts, texts; from /summary, or /replicas/<k>/summary with several) and status; with
// `everything`, also what /checkpoint holds (series, final state, integrator counters, wall
// and CPU time). A file without cpu_seconds (written before CPU time was recorded) is read with
// its wall seconds in their place and ReplicaResult::cpu_from_wall set. An IoError names what is
// missing.
struct RunFile {
  std::string scene;   // the root attribute "scene": the canonical scene text
  std::string status;  // the root attribute "status"
  std::vector<ReplicaResult> replicas;
};
RunFile read_run_file(const std::string& path, bool everything = true);

}  // namespace jamflow
