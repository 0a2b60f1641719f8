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
//                                    series: the group holding the samples so far (the
//                                           replica's /timeseries or
//                                           /replicas/<k>/timeseries, stored once)
//     series/<field>                 only the columns that group lacks (piston_dissipation at
//                                    constant volume); files written before every column
//                                    here (read as before)
//     integrator                     attrs: the integrator's counters
//     model                          attrs: evaluations, builds_at_last_sort, sorted_once,
//                                           evaluated, particle_volume
//     model/state                    pos, image, diameter, species, id; attrs: box, time
//     model/list                     the neighbour lists (lib/neighbour_list.hpp Snapshot)
//   Every dataset carries the attribute "unit" (unit_of, driver/run.hpp), as the run file's do.
#pragma once
#include <string>
#include <string_view>
#include <vector>

#include "driver/run.hpp"

namespace jamflow {

class H5Writer;
class H5Reader;

inline constexpr std::int64_t kCheckpointFormat = 1;

// The sampled columns of a replica's series, in Sample's order: the run file's timeseries
// group and a checkpoint store these names.
struct SeriesField {
  const char* name;
  double Sample::*field;
};
inline constexpr SeriesField kSeriesFields[] = {
    {"time", &Sample::time},
    {"strain", &Sample::strain},
    {"volume", &Sample::volume},
    {"phi", &Sample::phi},
    {"pressure", &Sample::pressure},
    {"sigma_xy", &Sample::sigma_xy},
    {"energy", &Sample::energy},
    {"dissipation", &Sample::dissipation},
    {"piston_dissipation", &Sample::piston_dissipation}};

// Whether a run's timeseries group holds `column` (piston_dissipation only with a piston).
bool timeseries_has(const RunSpec& spec, std::string_view column);

// Writes the replicas' checkpoints (finished and running alike) under /checkpoint, with the
// attribute "digest" (checkpoint_digest) of the scene, the version and the state. Replica k's
// series is not written again: `timeseries[k]` names the group of this file that holds it.
void write_checkpoint(H5Writer& w, const RunSpec& spec, const std::vector<ReplicaResult>& replicas,
                      const std::vector<std::string>& timeseries);

// A digest (64-bit FNV-1a, hex) of what a continued run must not change: the scene text as
// parsed, but for the keys a continuation may set (run.threads, output.file, and --extend's
// run.t_av, run.target_error, run.max_time, output.checkpoint_every), the version that wrote
// it, and the checkpointed replicas' sizes, sample counts, times and cells.
std::string checkpoint_digest(const std::string& scene_text, const std::string& version,
                              const std::vector<ReplicaResult>& replicas);

// --resume and --extend (`option`) of `file`: a ConfigError, one line, when the root attributes
// scene or version no longer match the checkpoint (its digest; a file written before digests
// were stored is checked as far as its state tells: the particle count, and a cell volume that
// moves only at constant pressure).
void check_checkpoint_matches(const H5Reader& r, const std::vector<ReplicaResult>& replicas,
                              const std::string& option, const std::string& file);

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
  std::string scene;  // the root attribute "scene": the canonical scene text
  RunStatus status;   // the root attribute "status"
  std::vector<ReplicaResult> replicas;
};
RunFile read_run_file(const std::string& path, bool everything = true);

// A run file opened to be continued by `option` (--resume or --extend): its scene text and
// status, and its checkpointed replicas (check_checkpoint_matches passed), the finished ones
// with their summaries (which a continuation keeps where it does not extend them; /checkpoint
// holds none). An IoError says what makes it no run file; a ConfigError, a digest mismatch.
struct Continuation {
  std::string scene;
  RunStatus status;
  std::vector<ReplicaResult> replicas;
};
Continuation read_continuation(const std::string& path, const std::string& option);

// The root attribute "status" of a run file, or (never throwing) kUnreadable with why: a file
// that cannot be opened, or has no status.
RunStatus read_run_status(const std::string& path);

// Whether a replica read from a checkpoint is finished for `spec`: complete, and either its
// length was found from its data (t_eq or t_av "auto") or it holds every sample of t_eq + t_av.
bool replica_finished(const RunSpec& spec, const ReplicaResult& replica);

// --resume and --extend (`option`) of `file`: a ConfigError, one line, when no replica would be
// continued, so that a finished file is never rewritten with nothing new (the replicas of
// `replicas` not continued keep the summaries they hold).
void check_continuation(const RunSpec& spec, const std::vector<ReplicaResult>& replicas,
                        const std::string& option, const std::string& file);

// The final run file could not be written at spec.file (a full disk, a lost mount): writes the
// finished run to the temporary folder instead ($TMPDIR, else /tmp) as <stem>.<pid>.h5, so that
// what is in memory is not lost. Returns that path, or "" when that failed too (`why` gets the
// reason). Not tried when the temporary folder is the output's own folder.
std::string write_run_file_elsewhere(const RunSpec& spec,
                                     const std::vector<ReplicaResult>& replicas,
                                     std::string* why = nullptr);

// The message for a final write that failed: where the finished run is, or exactly what is
// kept (OUT.part: the last checkpoint written before).
std::string kept_message(const std::string& file, const std::string& write_error,
                         const std::string& kept_in);

}  // namespace jamflow
