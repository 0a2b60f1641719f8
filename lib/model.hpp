// The evaluated system: State + neighbour list + force field, with cached observables.
//
// Integrators read forces and observables through evaluate() and change the State through
// the mutators below; the Model keeps the neighbour list valid (rebuilding when the
// displacement bound says so) and never returns forces for a stale configuration.
#pragma once
#include <Eigen/Dense>
#include <cstdint>

#include "lib/forces.hpp"
#include "lib/neighbour_list.hpp"
#include "lib/state.hpp"

namespace jamflow {

// Friction coefficient of the solvent drag (unit of the model, SPEC §1).
inline constexpr double kXiS = 1.0;

struct Evaluation {
  ForceResult forces;
  double volume = 0.0;
  double pressure = 0.0;     // P_hat = tr(W) / (3 V)
  double sigma_xy = 0.0;     // -W_xy / V
  double dissipation = 0.0;  // D = sum |F_i|^2 / xi_s
  double phi = 0.0;
};

struct ModelOptions {
  double alpha = 2.0;
  double skin = 0.3;
  int threads = 0;  // <= 0: all available
  // Reorder particles by cell every this many list rebuilds (0 = never). Reordering only
  // happens in prepare_step(), never inside a right-hand-side evaluation.
  int sort_every = 20;
  // Use the portable force kernel even where the vector one is available (comparisons).
  bool portable_kernel = false;
};

class Model {
 public:
  Model(State state, const ModelOptions& options);

  const State& state() const { return state_; }
  const ForceField& force_field() const { return field_; }
  const NeighbourList& neighbour_list() const { return list_; }
  const ModelOptions& options() const { return options_; }

  // Forces and observables of the current configuration (computed once, then cached).
  const Evaluation& evaluate();
  // The particle drift of an explicit Euler step fused into the force pass: the observables of
  // the current configuration are evaluated, every particle then moves by s += D F, and the
  // cell becomes `next` (D is mapped with it). Gives the same state, bit for bit, as evaluate()
  // followed by the cell change and the drift with the evaluation's forces, but the returned
  // evaluation holds no forces. Needs no touch(); the pass prepares the next one's rows, which
  // that pass uses if nothing else changes the state in between.
  const Evaluation& evaluate_and_drift(const Drift& drift, const Box& next);

  // Mutable access to the state. Call touch() after changing positions or the cell.
  State& mutable_state() { return state_; }
  void touch() {
    fresh_ = false;
    rows_ahead_ = false;
  }

  // Between steps: applies a due Lees–Edwards remap (returns true if one happened, so that
  // integrators drop their history) and may reorder particles in memory (returns true too).
  bool prepare_step();

  // Replace the whole state (restart, replica); drops the neighbour list.
  void reset_state(State state);

  std::size_t list_builds() const { return list_.builds(); }
  std::size_t force_evaluations() const { return evaluations_; }

 private:
  // Renews the lists as status() says; with `renew`, the force pass found that the inner list
  // no longer holds, so it is renewed even if status() calls it valid.
  void refresh_list(bool renew = false);
  void observe();  // eval_'s observables from its forces
  void sort_particles();

  State state_;
  ModelOptions options_;
  ForceField field_;
  NeighbourList list_;
  Evaluation eval_;
  bool fresh_ = false;
  // Nothing has changed the state since evaluate_and_drift() (see ForceField::compute_and_drift).
  bool rows_ahead_ = false;
  std::size_t evaluations_ = 0;
  std::size_t builds_at_last_sort_ = 0;
  bool sorted_once_ = false;
  double particle_volume_ = 0.0;
};

}  // namespace jamflow
