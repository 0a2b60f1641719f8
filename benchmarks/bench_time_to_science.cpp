// Time to science: what each integrator costs per unit of simulated time near jamming, and what
// error it makes, from one prepared state (issue "Integrators that reach the hard-sphere
// regime"). Prints figures; no test asserts on them.
//
//   bench_time_to_science INIT.xyz P GDOT [T = 2000] [SAMPLE = 10] [XI_V = 1e-4]
//
// Every integrator continues from INIT at constant pressure P and shear rate GDOT over the same
// deterministic interval T on one thread. Reported per integrator:
//   cpu_s/tau, cpu_s/strain      CPU seconds of this thread (CLOCK_THREAD_CPUTIME_ID)
//   passes/tau                   force passes, plus CVODE's Jacobian-vector products
//   pos_err/overlap              RMS real-space position error at T over delta = P^(1/(alpha-1))
//   d<sigma_xy>, d<P_hat>, d<phi>  relative error of the window means (samples every SAMPLE)
// against a reference: explicit Euler at dt = 0.02 and 0.01, Richardson-extrapolated to dt -> 0
// (its own remaining error is O(dt^2)).
#include <Eigen/Dense>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "ensembles/constant_pressure.hpp"
#include "integrators/registry.hpp"
#include "lib/cpu_clock.hpp"
#include "lib/model.hpp"
#include "lib/xyz.hpp"

using namespace jamflow;

namespace {

struct Outcome {
  std::vector<double> positions;  // unwrapped real space, by id
  double sigma_xy = 0, pressure = 0, phi = 0;
  double cpu = 0, passes = 0;
};

Outcome run(const State& init, const Ensemble& ens, const IntegratorSettings& settings, double t,
            double sample) {
  Model m(init, ModelOptions{2.0, 0.3, 1, 20});
  auto integ = make_integrator(settings);
  Outcome o;
  const double t0 = m.state().time;
  const long samples = std::lround(t / sample);
  const double c0 = cpu_clock();
  for (long k = 1; k <= samples; ++k) {
    integ->advance(m, ens, t0 + double(k) * sample);
    const Evaluation& ev = m.evaluate();
    o.sigma_xy += ev.sigma_xy / double(samples);
    o.pressure += ev.pressure / double(samples);
    o.phi += ev.phi / double(samples);
  }
  o.cpu = cpu_clock() - c0;
  o.passes = double(m.force_evaluations()) + statistic(integ->statistics(), "jtimes_evaluations");
  o.positions = m.state().unwrapped_by_id();
  return o;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4) {
    std::fprintf(stderr, "usage: %s INIT.xyz P GDOT [T] [SAMPLE] [XI_V]\n", argv[0]);
    return 2;
  }
  const State init = read_xyz(argv[1]);
  const double p = std::atof(argv[2]), gdot = std::atof(argv[3]);
  const double t = argc > 4 ? std::atof(argv[4]) : 2000.0;
  const double sample = argc > 5 ? std::atof(argv[5]) : 10.0;
  const double xi_v = argc > 6 ? std::atof(argv[6]) : 1e-4;
  const ConstantPressure ens(gdot, p, xi_v);
  const double delta = p;  // harmonic: the typical overlap is P / eps
  std::printf("# N = %zu, P = %g, gdot = %g (J = %g), T = %g, samples every %g, xi_V = %g\n",
              init.size(), p, gdot, gdot / p, t, sample, xi_v);

  auto euler = [](double dt) { return IntegratorSettings("euler").set("dt", dt); };
  const Outcome r1 = run(init, ens, euler(0.02), t, sample);
  const Outcome r2 = run(init, ens, euler(0.01), t, sample);
  Outcome ref = r2;
  for (std::size_t k = 0; k < ref.positions.size(); ++k)
    ref.positions[k] = 2.0 * r2.positions[k] - r1.positions[k];
  ref.sigma_xy = 2.0 * r2.sigma_xy - r1.sigma_xy;
  ref.pressure = 2.0 * r2.pressure - r1.pressure;
  ref.phi = 2.0 * r2.phi - r1.phi;

  struct Entry {
    std::string label;
    IntegratorSettings settings;
  };
  std::vector<Entry> entries = {
      {"euler dt 0.01", euler(0.01)},
      {"euler dt 0.25", euler(0.25)},
      {"euler dt 0.3", euler(0.3)},
      {"respa dt 1 n 4", IntegratorSettings("respa").set("dt", 1.0).set("n_inner", 4)},
      {"cvode rtol 1e-4", IntegratorSettings("cvode").set("rtol", 1e-4)},
      {"cvode rtol 1e-5", IntegratorSettings("cvode").set("rtol", 1e-5)},
  };
  for (double a : {1e-3, 1e-2, 1e-1, 3e-1, 1.0})
    entries.push_back({"rkc atol " + std::to_string(a).substr(0, 5) + " delta",
                       IntegratorSettings("rkc").set("atol", a * delta)});
  std::printf("%-22s %12s %12s %10s %14s %11s %11s %11s\n", "integrator", "cpu_s/tau",
              "cpu_s/strain", "passes/tau", "pos_err/overlap", "d<sxy>", "d<P_hat>", "d<phi>");
  for (const Entry& e : entries) {
    const Outcome o = e.label == "euler dt 0.01" ? r2 : run(init, ens, e.settings, t, sample);
    double sq = 0.0;
    for (std::size_t k = 0; k < o.positions.size(); ++k) {
      const double d = o.positions[k] - ref.positions[k];
      sq += d * d;
    }
    const double rms = std::sqrt(sq / double(o.positions.size() / 3));
    std::printf("%-22s %12.4g %12.4g %10.3g %14.3g %11.2e %11.2e %11.2e\n", e.label.c_str(),
                o.cpu / t, o.cpu / (t * gdot), o.passes / t, rms / delta,
                o.sigma_xy / ref.sigma_xy - 1.0, o.pressure / ref.pressure - 1.0,
                o.phi / ref.phi - 1.0);
    std::fflush(stdout);
  }
  return 0;
}
