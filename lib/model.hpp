// The evaluated system: State + neighbour list + force field, with cached observables.
//
// Integrators read forces and observables through evaluate() and change the State only through
// modify(), which drops the cached evaluation; the Model keeps the neighbour list valid
// (rebuilding when the displacement bound says so) and never returns forces for a stale
// configuration.
#pragma once
#include <Eigen/Dense>
#include <cstdint>
#include <string>
#include <utility>

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
  // The force backend (see lib/kernels/backend.hpp): "auto", "simd", "portable" or "reference".
  std::string kernel = "auto";
};

class Model {
 public:
  // A list build in a cell tilted by more than this (|xy / Lx|) remaps the state first, within
  // NeighbourList::kMaxBuildTilt; prepare_step() keeps it within 1/2 between steps.
  static constexpr double kRemapAtBuild = 0.55;

  Model(State state, const ModelOptions& options);

  const State& state() const { return state_; }
  const ForceField& force_field() const { return field_; }
  const NeighbourList& neighbour_list() const { return list_; }
  const ModelOptions& options() const { return options_; }

  // Forces and observables of the current configuration (computed once, then cached).
  const Evaluation& evaluate();
  // An explicit Euler step's particle drift, asked of the force backend as one pass: the
  // observables (and forces) of the current configuration are evaluated, every particle then
  // moves by s += D F, and the cell becomes `next` (D is mapped with it). The same state, bit
  // for bit, as evaluate(), the cell change, and Drift::apply with the evaluation's forces.
  // The returned evaluation is of the configuration before the step; none is cached after it.
  const Evaluation& evaluate_and_drift(const Drift& drift, const Box& next);
  // Changes the state: f(State&) is called with the state, and the cached evaluation is dropped
  // afterwards. This is the only write access, so an evaluation can never be stale. A list
  // rebuild in evaluate() may wrap the scaled positions and, in a cell sheared past
  // kRemapAtBuild since prepare_step(), remap them: callers keep real-space quantities (forces)
  // across evaluations, not scaled positions.
  template <class F>
  decltype(auto) modify(F&& f) {
    changed();
    return std::forward<F>(f)(state_);
  }
  // The last force pass, whatever configuration it was of (after an integrator step: the
  // configuration before the step). evaluate() gives the current configuration's.
  const Evaluation& last_evaluation() const { return eval_; }
  // The number of the current state (lib/kernels/backend.hpp): new after every change.
  std::uint64_t version() const { return version_; }
  // The clock alone (no force depends on it): keeps the cached evaluation.
  void set_time(double t) { state_.time = t; }

  // Between steps: applies a due Lees–Edwards remap (returns true if one happened, so that
  // integrators drop their history) and may reorder particles in memory (returns true too).
  bool prepare_step();

  // Replace the whole state (restart, replica); drops the neighbour list.
  void reset_state(State state);

  // Everything the model's future depends on, as plain values: the state, the neighbour
  // lists (which pairs are summed, in which order), when the next reorder is due, and whether
  // the current state's evaluation was cached. A model restored from it continues bit for bit
  // as the original would have (the force backend's caches are rebuilt from the state).
  struct Snapshot {
    State state;
    NeighbourList::Snapshot list;
    std::size_t evaluations = 0, builds_at_last_sort = 0;
    bool sorted_once = false, evaluated = false;
    // Summed in the memory order of the first state: summed again in another order, phi
    // would differ in the last bit.
    double particle_volume = 0.0;
  };
  Snapshot snapshot() const;
  // Restores a snapshot taken of a model with the same options (alpha, skin, kernel, threads).
  void restore(const Snapshot& snapshot);

  std::size_t list_builds() const { return list_.builds(); }
  std::size_t force_evaluations() const { return evaluations_; }

 private:
  // Renews the lists as status() says; with `renew`, the force pass found that the inner list
  // no longer holds, so it is renewed even if status() calls it valid.
  void refresh_list(bool renew = false);
  // The state changed: the cached evaluation is dropped and the state gets a new number.
  void changed() {
    fresh_ = false;
    ++version_;
  }
  void observe();  // eval_'s observables from its forces
  void sort_particles();

  State state_;
  ModelOptions options_;
  ForceField field_;
  NeighbourList list_;
  Evaluation eval_;
  bool fresh_ = false;
  // The number of the state (0 is "unknown" to the backends). A copied model's force field
  // gets a backend of its own, which keeps nothing from the original's passes.
  std::uint64_t version_ = 1;
  std::size_t evaluations_ = 0;
  std::size_t builds_at_last_sort_ = 0;
  bool sorted_once_ = false;
  double particle_volume_ = 0.0;
};

}  // namespace jamflow
