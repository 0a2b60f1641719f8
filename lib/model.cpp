// The evaluated system: neighbour-list upkeep, remaps, memory ordering and observables.
#include "lib/model.hpp"

#include <omp.h>

#include <cmath>
#include <stdexcept>
#include <string>

#include "lib/error.hpp"

namespace jamflow {

Model::Model(State state, const ModelOptions& options)
    : state_(std::move(state)),
      options_(options),
      field_(options.alpha, options.threads, options.kernel),
      list_(options.skin) {
  if (state_.size() < 2)
    throw ConfigError("[system] N must be at least 2");
  particle_volume_ = state_.particle_volume();
}

void Model::reset_state(State state) {
  state_ = std::move(state);
  particle_volume_ = state_.particle_volume();
  list_.invalidate();
  changed();
  sorted_once_ = false;
}

Model::Snapshot Model::snapshot() const {
  Snapshot s;
  s.state = state_;
  s.list = list_.snapshot();
  s.evaluations = evaluations_;
  s.builds_at_last_sort = builds_at_last_sort_;
  s.sorted_once = sorted_once_;
  s.evaluated = fresh_;
  s.particle_volume = particle_volume_;
  return s;
}

void Model::restore(const Snapshot& s) {
  if (s.state.size() < 2)
    throw ConfigError("[system] N must be at least 2");
  if (s.list.built && s.list.ref_pos.size() != s.state.pos.size())
    throw std::invalid_argument("model snapshot: the neighbour list is of " +
                                std::to_string(s.list.ref_pos.size() / 3) +
                                " particles, the state of " + std::to_string(s.state.size()));
  state_ = s.state;
  particle_volume_ = s.particle_volume > 0.0 ? s.particle_volume : state_.particle_volume();
  list_ = NeighbourList::from(s.list);
  changed();
  builds_at_last_sort_ = s.builds_at_last_sort;
  sorted_once_ = s.sorted_once;
  if (s.evaluated) {
    // The original held this state's evaluation; computing it again gives the same bits (the
    // pass is deterministic), and the count is the original's.
    evaluate();
  }
  evaluations_ = s.evaluations;
}

void Model::refresh_list(bool renew) {
  switch (list_.status(state_, field_.threads())) {
    case NeighbourList::Status::kValid:
      // The force pass measures the displacement in a loop of its own; at the very limit its
      // last bit may differ from status()'s. Its verdict stands: the inner list is renewed.
      if (renew)
        list_.refresh_inner(state_, field_.threads());
      return;
    case NeighbourList::Status::kInnerStale:
      list_.refresh_inner(state_, field_.threads());
      return;
    case NeighbourList::Status::kStale:
      // A list is built in a cell reduced by remaps. Between steps prepare_step() keeps the tilt
      // within 1/2; within a step that shears by more (RESPA's half step at gdot dt > 1) the
      // state is remapped here. Not at the 1/2 threshold itself, which CVODE's stretches end
      // just past: it holds the state's scaled positions and remaps only between them.
      if (std::abs(state_.box.tilt_fraction()) > kRemapAtBuild) {
        state_.remap(state_.box.remaps_due());
        list_.invalidate();
      }
      state_.wrap();
      changed();
      list_.build(state_, field_.threads());
      return;
  }
}

const Evaluation& Model::evaluate() {
  if (fresh_)
    return eval_;
  // The force pass also measures the largest displacement since the inner list was selected;
  // in the rare step where the list no longer holds, it is renewed and the pass repeated.
  if (!list_.built() || list_.inner_reference().size() != state_.pos.size())
    refresh_list();
  field_.compute(state_, list_, eval_.forces, version_);
  if (!list_.inner_holds(state_, std::sqrt(eval_.forces.max_drift2))) {
    refresh_list(true);
    field_.compute(state_, list_, eval_.forces, version_);
  }
  observe();
  fresh_ = true;
  return eval_;
}

const Evaluation& Model::evaluate_and_drift(const Drift& drift, const Box& next) {
  // `next` and the drift are of the current cell's remaps: the list must not remap it.
  if (!(std::abs(state_.box.tilt_fraction()) <= kRemapAtBuild))
    throw std::logic_error("Model::evaluate_and_drift: the cell's tilt xy / Lx = " +
                           std::to_string(state_.box.tilt_fraction()) +
                           " is due a remap; call prepare_step() first");
  if (!list_.built() || list_.inner_reference().size() != state_.pos.size())
    refresh_list();
  fresh_ = false;  // whatever happens below, the state moves or the pass is repeated
  if (!field_.compute_and_drift(state_, list_, eval_.forces, drift, next, version_, version_ + 1)) {
    // The list no longer holds (or a position is not finite): renew it and repeat; the second
    // pass stops only for a non-finite state, which evaluate() then reports.
    refresh_list(true);
    if (!field_.compute_and_drift(state_, list_, eval_.forces, drift, next, version_,
                                  version_ + 1)) {
      evaluate();
      throw IntegrationError("the neighbour list does not hold after a rebuild at t = " +
                             std::to_string(state_.time));
    }
  }
  observe();
  state_.box = next;
  ++version_;  // the number the pass was told the new state gets
  return eval_;
}

void Model::observe() {
  ++evaluations_;
  const double v = state_.box.volume();
  const Eigen::Matrix3d& w = eval_.forces.virial;
  eval_.volume = v;
  eval_.pressure = w.trace() / (3.0 * v);
  eval_.sigma_xy = -w(0, 1) / v;
  const double dsum = eval_.forces.force_squared;
  eval_.dissipation = dsum / kXiS;
  eval_.phi = particle_volume_ / v;
  if (!std::isfinite(eval_.forces.energy) || !std::isfinite(dsum) || !std::isfinite(w.sum())) {
    throw IntegrationError("forces became non-finite at t = " + std::to_string(state_.time) +
                           " (energy " + std::to_string(eval_.forces.energy) + ")");
  }
}

bool Model::prepare_step() {
  bool moved = false;
  // All the remaps due at once: a step may shear by more than one cell length (gdot dt > 1).
  if (const std::int64_t dir = state_.box.remaps_due(); dir != 0) {
    state_.remap(dir);
    list_.invalidate();
    moved = true;
  }
  // Sort on the first step (initial states come in arbitrary memory order), then every
  // sort_every rebuilds as particles diffuse.
  if (options_.sort_every > 0 &&
      (!sorted_once_ ||
       list_.builds() >= builds_at_last_sort_ + std::size_t(options_.sort_every))) {
    sorted_once_ = true;
    sort_particles();
    moved = true;
  }
  if (moved)
    changed();
  return moved;
}

void Model::sort_particles() {
  state_.wrap();
  const auto order = NeighbourList::cell_order(state_, 1.4 + options_.skin);
  const std::size_t n = state_.size();
  State s = state_;
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t o = order[k];
    for (int c = 0; c < 3; ++c) {
      s.pos[c * n + k] = state_.pos[c * n + o];
      s.image[c * n + k] = state_.image[c * n + o];
    }
    s.diameter[k] = state_.diameter[o];
    s.species[k] = state_.species[o];
    s.id[k] = state_.id[o];
  }
  state_ = std::move(s);
  list_.invalidate();
  builds_at_last_sort_ = list_.builds() + 1;  // the rebuild that follows
}

}  // namespace jamflow
