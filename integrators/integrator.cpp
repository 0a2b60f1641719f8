// Shared building blocks of the integrators (the factory is in registry.cpp).
#include "integrators/integrator.hpp"

#include <cmath>

#include "lib/model.hpp"

namespace jamflow {

double Integrator::cpu_seconds_per_particle_time(const Ensemble& ensemble,
                                                 const CostPoint& /*at*/) const {
  return force_passes_per_time(ensemble) * kCpuSecondsPerParticlePass;
}

void move_cell(State& state, double dstrain, double new_volume) {
  state.box.strain += dstrain;
  if (new_volume != state.box.volume())
    state.box.set_volume(new_volume);
}

void drift_particles(State& state, const std::vector<double>& force, double dt, int threads) {
  const std::size_t n = state.size();
  const Drift drift = Drift::of(state.box.h_inv(), dt / kXiS);
  double* x = state.x();
  double* y = state.y();
  double* z = state.z();
  const double* fx = force.data();
  const double* fy = fx + n;
  const double* fz = fx + 2 * n;
#pragma omp parallel for simd schedule(static) num_threads(threads) if (threads > 1)
  for (std::size_t i = 0; i < n; ++i)
    drift.apply(x[i], y[i], z[i], fx[i], fy[i], fz[i]);
}

}  // namespace jamflow
