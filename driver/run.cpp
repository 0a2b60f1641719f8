// The run driver's loop: one replica from its spec (or its checkpoint) through the time loop with
// sampling, trajectories, checkpoints, the budget and the run-length policy; all replicas of a
// spec, with their output. The spec (run_spec.cpp), the summary (summary.cpp) and the run file
// (run_file.cpp) are apart.
#include "driver/run.hpp"

#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <thread>

#include "driver/checkpoint.hpp"
#include "driver/run_detail.hpp"
#include "driver/simulation.hpp"
#include "lib/cpu_clock.hpp"
#include "lib/error.hpp"
#include "lib/h5.hpp"
#include "lib/h5md.hpp"
#include "lib/progress.hpp"
#include "lib/statistics.hpp"
#include "lib/xyz.hpp"

namespace jamflow {

namespace {

std::string stem_of(const std::string& path) {
  const std::string ext = ".h5";
  if (path.size() > ext.size() && path.compare(path.size() - ext.size(), ext.size(), ext) == 0) {
    return path.substr(0, path.size() - ext.size());
  }
  return path;
}

std::string replica_suffix(std::size_t k, std::size_t count) {
  return count > 1 ? ".r" + std::to_string(k) : "";
}

}  // namespace

using detail::run_length_bound;

namespace {

std::string signal_name(int sig) {
  switch (sig) {
    case SIGTERM:
      return "SIGTERM";
    case SIGINT:
      return "SIGINT";
    case SIGHUP:
      return "SIGHUP";
    default:
      return "signal " + std::to_string(sig);
  }
}

// Raises `attention` (which the integrator polls between steps) when the run must look up
// from its loop: a stop request, a signal, a checkpoint request, or a checkpoint due by the
// clock. Polls every 10 ms from a thread of its own. The clock runs from the end of the last
// checkpoint (restart()), and waits at least as long as that checkpoint took to write: a write
// slower than checkpoint_every (a large system, a slow disk, a sanitizer build) then costs at
// most half of the wall time, instead of leaving the run a step between writes.
class Watcher {
 public:
  Watcher(const RunOptions& options, std::atomic<bool>& attention)
      : options_(options), attention_(attention) {
    const bool timed = bool(options.checkpoint) && options.checkpoint_every > 0.0;
    if (!options.stop && !options.control && !timed)
      return;
    if (raised())
      attention_.store(true);  // already set before the run began
    restart(0.0);
    thread_ = std::jthread([this, timed](std::stop_token token) {
      while (!token.stop_requested()) {
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
        bool raise = raised();
        if (timed && !timer_due_.load() &&
            std::chrono::steady_clock::now().time_since_epoch().count() >= next_.load()) {
          timer_due_.store(true);
          raise = true;
        }
        if (raise)
          attention_.store(true);
      }
    });
  }
  // The next timed checkpoint: checkpoint_every from now, or `wrote` seconds (the last write's
  // duration) if that is longer.
  void restart(double wrote) {
    const auto gap = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
        std::chrono::duration<double>(std::max(options_.checkpoint_every, wrote)));
    next_.store((std::chrono::steady_clock::now() + gap).time_since_epoch().count());
  }
  bool take_timer() { return timer_due_.exchange(false); }

 private:
  bool raised() const {
    return (options_.stop && options_.stop->load()) ||
           (options_.control &&
            (options_.control->signal.load() != 0 || options_.control->checkpoint.load()));
  }
  const RunOptions& options_;
  std::atomic<bool>& attention_;
  std::atomic<bool> timer_due_{false};
  std::atomic<std::chrono::steady_clock::rep> next_{0};  // steady_clock ticks
  std::jthread thread_;
};

}  // namespace

namespace {

// CPU seconds for run_replica. With one thread, the run's own thread's CPU time
// (CLOCK_THREAD_CPUTIME_ID): every force pass, integrator step and checkpoint write of the
// replica happens in it, and other threads of the process are not counted: the Watcher above,
// the Python module's thread that polls for signals while a run goes on in another thread, and
// other Python threads or runs of other replicas that a caller might start in the same process.
// With OpenMP threads the force passes are spread over a team, so the whole process's CPU time
// (CLOCK_PROCESS_CPUTIME_ID) is taken instead: it counts the team, and would also count
// anything else the process does meanwhile (a `jamflow run` does nothing else, and the sweep
// engine and the studies start one `jamflow run` process per point). lib/cpu_clock.hpp.

// How long a run goes, decided from its samples so far (so a continued run decides the same).
struct Length {
  bool done = false;
  double t_eq = 0.0;     // the transient's end (given, or found)
  double horizon = 0.0;  // the time to reach before deciding again
  std::string why, method;
};

Length decide_length(const RunSpec& spec, const Series& series, const StepPairs* steps) {
  Length len;
  const double eps = 1e-9 * spec.sample_every;
  const double t = series.samples.back().time;
  len.t_eq = spec.t_eq;
  len.method = "given";
  if (spec.auto_eq) {
    std::size_t drop = 0;
    for (double Sample::*field : {&Sample::sigma_xy, &Sample::pressure, &Sample::phi})
      drop = std::max(drop, mser_truncation(series.column(field)));
    drop = std::min(drop, series.samples.size() - 1);
    len.t_eq = series.samples[drop].time;
    len.method =
        "MSER-5 (marginal standard error rule on batch means of 5 samples) of sigma_xy, "
        "P_hat and phi; the latest of their truncation points";
  }
  if (!spec.auto_av) {
    len.horizon = len.t_eq + spec.t_av;
    if (spec.auto_eq)
      len.horizon = std::min(len.horizon, run_length_bound(spec));
    len.done = t >= len.horizon - eps;
    len.why =
        spec.auto_eq ? "t_av = " + fmt(spec.t_av) + " after the transient" : "t_eq + t_av as given";
    return len;
  }
  const double window = t - len.t_eq;
  const double least = 4.0 * double(spec.blocks) * spec.sample_every;
  if (window < least - eps) {
    len.horizon = std::min(spec.max_time, len.t_eq + least);
    len.done = t >= spec.max_time - eps;
    len.why = "max_time reached before the window held 4 samples per block";
    return len;
  }
  RunSpec eff = spec;
  eff.t_eq = len.t_eq;
  const Summary sum = summarize(eff, series, steps);
  const bool sheared = spec.shear_rate > 0.0;
  const std::string name = !sheared ? "pressure" : spec.ensemble->imposed_pressure() ? "mu" : "eta";
  const Estimate e = !sheared                            ? sum.pressure
                     : spec.ensemble->imposed_pressure() ? sum.mu
                                                         : *sum.eta;
  const double value = e.value, err = e.err;
  const double rel = std::abs(err / value);
  const bool decorrelated = sum.decorrelated.passed();
  char what[200];
  std::snprintf(what, sizeof what, "relative error of %s %.3g %s target_error %g%s at t_av = %g",
                name.c_str(), rel, rel <= spec.target_error ? "<=" : ">", spec.target_error,
                decorrelated ? "" : " (blocks shorter than 2 tau)", window);
  if (rel <= spec.target_error && decorrelated) {
    len.done = true;
    len.why = std::string("target reached: ") + what;
  } else if (t >= spec.max_time - eps) {
    len.done = true;
    len.why = std::string("max_time reached: ") + what;
  } else {
    // The block error falls as 1 / sqrt(window): aim for the target, growing by 1.5x to 4x.
    const double ratio = rel / spec.target_error;
    const double grow = std::clamp(std::isfinite(ratio) ? ratio * ratio : 4.0, 1.5, 4.0);
    len.horizon = std::min(spec.max_time, len.t_eq + grow * window);
    len.why = what;
  }
  return len;
}

// An observer of the time loop made of functions (any left empty does nothing).
struct HookObserver final : LoopObserver {
  std::function<bool(long long)> on_proceed;
  std::function<void(long long, double)> on_sample;
  std::function<bool()> on_attend;
  bool proceed(Simulation&, long long k) override { return on_proceed ? on_proceed(k) : true; }
  void sampled(Simulation&, long long k, double t) override {
    if (on_sample)
      on_sample(k, t);
  }
  bool attend(Simulation&) override { return on_attend ? on_attend() : false; }
};

long long sample_index(double time, double sample_every) {
  return static_cast<long long>(std::floor(time / sample_every + 1e-9));
}

}  // namespace

ReplicaResult run_replica(const RunSpec& spec, std::uint64_t seed, const RunOptions& options,
                          const ReplicaResult* from) {
  ReplicaResult res;
  res.seed = seed;
  const auto wall0 = std::chrono::steady_clock::now();
  Simulation sim(spec, seed, from ? from->end.state : initial_state(spec, seed),
                 Simulation::model_options(spec));
  Model& model = sim.model();
  Integrator* const integ = &sim.integrator();
  res.kernel = model.force_field().kernel();
  res.kernel_target = model.force_field().target();
  res.threads = model.force_field().threads();
  const bool cpu_process = res.threads > 1;
  const double cpu0 = cpu_clock(cpu_process);
  std::atomic<bool> attention{false};
  const Ensemble& ens = sim.ensemble();
  if (integ->has_solver_history())
    res.history = "kept";

  double wall_before = 0.0, cpu_before = 0.0;
  long long k_first = 1;  // the first sample this call computes
  if (from) {
    if (from->series.samples.empty())
      throw IoError("the checkpoint of replica seed " + std::to_string(seed) + " holds no samples");
    model.restore(from->end);
    integ->restore_statistics(from->integrator_stats);
    res.series = from->series;
    res.t_start = from->t_start;
    res.resumes = from->resumes + 1;
    res.seed = from->seed;
    wall_before = from->wall_seconds;
    cpu_before = from->cpu_seconds;
    res.cpu_from_wall = from->cpu_from_wall;
    k_first = static_cast<long long>(from->series.samples.size());
    if (integ->has_solver_history()) {
      res.history = (from->history == "kept" ? std::string() : from->history + "; ") +
                    "fresh after resume at t = " + fmt(model.state().time - from->t_start);
    }
  } else {
    res.t_start = model.state().time;
  }
  const double t_start = res.t_start;
  sim.set_start_time(t_start);
  const bool automatic = spec.auto_eq || spec.auto_av;
  // The first horizon: t_eq + t_av; with t_eq = "auto", t_av (where the transient is first
  // looked for); a continued automatic run keeps the horizon it had.
  res.horizon = spec.auto_eq && !spec.auto_av ? spec.t_av : spec.t_eq + spec.t_av;
  if (from && automatic && from->horizon > 0.0)
    res.horizon = from->horizon;
  long long k_max = sample_index(res.horizon, spec.sample_every);
  const double t_total = res.horizon;
  const long long traj_stride =
      spec.trajectory_every > 0 ? std::llround(spec.trajectory_every / spec.sample_every) : 0;

  const bool traj_xyz = traj_stride > 0 && spec.trajectory_format != "h5md";
  const bool traj_h5md = traj_stride > 0 && spec.trajectory_format != "xyz";
  std::ofstream traj;
  std::string traj_path;
  std::unique_ptr<H5mdTrajectory> h5md;
  const std::string h5md_path = options.label + ".traj.h5md";
  if (from && from->status.is_complete()) {
    // Extending a finished run: its trajectories were completed (renamed); they go on as .part.
    for (const std::string& path : {options.label + ".traj.xyz", h5md_path}) {
      std::error_code ec;
      if (std::filesystem::exists(path, ec) && !std::filesystem::exists(path + ".part", ec))
        std::filesystem::rename(path, path + ".part", ec);
    }
  }
  if (traj_h5md) {
    // The frames up to the checkpoint's last sample (k = 0, stride, 2 stride, ...) are kept.
    const std::int64_t keep =
        from ? std::int64_t(from->series.samples.size() - 1) / traj_stride + 1 : -1;
    h5md = std::make_unique<H5mdTrajectory>(
        h5md_path + ".part", from ? from->end.state : model.state(), spec.scene_text, seed, keep);
  }
  if (traj_xyz) {
    traj_path = options.label + ".traj.xyz";
    if (from) {
      // Frames written after the checkpoint (a run killed later) are dropped.
      std::error_code ec;
      std::filesystem::resize_file(traj_path + ".part", std::uintmax_t(from->trajectory_bytes), ec);
      if (ec)
        throw IoError("cannot continue trajectory '" + traj_path + ".part': " + ec.message());
      traj.open(traj_path + ".part", std::ios::app);
    } else {
      traj.open(traj_path + ".part");
    }
    if (!traj)
      throw IoError("cannot write trajectory '" + traj_path + ".part'");
  }
  res.trajectory_bytes = from ? from->trajectory_bytes : 0;

  Progress progress(options.label, t_total, options.quiet,
                    from ? from->series.samples.back().time : 0.0, options.progress);
  auto record = [&](double t_rel) {
    const Evaluation& ev = model.evaluate();
    const State& s = model.state();
    res.series.samples.push_back(Sample{t_rel, s.box.strain, ev.volume, ev.phi, ev.pressure,
                                        ev.sigma_xy, ev.forces.energy, ev.dissipation,
                                        ens.piston_dissipation(ev.pressure)});
  };
  auto elapsed = [&] {
    return wall_before +
           std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  };
  auto cpu_elapsed = [&] { return cpu_before + (cpu_clock(cpu_process) - cpu0); };
  // The replica as it stands, ready to continue.
  auto fill = [&](ReplicaResult& r) {
    r.end = model.snapshot();
    r.final_state = model.state();
    r.integrator_stats = integ->statistics();
    r.integrator_stats.emplace_back("force_evaluations", double(model.force_evaluations()));
    r.integrator_stats.emplace_back("force_pass_equivalents", integ->force_pass_equivalents(model));
    r.wall_seconds = elapsed();
    r.cpu_seconds = cpu_elapsed();
    if (traj_xyz) {
      traj.flush();
      r.trajectory_bytes = static_cast<std::int64_t>(traj.tellp());
    }
    if (h5md)
      h5md->flush();
  };
  auto write_frame = [&](long long k, double t_rel) {
    if (traj_xyz)
      write_xyz(traj, model.state());
    if (h5md)
      h5md->append(model.state(), k, t_rel);
  };
  auto checkpoint = [&] {
    if (!options.checkpoint)
      return;
    const RunStatus status = res.status;
    res.status = RunStatus::running();
    fill(res);
    options.checkpoint(res);
    res.status = status;
  };
  Watcher watcher(options, attention);
  // Looks up from the loop: writes a checkpoint if one is due; true if the run must stop.
  auto attend = [&]() -> bool {
    const int sig = options.control ? options.control->signal.load() : 0;
    const bool stop = sig != 0 || (options.stop && options.stop->load());
    const bool asked = options.control && options.control->checkpoint.exchange(false);
    if (watcher.take_timer() || asked || stop) {
      const auto began = std::chrono::steady_clock::now();
      checkpoint();
      watcher.restart(
          std::chrono::duration<double>(std::chrono::steady_clock::now() - began).count());
    }
    if (stop) {
      res.status = RunStatus::interrupted("at t = " + fmt(model.state().time - t_start) +
                                          (sig != 0 ? " by " + signal_name(sig) : std::string()));
      res.signal = sig;
    }
    return stop;
  };
  // The step-to-step oscillation test (fixed-step integrators).
  const bool step_test = integ->nominal_dt() > 0.0;
  std::vector<double> before;
  if (from)
    res.steps = from->steps;
  const double t_begin = model.state().time;
  try {
    if (!from) {
      record(0.0);
      if (traj_stride > 0)
        write_frame(0, 0.0);
      checkpoint();  // the .part file exists from the start
    }
    // The loop's observers, in the order they are called: the run-length policy and the
    // budget before each sample; the sample itself (with the oscillation test's step pair), the
    // trajectory frame and the progress line at it; checkpoints and signals when the loop looks
    // up.
    HookObserver length, budget, sampler, frames, report, control;
    length.on_proceed = [&](long long k) {
      if (k <= k_max)
        return true;
      if (!automatic)
        return false;
      const Length len = decide_length(spec, res.series, step_test ? &res.steps : nullptr);
      if (len.done)
        return false;
      res.horizon = std::max(len.horizon, double(k) * spec.sample_every);
      k_max = sample_index(res.horizon, spec.sample_every);
      progress.set_total(res.horizon);
      return true;
    };
    // The budget, checked before each sample (a count, so the same sample wherever it runs),
    // in force-pass equivalents: what the integrator computed, not only the model's passes.
    budget.on_proceed = [&](long long) {
      if (spec.max_force_evaluations > 0 &&
          integ->force_pass_equivalents(model) >= double(spec.max_force_evaluations)) {
        res.status = RunStatus::budget("stopped at t = " + fmt(model.state().time - t_start) +
                                       " after " + fmt(integ->force_pass_equivalents(model)) +
                                       " force-pass equivalents (" +
                                       std::to_string(model.force_evaluations()) +
                                       " force evaluations; [run] max_force_evaluations = " +
                                       std::to_string(spec.max_force_evaluations) + ")");
        return false;
      }
      return true;
    };
    sampler.on_sample = [&](long long, double t_rel) {
      if (step_test && t_rel > spec.t_eq + 1e-9 * spec.sample_every) {
        // The forces of the step before this sample, and of the sample itself.
        before = model.last_evaluation().forces.force;
        record(t_rel);
        res.steps.add(before, model.last_evaluation().forces.force);
      } else {
        record(t_rel);
      }
    };
    frames.on_sample = [&](long long k, double t_rel) {
      if (traj_stride > 0 && k % traj_stride == 0)
        write_frame(k, t_rel);
    };
    report.on_sample = [&](long long, double t_rel) {
      const Sample& last = res.series.samples.back();
      char extra[160];
      std::snprintf(extra, sizeof extra, "phi %.5f  pressure %.3e  sigma_xy %.3e", last.phi,
                    last.pressure, last.sigma_xy);
      progress.update(t_rel, extra);
    };
    control.on_attend = attend;
    sim.run(spec.sample_every, k_first, {&length, &budget, &sampler, &frames, &report, &control},
            &attention);
    if (res.status.is_complete())
      progress.finish(res.series.samples.back().time);
  } catch (const IntegrationError& e) {
    res.status = RunStatus::failed("at t = " + fmt(model.state().time - t_start) + ": " + e.what());
  } catch (const ConfigError& e) {
    // The scene was valid when the run started; a state that has since left the range the
    // engine accepts (a piston that collapsed the box below the neighbour list's cell) is a
    // failure of the run, recorded in its .part like any other, not bad input.
    if (!(model.state().time > t_begin))
      throw;
    res.status = RunStatus::failed("at t = " + fmt(model.state().time - t_start) +
                                   ": the state left the engine's range: " + e.what());
  }
  fill(res);
  res.integrator_stats.emplace_back("neighbour_list_builds", double(model.list_builds()));
  if (traj_xyz) {
    traj.close();
    if (res.status.is_complete())
      std::filesystem::rename(traj_path + ".part", traj_path);
  }
  if (h5md) {
    h5md->close();
    if (res.status.is_complete())
      std::filesystem::rename(h5md_path + ".part", h5md_path);
  }
  if (res.status.is_complete()) {
    const StepPairs* steps = step_test ? &res.steps : nullptr;
    const Length len = decide_length(spec, res.series, steps);
    RunSpec eff = spec;
    eff.t_eq = len.t_eq;
    res.summary = summarize(eff, res.series, steps);
    res.summary.t_eq = len.t_eq;
    res.summary.t_av = res.series.samples.back().time - len.t_eq;
    res.summary.run_length = len.why;
    res.summary.t_eq_method = len.method;
    if (spec.auto_av && len.why.rfind("max_time", 0) == 0)
      res.summary.warnings.push_back("t_av = \"auto\": " + len.why);
  }
  res.wall_seconds = elapsed();
  res.cpu_seconds = cpu_elapsed();
  return res;
}

RunOutcome run_replicas(const RunSpec& spec, const RunOptions& options,
                        const OutputOptions& output) {
  if (output.write) {
    check_output(spec.file, output);
  } else if (spec.trajectory_every > 0.0) {
    throw ConfigError("[output] trajectory_every = " + fmt(spec.trajectory_every) +
                      " needs an output file; allowed 0 for a run that writes no files");
  }
  RunOutcome outcome;
  std::vector<ReplicaResult>& results = outcome.replicas;
  if (output.continue_from)
    results = *output.continue_from;
  const std::string stem = stem_of(spec.file);
  const auto count = static_cast<std::size_t>(spec.replicas);
  if (results.size() > count) {
    throw ConfigError("[run] replicas = " + std::to_string(count) + " but the checkpoint holds " +
                      std::to_string(results.size()) + "; allowed at least that many");
  }
  // The .part file: every replica so far, the current one as it stands.
  auto write_part = [&](std::size_t k, const ReplicaResult& current) {
    if (!output.write)
      return;
    std::vector<ReplicaResult> all(results.begin(), results.begin() + std::ptrdiff_t(k));
    all.push_back(current);
    H5Writer w(spec.file + ".part", ".tmp");
    write_run_layout(w, spec, all);
    w.commit();
  };
  for (std::size_t k = 0; k < count; ++k) {
    const ReplicaResult* from = k < results.size() ? &results[k] : nullptr;
    if (from && from->status.is_failed()) {
      throw ConfigError("replica " + std::to_string(k) + " of this run " + from->status.text() +
                        "; a failed run cannot be continued");
    }
    if (from && replica_finished(spec, *from))
      continue;  // done
    RunOptions o = options;
    o.label = stem + replica_suffix(k, count);
    o.checkpoint_every = spec.checkpoint_every;
    // A checkpoint that cannot be written (a full disk) does not end the run: the previous one
    // stays in OUT.part, and the final write (or, for a stopped run, the .part) comes at the
    // end. Refused checkpoints are retried at intervals that double from checkpoint_every up to
    // ten minutes, and said once, with a count when the replica ends: a disk that stays full
    // cost a whole file's write, and a warning line, at every checkpoint_every.
    struct Refused {
      int count = 0;
      double wait = 0.0;
      std::chrono::steady_clock::time_point next{};
    } refused;
    if (output.write)
      o.checkpoint = [&, k](const ReplicaResult& current) {
        const auto now = std::chrono::steady_clock::now();
        if (refused.count > 0 && now < refused.next)
          return;
        try {
          write_part(k, current);
          if (refused.count > 0)
            std::fprintf(stderr, "jamflow: checkpoint written again, after %d refused\n",
                         refused.count);
          refused = {};
        } catch (const IoError& e) {
          if (refused.count == 0)
            std::fprintf(stderr,
                         "jamflow: warning: checkpoint not written: %s; the run goes on "
                         "(retried at growing intervals)\n",
                         e.what());
          ++refused.count;
          refused.wait = std::min(std::max(2.0 * refused.wait, spec.checkpoint_every), 600.0);
          refused.next = now + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                   std::chrono::duration<double>(refused.wait));
        }
      };
    ReplicaResult r = run_replica(spec, spec.seed + k, o, from);
    if (refused.count > 1)
      std::fprintf(stderr, "jamflow: warning: %d checkpoints of %s not written\n", refused.count,
                   o.label.c_str());
    if (k < results.size())
      results[k] = std::move(r);
    else
      results.push_back(std::move(r));
    const ReplicaResult& last = results[k];
    const bool ok = last.status.is_complete();
    if (output.write) {
      try {
        write_xyz_file(o.label + (ok ? ".final.xyz" : ".last.xyz"), last.final_state);
        // A resumed run that completes: the state it stopped at is superseded.
        if (ok) {
          std::error_code ec;
          std::filesystem::remove(o.label + ".last.xyz", ec);
        }
      } catch (const IoError& e) {  // the run file holds the same state under /final
        std::fprintf(stderr, "jamflow: warning: %s\n", e.what());
      }
    }
    if (last.status.is_budget()) {
      // Finished without a summary: the file is final, the next replica goes on.
      if (output.write)
        std::fprintf(stderr, "jamflow: %s: %s\n", o.label.c_str(), last.status.text().c_str());
    } else if (!ok) {
      write_part(k, last);
      if (output.write) {
        // Only a stopped run can be continued; --resume refuses a failed one.
        const bool resumable = last.status.is_interrupted() || last.signal != 0;
        const std::string next = resumable ? " (continue it with --resume " + spec.file + ".part)"
                                           : std::string(" (a failed run cannot be continued)");
        std::fprintf(stderr, "jamflow: %s; data kept in %s.part%s\n", last.status.text().c_str(),
                     spec.file.c_str(), next.c_str());
      }
      outcome.code = last.signal != 0 ? 128 + last.signal : last.status.is_interrupted() ? 130 : 1;
      return outcome;
    }
    if (k + 1 < count)
      write_part(k, last);
  }
  if (!output.write)
    return outcome;
  try {
    write_run_file(spec, results, spec.file);
    std::error_code ec;
    std::filesystem::remove(spec.file + ".part", ec);
  } catch (const std::exception& e) {
    outcome.write_error = e.what();
    outcome.kept_in = write_run_file_elsewhere(spec, results);
    // A final configuration beside no finished run file would look like a finished run.
    for (std::size_t k = 0; k < results.size(); ++k)
      std::remove((stem + replica_suffix(k, count) + ".final.xyz").c_str());
  }
  return outcome;
}

int run_and_write(const RunSpec& spec, const RunOptions& options, const OutputOptions& output) {
  const RunOutcome outcome = run_replicas(spec, options, output);
  if (outcome.code != 0)
    return outcome.code;
  bool budget = false;
  for (const auto& r : outcome.replicas)
    budget = budget || r.status.is_budget();
  // A replica stopped by the budget has no summary to print: the file says where it stopped.
  const bool failed_verdict = !budget && detail::print_summary(spec, outcome.replicas);
  if (budget)
    std::printf("jamflow run: stopped by [run] max_force_evaluations (no summary) -> %s\n",
                spec.file.c_str());
  if (!outcome.write_error.empty()) {
    std::fprintf(stderr, "jamflow: error: %s\n",
                 kept_message(spec.file, outcome.write_error, outcome.kept_in).c_str());
    return 1;
  }
  if (failed_verdict && output.strict) {
    std::fprintf(stderr, "jamflow: a verdict failed and --strict was given\n");
    return 3;
  }
  return 0;
}

}  // namespace jamflow
