// What CVODE's parts cost against one force pass: the right-hand side (one force pass, what the
// model counts), the Jacobian data of a Newton iterate (jacobian_setup at the point of the
// last right-hand side: the contact list), one Jacobian-vector product, one preconditioner setup
// and one preconditioner solve, on a sheared dense packing (N = 1000, phi = 0.62, alpha_r = 2,
// gdot = 1e-3 by default), at constant volume and at constant pressure. The figures weigh
// CVODE's counters into force-pass equivalents (Cvode::force_pass_equivalents, cvode.hpp).
//
// Times are the calling thread's CPU time (one thread), so other tenants of a shared machine
// slow the figures less than wall time would; each part is timed in R rounds that take turns,
// and the median round is printed.
//
// usage: bench_cvode_parts [--n N] [--phi PHI] [--rounds R] [--reps K]
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include "ensembles/constant_pressure.hpp"
#include "ensembles/constant_volume.hpp"
#include "integrators/cvode.hpp"
#include "integrators/euler.hpp"
#include "lib/cpu_clock.hpp"
#include "lib/init.hpp"
#include "lib/model.hpp"

using namespace jamflow;

namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

struct Parts {
  double rhs = 0, jsetup = 0, jtimes = 0, psetup = 0, psolve = 0;  // seconds per call
};

// One round: each part timed over `reps` calls at points y_k near y = 0 (a fresh force pass
// each: the model caches the evaluation of an unchanged state).
Parts round_of(EquationOfMotion& sys, double t, int reps, std::mt19937_64& rng) {
  const std::size_t m = sys.size();
  std::normal_distribution<double> g(0.0, 1e-7);
  std::vector<std::vector<double>> ys(reps, std::vector<double>(m));
  for (auto& y : ys)
    for (double& v : y)
      v = g(rng);
  std::vector<double> ydot(m), v(m), jv(m), z(m);
  for (double& x : v)
    x = g(rng) * 1e7;
  Parts p;
  // The right-hand side, then (untimed order matters) the Jacobian data at the same point.
  double rhs = 0, js = 0;
  for (int k = 0; k < reps; ++k) {
    const double a = cpu_clock();
    sys.rhs(t, ys[k].data(), ydot.data());
    const double b = cpu_clock();
    sys.jacobian_setup(t, ys[k].data());
    const double c = cpu_clock();
    rhs += b - a;
    js += c - b;
  }
  p.rhs = rhs / reps;
  p.jsetup = js / reps;
  double a = cpu_clock();
  for (int k = 0; k < reps; ++k)
    sys.jacobian_times(v.data(), jv.data());
  p.jtimes = (cpu_clock() - a) / reps;
  a = cpu_clock();
  for (int k = 0; k < reps; ++k)
    sys.preconditioner_setup(0.1 + 1e-3 * k);
  p.psetup = (cpu_clock() - a) / reps;
  a = cpu_clock();
  for (int k = 0; k < reps; ++k)
    sys.preconditioner_solve(v.data(), z.data());
  p.psolve = (cpu_clock() - a) / reps;
  return p;
}

void report(const char* label, Model& model, const Ensemble& ens, int rounds, int reps) {
  EquationOfMotion sys(model, ens, false);
  const double t = model.state().time;
  std::mt19937_64 rng(7);
  std::vector<double> rhs, js, jt, ps, pv;
  for (int r = 0; r < rounds; ++r) {
    const Parts p = round_of(sys, t, reps, rng);
    rhs.push_back(p.rhs);
    js.push_back(p.jsetup);
    jt.push_back(p.jtimes);
    ps.push_back(p.psetup);
    pv.push_back(p.psolve);
  }
  const double f = median(rhs);
  std::printf("%s: force pass (rhs) %.1f us\n", label, 1e6 * f);
  std::printf(
      "  per force pass: jacobian setup %.3f, Jv product %.3f, preconditioner setup %.3f,"
      " preconditioner solve %.3f\n",
      median(js) / f, median(jt) / f, median(ps) / f, median(pv) / f);
}

}  // namespace

int main(int argc, char** argv) {
  std::size_t n = 1000;
  double phi = 0.62;
  int rounds = 7, reps = 200;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--n")
      n = std::strtoul(argv[i + 1], nullptr, 10);
    else if (a == "--phi")
      phi = std::atof(argv[i + 1]);
    else if (a == "--rounds")
      rounds = std::atoi(argv[i + 1]);
    else if (a == "--reps")
      reps = std::atoi(argv[i + 1]);
  }
  ModelOptions mo;
  mo.threads = 1;
  Model model(random_state(n, phi, 1), mo);
  Euler euler(0.1);
  euler.advance(model, ConstantVolume(0.0), 20.0);  // relax the random start
  const ConstantVolume sheared(1e-3);
  euler.advance(model, sheared, 120.0);  // into shear
  std::printf("N = %zu, phi = %.3f, alpha_r = 2, gdot = 1e-3, P_hat = %.3e, 1 thread\n", n, phi,
              model.evaluate().pressure);
  report("constant volume", model, sheared, rounds, reps);
  const ConstantPressure piston(1e-3, model.evaluate().pressure, 1e-4);
  report("constant pressure", model, piston, rounds, reps);
  return 0;
}
