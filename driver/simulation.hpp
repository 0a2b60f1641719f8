// The one time loop over a model, an integrator and an ensemble: the state a scene starts from,
// advanced by the scene's integrator in the scene's ensemble, with the observables the run
// driver samples. run_replica() and the studies' diagnostic windows run their samples through
// run(), with what they do at each sample as observers (LoopObserver); protocols that
// run_replica() does not know, such as a ramp of the shear rate, call advance_to() (the Python
// module's jamflow.Simulation is this class).
#pragma once
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "driver/run.hpp"

namespace jamflow {

class Simulation;

// What the time loop (Simulation::run) does besides advancing: sampling, trajectories,
// checkpoints, the force budget and the run-length policy are observers. Each is called in the
// order given to run().
class LoopObserver {
 public:
  virtual ~LoopObserver() = default;
  // Before the loop advances to sample k: false ends the loop there (the run-length policy, the
  // budget).
  virtual bool proceed(Simulation& sim, long long k) {
    (void)sim;
    (void)k;
    return true;
  }
  // At sample k, time t after the start, with the state at that time.
  virtual void sampled(Simulation& sim, long long k, double t) {
    (void)sim;
    (void)k;
    (void)t;
  }
  // The loop looked up because the attention flag was raised (between integrator steps, or
  // after a sample): true ends the loop (a stop request), after whatever else is due
  // (a checkpoint).
  virtual bool attend(Simulation& sim) {
    (void)sim;
    return false;
  }
};

class Simulation {
 public:
  // The spec's initial state for `seed` (random, or the scene's init), its integrator and
  // ensemble, and a model with the spec's alpha, skin and threads: what run_replica() starts.
  Simulation(const RunSpec& spec, std::uint64_t seed);
  // From `start` with the spec's integrator and ensemble and a model with `options` (a replica
  // continued from its checkpoint, a diagnostic window). Times count from the state's time.
  Simulation(const RunSpec& spec, std::uint64_t seed, State start, const ModelOptions& options);
  // The model options the spec asks for (alpha, skin, threads).
  static ModelOptions model_options(const RunSpec& spec);

  // The time loop: samples k_first, k_first + 1, ... at times k * sample_every after the start,
  // each reached exactly, until an observer's proceed() ends it (returns true) or its attend()
  // stops it (returns false; the state is then at the end of an integrator step, and running
  // again from the same sample continues as if never stopped). `attention`, if given, is the
  // flag that the integrator polls between steps; raised, the loop lowers it and asks the
  // observers to attend. An IntegrationError propagates, the state where it failed.
  bool run(double sample_every, long long k_first, const std::vector<LoopObserver*>& observers,
           std::atomic<bool>* attention = nullptr);

  // Advances to time t_end (relative to the start, as the run's time series). Returns false when
  // `stop` was raised first: the state is then at the end of a step, and advancing again to the
  // same time continues as if never stopped. An IntegrationError leaves the dynamics where it
  // failed. A t_end before the current time is a ConfigError.
  bool advance_to(double t_end, const std::atomic<bool>* stop = nullptr);
  double time() const { return model_.state().time - t_start_; }

  // The observables of the current configuration, as run_replica() samples them.
  Sample sample();
  // Forces on the particles in id order (N x 3, row-major), of the current configuration.
  std::vector<double> forces();
  // Particles in id order, real-space positions wrapped into the cell.
  Configuration configuration() const { return configuration_of(model_.state()); }

  double shear_rate() const { return ensemble_->shear_rate(); }
  // From now on, the cell shears at `rate` (>= 0; a ConfigError otherwise). An adaptive
  // integrator starts a fresh history.
  void set_shear_rate(double rate);

  // The integrator's counters, force evaluations and neighbour-list builds.
  std::vector<std::pair<std::string, double>> statistics() const;
  const Model& model() const { return model_; }
  Model& model() { return model_; }
  Integrator& integrator() { return *integrator_; }
  const Integrator& integrator() const { return *integrator_; }
  const Ensemble& ensemble() const { return *ensemble_; }
  // The state's time at the start (a continued replica keeps that of its first run).
  double start_time() const { return t_start_; }
  void set_start_time(double t) { t_start_ = t; }
  const RunSpec& spec() const { return spec_; }
  std::uint64_t seed() const { return seed_; }

 private:
  RunSpec spec_;
  std::uint64_t seed_;
  Model model_;
  std::unique_ptr<Integrator> integrator_;
  std::shared_ptr<const Ensemble> ensemble_;
  double t_start_ = 0.0;
};

}  // namespace jamflow
