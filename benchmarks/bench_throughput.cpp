// Throughput benchmark: ns per particle-step and particle-steps/s of steady shear with explicit
// Euler, N = 1000 and 10000, phi = 0.64, gdot = 1e-4, dt = 0.1, alpha_r = 2 and 2.5, on 1 thread
// and on all cores, with the force backend and its instruction-set target named. Start-up is
// excluded: each case first relaxes and shears the random initial state, then times steady-shear
// windows (list rebuilds and remap checks included, as in a production run).
//
// A shared machine's speed drifts over seconds, so the thread counts take turns: R rounds, each
// timing one window per thread count, and the figures are the median window (the fastest in
// brackets). The speed-up is the ratio of the medians.
//
// With P > 1 cores, each round also times a control: P independent one-thread runs of N/P
// particles at once, against one such run alone. Runs that share nothing but the hardware show
// what the machine itself gives the extra threads over the same period (caches, memory and
// clock shared with the first thread, and with other tenants); the engine's own speed-up falls
// short of it by what splitting one run across threads costs.
//
// usage: bench_throughput [--quick] [--steps S] [--rounds R] [--sizes 1000,10000]
//                         [--alphas 2,2.5] [--kernel auto|simd|portable]
// JAMFLOW_SIMD_TARGET=AVX2 pins the simd backend to one target (e.g. AVX2 on an AVX-512 CPU).
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <sstream>
#include <string>
#include <vector>

#include "ensembles/constant_volume.hpp"
#include "integrators/euler.hpp"
#include "lib/init.hpp"
#include "lib/model.hpp"

using namespace jamflow;

namespace {

struct Result {
  double ns_per_particle_step;
  double cpu_ns_per_particle_step;  // process CPU time / threads: robust to a loaded machine
  double particle_steps_per_s;
  std::size_t builds;     // full list builds in the window
  std::size_t refreshes;  // inner-list re-selections without a full build
  std::string kernel;     // backend/target
};

Result time_window(Model& m, const ConstantVolume& ens, Euler& euler, long steps, double dt) {
  const std::size_t builds0 = m.list_builds();
  const std::size_t inner0 = m.neighbour_list().inner_builds();
  const double t0 = m.state().time;
  const auto w0 = std::chrono::steady_clock::now();
  const std::clock_t c0 = std::clock();
  euler.advance(m, ens, t0 + steps * dt);
  const double cpu = double(std::clock() - c0) / CLOCKS_PER_SEC;
  const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count();
  const double ps = double(steps) * double(m.state().size());
  const std::size_t builds = m.list_builds() - builds0;
  return {1e9 * sec / ps,
          1e9 * cpu / ps / m.force_field().threads(),
          ps / sec,
          builds,
          m.neighbour_list().inner_builds() - inner0 - builds,
          m.force_field().kernel() + "/" + m.force_field().target()};
}

// The control: `runs` independent one-thread runs of the state `part` at once, one per thread,
// `steps` steps each after a warm-up. Returns the particle-steps per second of all of them.
double independent_runs(const State& part, const ConstantVolume& ens, int runs, long steps,
                        double dt, const ModelOptions& options) {
  std::vector<double> seconds(runs, 0.0);
#pragma omp parallel num_threads(runs)
  {
    const int t = omp_get_thread_num();
    ModelOptions one = options;
    one.threads = 1;
    Model m(part, one);
    Euler euler(dt);
    euler.advance(m, ens, m.state().time + double(steps / 10) * dt);
#pragma omp barrier
    const auto w0 = std::chrono::steady_clock::now();
    euler.advance(m, ens, m.state().time + double(steps) * dt);
    seconds[t] = std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count();
  }
  // Every run does the same work; the throughput ends with the slowest.
  const double slowest = *std::max_element(seconds.begin(), seconds.end());
  return double(runs) * double(steps) * double(part.size()) / slowest;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::size_t> sizes = {1000, 10000};
  std::vector<double> alphas = {2.0, 2.5};
  std::string kernel = "auto";
  long steps_override = 0;
  int rounds = 5;
  bool quick = false;
  for (int k = 1; k < argc; ++k) {
    const std::string a = argv[k];
    if (a == "--quick") {
      quick = true;
    } else if (a == "--steps" && k + 1 < argc) {
      steps_override = std::atol(argv[++k]);
    } else if (a == "--rounds" && k + 1 < argc) {
      rounds = std::max(1, std::atoi(argv[++k]));
    } else if (a == "--alphas" && k + 1 < argc) {
      alphas.clear();
      std::stringstream ss(argv[++k]);
      std::string item;
      while (std::getline(ss, item, ','))
        alphas.push_back(std::stod(item));
    } else if (a == "--kernel" && k + 1 < argc) {
      kernel = argv[++k];
    } else if (a == "--sizes" && k + 1 < argc) {
      sizes.clear();
      std::stringstream ss(argv[++k]);
      std::string item;
      while (std::getline(ss, item, ','))
        sizes.push_back(std::stoul(item));
    } else {
      std::fprintf(stderr,
                   "usage: bench_throughput [--quick] [--steps S] [--rounds R] [--sizes N1,N2] "
                   "[--alphas A1,A2] [--kernel auto|simd|portable]\n");
      return 2;
    }
  }
  const double phi = 0.64, gdot = 1e-4, dt = 0.1;
  const int all = omp_get_max_threads();
  std::printf("jamflow throughput: Euler, phi = %.2f, gdot = %g, dt = %g, %d cores available\n",
              phi, gdot, dt, all);
  std::printf("median of %d interleaved windows per thread count (fastest in brackets)\n", rounds);
  std::printf("%8s %6s %8s %22s %14s %16s %10s %8s %8s %s\n", "N", "alpha", "threads",
              "ns/part-step", "cpu-ns/p-step", "part-steps/s", "speed-up", "rebuilds", "refresh",
              "kernel/target");
  for (const double alpha : alphas)
    for (std::size_t n : sizes) {
      const ModelOptions options{alpha, 0.3, 1, 20, kernel};
      const auto with_threads = [&](int t) {
        ModelOptions o = options;
        o.threads = t;
        return o;
      };
      // Pre-shear once: relax the random overlaps and reach steady flow (strain 0.3).
      ConstantVolume ens(gdot);
      const auto presheared = [&](std::size_t particles, std::uint64_t seed) {
        Model m(random_state(particles, phi, seed), with_threads(all));
        Euler pre(dt);
        ConstantVolume fast(1e-3);
        pre.advance(m, fast, quick ? 50.0 : 300.0);  // strain 0.3 at a faster rate
        pre.advance(m, ens, m.state().time + (quick ? 20.0 : 200.0));
        return m.state();
      };
      const State steady = presheared(n, 42);
      // The control's system: N/P particles, sheared the same way.
      const State part = all > 1 ? presheared(n / std::size_t(all), 43) : State{};
      const long steps = steps_override > 0
                             ? steps_override
                             : (quick ? 200 : long(std::max<std::size_t>(2000, 2e8 / n)));
      std::vector<int> counts = {1};
      if (all > 1)
        counts.push_back(all);
      // Every thread count runs the same stretch of the same trajectory in every round: each
      // round starts from the steady state again.
      std::vector<std::vector<Result>> results(counts.size());
      std::vector<double> control;  // per round: P runs at once over one alone
      for (int r = 0; r < rounds; ++r) {
        for (std::size_t c = 0; c < counts.size(); ++c) {
          Model run(steady, with_threads(counts[c]));
          Euler euler(dt);
          time_window(run, ens, euler, steps / 10, dt);  // warm caches and buffers
          results[c].push_back(time_window(run, ens, euler, steps, dt));
        }
        if (all > 1) {
          const double alone = independent_runs(part, ens, 1, steps / 2, dt, options);
          control.push_back(independent_runs(part, ens, all, steps / 2, dt, options) / alone);
        }
      }
      const auto median = [](std::vector<double> v) {
        std::sort(v.begin(), v.end());
        const std::size_t k = v.size() / 2;
        return v.size() % 2 ? v[k] : 0.5 * (v[k - 1] + v[k]);
      };
      double base = 0.0, engine = 1.0;
      std::vector<double> per_round;  // the engine's speed-up on all cores, per round
      for (std::size_t c = 0; c < counts.size(); ++c) {
        std::vector<double> wall, cpu;
        for (const Result& x : results[c]) {
          wall.push_back(x.ns_per_particle_step);
          cpu.push_back(x.cpu_ns_per_particle_step);
        }
        const double med = median(wall), best = *std::min_element(wall.begin(), wall.end());
        if (c == 0)
          base = med;
        engine = base / med;
        for (int r = 0; c > 0 && r < rounds; ++r)
          per_round.push_back(results[0][r].ns_per_particle_step /
                              results[c][r].ns_per_particle_step);
        const Result& x = results[c].back();
        char figure[64];
        std::snprintf(figure, sizeof figure, "%.2f (%.2f)", med, best);
        std::printf("%8zu %6.2f %8d %22s %14.2f %16.3e %10.2f %8zu %8zu %s\n", n, alpha, counts[c],
                    figure, median(cpu), 1e9 / med, base / med, x.builds, x.refreshes,
                    x.kernel.c_str());
      }
      if (all > 1) {
        const auto [elo, ehi] = std::minmax_element(per_round.begin(), per_round.end());
        const auto [clo, chi] = std::minmax_element(control.begin(), control.end());
        std::printf(
            "%8zu %6.2f %8d speed-up per round %.2f-%.2f; control, %d runs of N/%d at once: "
            "%.2f x one alone (%.2f-%.2f); engine/control %.2f\n",
            n, alpha, all, *elo, *ehi, all, all, median(control), *clo, *chi,
            engine / median(control));
      }
      std::fflush(stdout);
    }
  return 0;
}
