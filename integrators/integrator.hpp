// Integrators own time: each advances the Model to an exact t_end using the rates that the
// Ensemble supplies. Equations (SPEC §2), in scaled coordinates s = h^-1 r:
//   ds/dt = h^-1 F / xi_s,   d(strain)/dt = gdot,   dV/dt = ensemble.volume_rate(P_hat)
// The affine shear and dilation are carried by the cell h, so r = h s follows
//   dr/dt = F / xi_s + gdot y e_x (+ the affine dilation at constant pressure).
#pragma once
#include <atomic>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "ensembles/ensemble.hpp"
#include "lib/config.hpp"
#include "lib/model.hpp"

namespace jamflow {

// CPU seconds of one particle's force pass and drift on one thread inside a run, N = 1000,
// alpha_r = 2 (benchmarks/README.md, "Time to science"): Euler 14.6 ns at P = 1e-5 and 19.5 ns at
// P = 1e-3, RESPA 13.9 and 17.6 ns (its force passes per tau_0 over its CPU time per tau_0).
inline constexpr double kCpuSecondsPerParticlePass = 17e-9;

class Integrator {
 public:
  virtual ~Integrator() = default;

  virtual std::string name() const = 0;  // the scene's `kind`
  // Declared convergence order in the step size (tests measure it), for the worst case over
  // ensembles.
  virtual int order() const = 0;
  // The order for this ensemble (RESPA: a collective level without a piston is exact, so the
  // order can be higher at constant volume). Default: order().
  virtual int order(const Ensemble& ensemble) const {
    (void)ensemble;
    return order();
  }

  // Nominal force passes per unit time in this ensemble, for cost estimates: for fixed-step
  // integrators what the scheme costs per step over dt (Euler: 1 / dt); NaN for adaptive ones,
  // whose cost is known only once they ran (force_pass_equivalents()).
  virtual double force_passes_per_time(const Ensemble& ensemble) const = 0;

  // Expected CPU seconds per particle per unit time on one thread, for cost estimates (a
  // sweep's dry-run and the order in which it runs its tasks). Adaptive integrators' costs
  // depend on the state point: `at` gives its pressure (imposed, or a stand-in at constant
  // volume), shear rate and alpha_r. Measured at N = 1000, alpha_r = 2 on one thread
  // (benchmarks/README.md, "Time to science"): an estimate to about a factor of 2, not a
  // prediction. Default: the nominal force passes per time at kCpuSecondsPerParticlePass.
  struct CostPoint {
    double pressure = 1e-4;
    double shear_rate = 1e-5;
    double alpha = 2.0;
    double viscous_number() const { return shear_rate / pressure; }  // J = gdot xi_s / P
  };
  virtual double cpu_seconds_per_particle_time(const Ensemble& ensemble, const CostPoint& at) const;

  // The cost so far, in force-pass equivalents: the model's force evaluations plus whatever
  // else the integrator computes, weighted by its cost relative to one force pass (CVODE's
  // Jacobian-vector products, see cvode.hpp). The run budget ([run] max_force_evaluations)
  // counts this. Default: the model's force evaluations.
  virtual double force_pass_equivalents(const Model& model) const {
    return double(model.force_evaluations());
  }

  // Advance to exactly t_end (model.state().time == t_end on return), or, once the interrupt
  // flag is set, stop early at the end of a step (model.state().time < t_end on return).
  // Calling advance() again with the same t_end then continues as if never stopped, bit for
  // bit (CVODE keeps its solver history across the stop; see cvode.hpp).
  virtual void advance(Model& model, const Ensemble& ensemble, double t_end) = 0;

  // A flag, set from another thread or a signal handler, that advance() polls between steps.
  void set_interrupt(const std::atomic<bool>* flag) { interrupt_ = flag; }
  bool interrupted() const {
    return interrupt_ != nullptr && interrupt_->load(std::memory_order_relaxed);
  }

  // Drop any history (after a discrete change such as a remap or a new state).
  virtual void reset() {}

  // Counters for the output summary (steps, evaluations, failures, ...).
  virtual std::vector<std::pair<std::string, double>> statistics() const { return {}; }
  // A continued run (checkpoint) starts from the counters statistics() gave: the counters of
  // the continued run then count the whole run.
  virtual void restore_statistics(const std::vector<std::pair<std::string, double>>& stats) {
    (void)stats;
  }
  // Whether the integrator carries history between steps that a checkpoint does not keep
  // (then a continued run starts with a fresh history, and the output says so).
  virtual bool has_solver_history() const { return false; }

  // A characteristic step for progress reporting and sampling checks (0 if adaptive).
  virtual double nominal_dt() const { return 0.0; }

 private:
  const std::atomic<bool>* interrupt_ = nullptr;
};

// Builds the integrator named by [integrator] kind (a registered kind, integrators/registry.hpp),
// reading only that kind's keys.
std::unique_ptr<Integrator> make_integrator(ConfigSection& section);

// Per-kind factories (each reads its own keys; `kind` has been read already). Each kind
// registers its factory in the integrator registry (integrators/registry.hpp).
std::unique_ptr<Integrator> make_euler(ConfigSection& section);
std::unique_ptr<Integrator> make_respa(ConfigSection& section);
std::unique_ptr<Integrator> make_cvode(ConfigSection& section);

// Shared building blocks --------------------------------------------------------------

// The value of counter `name` in statistics() output, or `otherwise`.
inline double statistic(const std::vector<std::pair<std::string, double>>& stats,
                        const std::string& name, double otherwise = 0.0) {
  for (const auto& [k, v] : stats)
    if (k == name)
      return v;
  return otherwise;
}

// Moves the cell: strain += dstrain and V -> new_volume (affine: scaled coordinates fixed).
void move_cell(State& state, double dstrain, double new_volume);

// Particle drift with the forces of `eval`: s += dt h^-1 F / xi_s, with h the current cell.
// Independent per particle, so threading it changes nothing in the result.
void drift_particles(State& state, const std::vector<double>& force, double dt, int threads = 1);

}  // namespace jamflow
