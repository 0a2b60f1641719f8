// A run under the caller's control: the state a scene starts from, advanced step by step by the
// scene's integrator in the scene's ensemble, with the observables the run driver samples. For
// protocols that run_replica() does not know, such as a ramp of the shear rate; the Python
// module's jamflow.Simulation is this class.
#pragma once
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "driver/run.hpp"

namespace jamflow {

class Simulation {
 public:
  // The spec's initial state for `seed` (random, or the scene's init), its integrator and
  // ensemble, and a model with the spec's alpha, skin and threads: what run_replica() starts.
  Simulation(const RunSpec& spec, std::uint64_t seed);

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
