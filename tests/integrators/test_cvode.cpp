// CVODE: analytic relaxations, tolerance proportionality, the analytic Jacobian against finite
// differences and the Hessian product, list validity against the all-pairs reference, a run
// through Lees–Edwards remaps against a tiny-step Euler reference, the piston, and stops on the
// interrupt flag between internal steps.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <optional>
#include <random>
#include <thread>

#include "ensembles/constant_pressure.hpp"
#include "ensembles/constant_volume.hpp"
#include "integrators/cvode.hpp"
#include "integrators/euler.hpp"
#include "lib/config.hpp"
#include "lib/error.hpp"
#include "lib/init.hpp"
#include "lib/model.hpp"
#include "tests/short_tests.hpp"
#include "tests/two_spheres.hpp"

namespace jamflow {
namespace {

using fixtures::two_spheres;  // tests/two_spheres.hpp

double overlap(const Model& m) {
  return 1.0 - (m.state().real(1) - m.state().real(0)).norm();
}

CvodeOptions tolerances(double rtol, double atol) {
  CvodeOptions o;
  o.rtol = rtol;
  o.atol = atol;
  return o;
}

double two_sphere_overlap(const CvodeOptions& o, double t_end, double gdot, double alpha = 2.0) {
  Model m(two_spheres(0.8), ModelOptions{alpha, 0.3, 1, 0});
  ConstantVolume ens(gdot);
  Cvode cv(o);
  cv.advance(m, ens, t_end);
  return overlap(m);
}

double stat(const Integrator& integ, const std::string& key) {
  for (const auto& [k, v] : integ.statistics()) {
    if (k == key)
      return v;
  }
  ADD_FAILURE() << "no statistic " << key;
  return -1.0;
}

// Unwrapped real-space positions in id order.
std::vector<Eigen::Vector3d> unwrapped(const State& s) {
  std::vector<Eigen::Vector3d> r(s.size());
  const std::size_t n = s.size();
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d u(s.pos[i] + s.image[i], s.pos[n + i] + s.image[n + i],
                            s.pos[2 * n + i] + s.image[2 * n + i]);
    r[s.id[i]] = s.box.h() * u;
  }
  return r;
}

TEST(Cvode, TwoSpheresRelaxExponentially) {
  const double exact = 0.2 * std::exp(-2.0);
  // Same y: the shear flow does not separate them. Default tolerances: rtol = 1e-6 and atol a
  // thousandth of the overlap scale of P_hat ~ 5e-5 in this dilute box, i.e. ~5e-8; the global
  // error is a few tens of local tolerances.
  for (double gdot : {0.0, 1e-2}) {
    EXPECT_NEAR(two_sphere_overlap(CvodeOptions{}, 1.0, gdot), exact, 2e-6) << "gdot " << gdot;
  }
  // Every solver variant reaches the same answer.
  CvodeOptions pcg, plain, adams;
  pcg.linear_solver = CvodeOptions::LinearSolver::kPcg;
  plain.preconditioner = CvodeOptions::Preconditioner::kNone;
  adams.method = CvodeOptions::Method::kAdams;
  for (const CvodeOptions& o : {pcg, plain, adams})
    EXPECT_NEAR(two_sphere_overlap(o, 1.0, 0.0), exact, 2e-6);
}

TEST(Cvode, ErrorIsProportionalToTolerance) {
  // rtol = atol = tol. CVODE controls local errors, so the global error is proportional to
  // tol only on average: single decades can go the wrong way (measured: tol 1e-6 -> 2e-7,
  // 1e-7 -> 5e-7), two decades never do, and the fitted slope is 0.9.
  const double t_end = 3.0, exact = 0.2 * std::exp(-2.0 * t_end);
  const std::vector<double> tol{1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9};
  std::vector<double> err;
  for (double t : tol)
    err.push_back(std::abs(two_sphere_overlap(tolerances(t, t), t_end, 0.0) - exact));
  for (std::size_t k = 2; k < err.size(); ++k)
    EXPECT_LT(err[k], err[k - 2]) << "tol " << tol[k];
  // Least-squares slope of log(err) against log(tol).
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  const double m = double(err.size());
  for (std::size_t k = 0; k < err.size(); ++k) {
    const double x = std::log10(tol[k]), y = std::log10(err[k]);
    sx += x;
    sy += y;
    sxx += x * x;
    sxy += x * y;
  }
  const double slope = (m * sxy - sx * sy) / (m * sxx - sx * sx);
  EXPECT_NEAR(slope, 1.0, 0.25);
  // And the error is of the order of the tolerance (atol is a length in units of a).
  for (std::size_t k = 0; k < err.size(); ++k)
    EXPECT_LT(err[k], 20.0 * tol[k]) << "tol " << tol[k];
}

TEST(Cvode, SoftExponentContactOpensInFiniteTime) {
  // alpha = 1.5: d sqrt(delta)/dt = -1, so delta = (sqrt(delta_0) - t)^2 until the contact
  // opens at t = sqrt(0.2); the force derivative diverges there (the stiff case).
  const double t_open = std::sqrt(0.2);
  const double at = 0.3;
  EXPECT_NEAR(two_sphere_overlap(CvodeOptions{}, at, 0.0, 1.5), std::pow(t_open - at, 2), 1e-6);
  // The jump of d^2 delta/dt^2 at the opening costs accuracy (measured overshoot 2e-6).
  EXPECT_NEAR(two_sphere_overlap(CvodeOptions{}, 1.0, 0.0, 1.5), 0.0, 1e-5);
}

TEST(Cvode, LandsExactlyOnRequestedTimesAndCounts) {
  Model m(two_spheres(0.9), ModelOptions{2.0, 0.3, 1, 0});
  ConstantVolume ens(1e-3);
  Cvode cv(tolerances(1e-6, 1e-8));  // a fixed atol: the default one follows P_hat
  for (double t : {0.3, 0.6, 1.0, 1.0, 2.5}) {
    cv.advance(m, ens, t);
    EXPECT_EQ(m.state().time, t);
    EXPECT_NEAR(m.state().box.strain, 1e-3 * t, 1e-15);
  }
  for (const char* key : {"steps", "rhs_evaluations", "nonlinear_iterations", "linear_iterations",
                          "jtimes_evaluations", "preconditioner_setups", "reinits", "atol"})
    EXPECT_GT(stat(cv, key), 0.0) << key;
  // One initialisation: consecutive advance() calls keep CVODE's history.
  EXPECT_EQ(stat(cv, "reinits"), 1.0);
  // A state replaced behind the integrator's back restarts it.
  m.reset_state(two_spheres(0.9));
  cv.advance(m, ens, 1.0);
  EXPECT_EQ(m.state().time, 1.0);
  EXPECT_EQ(stat(cv, "reinits"), 2.0);
}

// A dense random packing: many contacts, so every Jacobian term is exercised.
struct Dense {
  explicit Dense(double phi, std::size_t n = 64, double alpha = 2.0, std::uint64_t seed = 7)
      : model(random_state(n, phi, seed), ModelOptions{alpha, 0.3, 1, 0}) {}
  Model model;
};

// J v against central differences of the right-hand side.
void check_jacobian(Model& m, const Ensemble& ens, double tol) {
  EquationOfMotion sys(m, ens, false);
  const std::size_t size = sys.size();
  std::mt19937_64 rng(3);
  std::normal_distribution<double> normal;
  std::vector<double> y(size), v(size), jv(size), fp(size), fm(size), yp(size), ym(size);
  for (auto& x : y)
    x = 1e-4 * normal(rng);
  for (auto& x : v)
    x = normal(rng);
  const double t = 0.7;
  sys.jacobian_setup(t, y.data());
  sys.jacobian_times(v.data(), jv.data());
  const double eps = 1e-7;
  for (std::size_t k = 0; k < size; ++k) {
    yp[k] = y[k] + eps * v[k];
    ym[k] = y[k] - eps * v[k];
  }
  sys.rhs(t, yp.data(), fp.data());
  sys.rhs(t, ym.data(), fm.data());
  double diff = 0.0, norm = 0.0;
  for (std::size_t k = 0; k < size; ++k) {
    const double fd = (fp[k] - fm[k]) / (2.0 * eps);
    diff = std::max(diff, std::abs(fd - jv[k]));
    norm = std::max(norm, std::abs(jv[k]));
  }
  EXPECT_GT(norm, 0.0);
  EXPECT_LT(diff, tol * norm) << "max |Jv - FD| " << diff << " of " << norm;
  if (sys.has_piston()) {
    const double fd = (fp[size - 1] - fm[size - 1]) / (2.0 * eps);
    EXPECT_NEAR(jv[size - 1], fd, tol * std::abs(fd)) << "piston row";
  }
}

TEST(Cvode, JacobianTimesMatchesFiniteDifferences) {
  for (double alpha : {2.0, 2.5}) {
    Dense d(0.72, 64, alpha);
    ConstantVolume nv(0.1);
    check_jacobian(d.model, nv, 1e-6);
    ConstantPressure np(0.1, 0.05, 1e-3);
    check_jacobian(d.model, np, 1e-6);
  }
}

// A piston whose law is not linear in P_hat: xi_V dV/dt = d + d^3 / P^2 with d = P_hat - P. Its
// slope comes from Ensemble's default (a central difference), as for any law without a closed
// form.
class CubicPiston final : public Ensemble {
 public:
  CubicPiston(double gdot, double pressure, double xi_v)
      : Ensemble(gdot), pressure_(pressure), xi_v_(xi_v) {}
  std::string name() const override { return "cubic_piston"; }
  bool has_piston() const override { return true; }
  double volume_rate(double p_hat) const override {
    const double d = p_hat - pressure_;
    return (d + d * d * d / (pressure_ * pressure_)) / xi_v_;
  }
  double piston_friction() const override { return xi_v_; }
  std::optional<double> imposed_pressure() const override { return pressure_; }

 private:
  double pressure_, xi_v_;
};

// The piston's row and column of the Jacobian take the law's slope at the state's P_hat: a
// slope taken anywhere else (a secant over [0, 1]) is off by orders of magnitude for this law.
TEST(Cvode, JacobianTimesMatchesFiniteDifferencesForANonlinearPistonLaw) {
  Dense d(0.72);
  const double p_hat = d.model.evaluate().pressure;
  CubicPiston law(0.1, 0.5 * p_hat, 1e-3);
  // The slope at P_hat differs from the linear part's 1 / xi_V by the cubic term, 3 d^2 / P^2 = 3.
  const double analytic = (1.0 + 3.0) / 1e-3;
  EXPECT_NEAR(law.volume_rate_slope(p_hat), analytic, 1e-6 * analytic);
  check_jacobian(d.model, law, 1e-6);
}

TEST(Cvode, JacobianParticleBlockIsTheHessianProduct) {
  Dense d(0.72);
  ConstantVolume nv(0.0);
  EquationOfMotion sys(d.model, nv, false);
  std::vector<double> y(sys.size(), 0.0), v(sys.size()), jv(sys.size()), hv(sys.size());
  std::mt19937_64 rng(5);
  std::normal_distribution<double> normal;
  for (auto& x : v)
    x = normal(rng);
  sys.jacobian_setup(0.0, y.data());
  sys.jacobian_times(v.data(), jv.data());
  // u is in box lengths along real axes: J_uu v = -H v / xi_s for a real-space field v.
  d.model.force_field().hessian_product(d.model.state(), d.model.neighbour_list(), v.data(),
                                        hv.data());
  for (std::size_t k = 0; k < sys.size(); ++k)
    EXPECT_NEAR(jv[k], hv[k] / kXiS, 1e-12 * (1.0 + std::abs(hv[k])));
}

TEST(Cvode, ForcesMatchAllPairsThroughRebuildsRemapsAndSorts) {
  // Fast shear: list rebuilds inside right-hand sides, remaps and particle sorts.
  Model m(random_state(128, 0.62, 11), ModelOptions{2.0, 0.3, 1, 5});
  ConstantVolume ens(0.05);
  Cvode cv(CvodeOptions{});
  ForceResult ref;
  for (int k = 1; k <= 30; ++k) {
    cv.advance(m, ens, 1.0 * k);
    const Evaluation& ev = m.evaluate();
    m.force_field().compute_all_pairs(m.state(), ref);
    double fmax = 0.0, diff = 0.0;
    for (std::size_t i = 0; i < ref.force.size(); ++i) {
      fmax = std::max(fmax, std::abs(ref.force[i]));
      diff = std::max(diff, std::abs(ref.force[i] - ev.forces.force[i]));
    }
    ASSERT_LT(diff, 1e-12 * (1.0 + fmax)) << "t " << m.state().time;
    ASSERT_NEAR(ev.pressure, ref.virial.trace() / (3.0 * m.state().box.volume()),
                1e-12 * (1.0 + std::abs(ev.pressure)));
  }
  EXPECT_NE(m.state().box.flips, 0);  // went through remaps
  EXPECT_GT(m.list_builds(), 10u);
  EXPECT_GT(stat(cv, "reinits"), 2.0);
}

TEST(Cvode, RemapRunAgreesWithTinyStepEuler) {
  // Small dense system sheared through two Lees–Edwards remaps (strain 0.45 -> 1.65), with
  // particle sorts in the CVODE run. Euler converges to the CVODE trajectory at first order:
  // its distance to it halves with dt (measured 1.06e-4, 5.3e-5, 2.6e-5 for dt = 2e-4, 1e-4,
  // 5e-5), so CVODE's own error is far below Euler's.
  const double gdot = 0.1, t_end = 12.0;
  State s0 = random_state(64, 0.62, 21);
  s0.box.strain = 0.45;
  ConstantVolume ens(gdot);
  Model m(s0, ModelOptions{2.0, 0.3, 1, 20});
  Cvode cv(tolerances(1e-9, 1e-9));
  cv.advance(m, ens, t_end);
  EXPECT_EQ(m.state().box.flips, 2);
  const auto rc = unwrapped(m.state());
  const auto r0 = unwrapped(s0);
  double moved = 0.0;
  for (std::size_t i = 0; i < rc.size(); ++i)
    moved = std::max(moved, (rc[i] - r0[i]).norm());
  EXPECT_GT(moved, 0.5);  // the flow carried them far
  std::vector<double> dist;
  for (double dt : {4e-4, 2e-4}) {
    Model ref(s0, ModelOptions{2.0, 0.3, 1, 0});
    Euler euler(dt);
    euler.advance(ref, ens, t_end);
    EXPECT_EQ(ref.state().box.flips, 2);
    const auto re = unwrapped(ref.state());
    double d = 0.0;
    for (std::size_t i = 0; i < re.size(); ++i)
      d = std::max(d, (re[i] - rc[i]).norm());
    dist.push_back(d);
    EXPECT_NEAR(ref.evaluate().sigma_xy, m.evaluate().sigma_xy, 5e-6);
    EXPECT_NEAR(ref.evaluate().pressure, m.evaluate().pressure, 5e-6);
  }
  EXPECT_LT(dist[1], 2e-4);
  EXPECT_NEAR(dist[0] / dist[1], 2.0, 0.1);
  EXPECT_GT(stat(cv, "reinits"), 2.0);  // one per remap at least
}

TEST(Cvode, PistonWithoutContactsIsLinearInTime) {
  // P_hat = 0 without contacts: V(t) = V0 - P t / xi_V exactly, particles follow affinely.
  State s = two_spheres(3.0);
  const double v0 = s.box.volume(), p = 0.5, xi_v = 1.0;
  Model m(s, ModelOptions{2.0, 0.3, 1, 0});
  ConstantPressure ens(1e-2, p, xi_v);
  Cvode cv(CvodeOptions{});
  for (double t : {10.0, 50.0, 100.0}) {
    cv.advance(m, ens, t);
    EXPECT_NEAR(m.state().box.volume(), v0 - p * t / xi_v, 1e-9 * v0) << "t " << t;
    EXPECT_NEAR(m.state().box.strain, 1e-2 * t, 1e-14);
    EXPECT_DOUBLE_EQ(m.state().x()[1] - m.state().x()[0], 3.0 / std::cbrt(v0));
  }
}

TEST(Cvode, PistonRelaxesToImposedPressure) {
  // Compressed random packing at gdot = 0: the piston expands the cell until P_hat = P and
  // the packing is in mechanical equilibrium (dV/dt = 0).
  const double p = 1e-2, xi_v = 1e-3;
  Model m(random_state(64, 0.75, 3), ModelOptions{2.0, 0.3, 1, 20});
  ConstantPressure ens(0.0, p, xi_v);
  Cvode cv(CvodeOptions{});
  const double p0 = m.evaluate().pressure;
  ASSERT_GT(p0, 10.0 * p);
  cv.advance(m, ens, 2000.0);
  const Evaluation& ev = m.evaluate();
  EXPECT_NEAR(ev.pressure, p, 1e-4 * p);
  EXPECT_LT(ev.dissipation, 1e-10);
  EXPECT_LT(ev.phi, 0.75);
  EXPECT_GT(ev.phi, 0.6);
}

TEST(Cvode, FactoryReadsOnlyItsKeys) {
  const auto build = [](const std::string& body) {
    Scene scene = Scene::parse("[integrator]\nkind = \"cvode\"\n" + body, "test");
    ConfigSection sec = scene.section("integrator");
    return make_integrator(sec);
  };
  const auto integ = build("rtol = 1e-7\natol = 1e-9\n");
  EXPECT_EQ(integ->name(), "cvode");
  EXPECT_EQ(integ->nominal_dt(), 0.0);
  const auto* cv = dynamic_cast<const Cvode*>(integ.get());
  ASSERT_NE(cv, nullptr);
  EXPECT_EQ(cv->options().rtol, 1e-7);
  EXPECT_EQ(cv->options().atol.value_or(0.0), 1e-9);
  EXPECT_NO_THROW(build(
      "method = \"adams\"\nlinear_solver = \"pcg\"\npreconditioner = \"none\"\nmax_steps = 10\n"));
  EXPECT_THROW(build("dt = 0.1\n"), ConfigError);
  EXPECT_THROW(build("rtol = 2.0\n"), ConfigError);
  EXPECT_THROW(build("atol = -1.0\n"), ConfigError);
  EXPECT_THROW(build("method = \"rk4\"\n"), ConfigError);
  EXPECT_THROW(build("max_steps = 0\n"), ConfigError);
}

TEST(Cvode, TooManyStepsIsAnIntegrationError) {
  Dense d(0.72);
  ConstantVolume ens(0.0);
  CvodeOptions o;
  o.max_steps = 3;
  Cvode cv(o);
  try {
    cv.advance(d.model, ens, 100.0);
    FAIL() << "expected IntegrationError";
  } catch (const IntegrationError& e) {
    EXPECT_NE(std::string(e.what()).find("max_steps"), std::string::npos) << e.what();
  }
  // The Model is left at CVODE's last successful step, not at a trial point.
  EXPECT_GT(d.model.state().time, 0.0);
  EXPECT_LT(d.model.state().time, 100.0);
  EXPECT_TRUE(std::isfinite(d.model.evaluate().pressure));
}

TEST(Cvode, CollapsingPistonFailsFastNamingTheVolume) {
  // No contacts and P / xi_V = 1e5: V reaches 0 at t = 0.01, after the cell has become too
  // small for the neighbour list. That is final, so CVODE must not creep on with ever
  // smaller steps (it took 1e6 of them while it was a recoverable error).
  const ConstantPressure ens(1e-3, 10.0, 1e-4);
  Model m(two_spheres(3.0), ModelOptions{2.0, 0.3, 1, 0});
  Cvode cv(CvodeOptions{});
  try {
    cv.advance(m, ens, 1.0);
    FAIL() << "expected IntegrationError";
  } catch (const IntegrationError& e) {
    EXPECT_NE(std::string(e.what()).find("volume"), std::string::npos) << e.what();
  }
  EXPECT_LT(stat(cv, "steps"), 100.0);
  EXPECT_LT(m.state().time, 0.01);
  EXPECT_GT(m.state().box.volume(), 0.0);
}

// The interrupt flag is polled between CVODE's internal steps, not only between stretches (up
// to a sample time or a remap): a stretch of several seconds stops within one internal step of
// the flag, and the run then continues to the end with the solver history it had.
TEST(Cvode, InterruptStopsWithinOneInternalStep) {
  // N = 1000 at phi = 0.64 and gdot = 1e-2 with tight tolerances: the first remap is due at
  // t = 50, so t_end = 40 is one stretch (about 6 s on the 2-core development VM in Release).
  Model m(random_state(1000, 0.64, 3), ModelOptions{2.0, 0.3, 1, 20});
  ConstantVolume ens(1e-2);
  Cvode cv(tolerances(1e-11, 1e-11));
  std::atomic<bool> flag{false};
  cv.set_interrupt(&flag);
  const double t_end = 40.0;
  using Clock = std::chrono::steady_clock;
  Clock::time_point raised{};
  std::thread raiser([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    raised = Clock::now();
    flag.store(true);
  });
  cv.advance(m, ens, t_end);
  const Clock::time_point returned = Clock::now();
  raiser.join();
  ASSERT_LT(m.state().time, t_end) << "the stretch ended before the flag: make it longer";
  const double latency = std::chrono::duration<double>(returned - raised).count();
  RecordProperty("stop_latency_s", std::to_string(latency));
  EXPECT_LT(latency, 1.5);
  // Stopped at an internal step, with the forces of that state.
  EXPECT_GT(m.state().time, 0.0);
  EXPECT_TRUE(std::isfinite(m.evaluate().pressure));
  EXPECT_GT(stat(cv, "steps"), 0.0);
  flag.store(false);
  // It goes on from there (to the end of the stretch, or a little way in a short test run).
  const double t_on = testing_support::shortened(t_end, std::min(t_end, m.state().time + 0.5));
  cv.advance(m, ens, t_on);
  EXPECT_EQ(m.state().time, t_on);
  EXPECT_EQ(stat(cv, "reinits"), 1.0);
}

// Stopped by the flag every millisecond of wall time (inside stretches, between them, at their
// start) and continued each time, as the run driver does for checkpoints: the same bits as an
// uninterrupted run through remaps, list rebuilds and reorders, with the same work counted.
TEST(Cvode, InterruptedAndContinuedRunIsBitForBitTheSame) {
  const State start = random_state(200, 0.62, 4);
  const ModelOptions mo{2.0, 0.3, 1, 20};
  ConstantVolume ens(0.05);  // a remap every 20 time units in this cell (about 7 wide)
  const double t_end = 80.0;
  Model ref(start, mo);
  Cvode cv_ref(CvodeOptions{});
  for (int k = 1; k <= 40; ++k)
    cv_ref.advance(ref, ens, t_end * k / 40);

  Model cut(start, mo);
  Cvode cv_cut(CvodeOptions{});
  std::atomic<bool> flag{false};
  cv_cut.set_interrupt(&flag);
  std::atomic<bool> done{false};
  std::thread raiser([&] {
    while (!done.load()) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
      flag.store(true);
    }
  });
  int stops = 0;
  for (int k = 1; k <= 40; ++k) {
    const double t = t_end * k / 40;
    cv_cut.advance(cut, ens, t);
    while (cut.state().time < t) {
      ++stops;
      flag.store(false);
      cv_cut.advance(cut, ens, t);
    }
  }
  done.store(true);
  raiser.join();
  RecordProperty("stops", stops);
  EXPECT_GE(stops, 3) << "hardly interrupted: the machine ran it in a few milliseconds";

  const State& a = ref.state();
  const State& b = cut.state();
  EXPECT_EQ(a.time, b.time);
  EXPECT_EQ(a.box.strain, b.box.strain);
  EXPECT_EQ(a.box.flips, b.box.flips);
  ASSERT_EQ(a.pos.size(), b.pos.size());
  EXPECT_EQ(0, std::memcmp(a.pos.data(), b.pos.data(), a.pos.size() * sizeof(double)));
  EXPECT_EQ(a.id, b.id);
  EXPECT_EQ(ref.evaluate().sigma_xy, cut.evaluate().sigma_xy);
  EXPECT_EQ(ref.force_evaluations(), cut.force_evaluations());
  EXPECT_EQ(ref.list_builds(), cut.list_builds());
  EXPECT_GT(ref.list_builds(), 5u);
  EXPECT_GT(a.box.flips, 0);
  for (const char* key : {"steps", "rhs_evaluations", "linear_iterations", "reinits"})
    EXPECT_EQ(stat(cv_ref, key), stat(cv_cut, key)) << key;
  EXPECT_GT(stat(cv_ref, "reinits"), 2.0);  // remaps and reorders re-initialise
}

TEST(Cvode, VectorKernelsAgreeWithNvectorSerial) {
  for (std::size_t n : {1u, 7u, 3001u})
    EXPECT_LT(cvode_kernel_discrepancy(n, 9), 1e-13) << "n " << n;
}

TEST(Cvode, DefaultAtolFollowsTheOverlapScale) {
  EXPECT_DOUBLE_EQ(cvode_default_atol(1e-3, 2.0), 1e-6);
  EXPECT_NEAR(cvode_default_atol(1e-4, 3.0), 1e-5, 1e-18);
  EXPECT_DOUBLE_EQ(cvode_default_atol(0.0, 2.0), 1e-12);   // floor
  EXPECT_DOUBLE_EQ(cvode_default_atol(1e-3, 1.2), 1e-12);  // (1e-3)^5 below the floor
  EXPECT_DOUBLE_EQ(cvode_default_atol(100.0, 2.0), 1e-3);  // overlap capped at a
}

// Cost on the default scene's state point (not part of the suite; run with
// --gtest_also_run_disabled_tests): N = 1000, phi = 0.62, gdot = 1e-3.
TEST(Cvode, DISABLED_CostPerUnitTimeN1000) {
  const double gdot = 1e-3, t_warm = 300.0, t_meas = 200.0;
  Model base(random_state(1000, 0.62, 1), ModelOptions{2.0, 0.3, 1, 20});
  ConstantVolume ens(gdot);
  Euler warm(0.1);
  warm.advance(base, ens, t_warm);
  const auto measure = [&](Integrator& integ, const char* label) {
    Model m(base.state(), ModelOptions{2.0, 0.3, 1, 20});
    m.evaluate();
    const std::size_t f0 = m.force_evaluations(), b0 = m.list_builds();
    const auto w0 = std::chrono::steady_clock::now();
    double sxy = 0.0, pr = 0.0;
    int samples = 0;
    for (double t = t_warm + 1.0; t <= t_warm + t_meas + 1e-9; t += 1.0) {
      integ.advance(m, ens, t);
      sxy += m.evaluate().sigma_xy;
      pr += m.evaluate().pressure;
      ++samples;
    }
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count();
    std::printf(
        "%-28s force evals / unit time %8.2f   list builds / unit time %6.3f   wall / unit "
        "time %.4f s   <sigma_xy> %.4e  <P> %.4e\n",
        label, double(m.force_evaluations() - f0) / t_meas, double(m.list_builds() - b0) / t_meas,
        wall / t_meas, sxy / samples, pr / samples);
    for (const auto& [k, v] : integ.statistics())
      std::printf("    %s = %.6g (%.3f per unit time)\n", k.c_str(), v, v / t_meas);
  };
  {
    // Stiffest relaxation rate: largest eigenvalue of H / xi_s (power iteration on -J). Explicit
    // Euler is stable for dt < 2 / lambda_max.
    ConstantVolume still(0.0);
    EquationOfMotion sys(base, still, true);
    std::vector<double> y(sys.size(), 0.0), v(sys.size(), 0.0), w(sys.size());
    std::mt19937_64 rng(1);
    std::normal_distribution<double> normal;
    for (auto& x : v)
      x = normal(rng);
    sys.jacobian_setup(base.state().time, y.data());
    double lambda = 0.0;
    for (int it = 0; it < 500; ++it) {
      double norm = 0.0;
      for (double x : v)
        norm += x * x;
      for (auto& x : v)
        x /= std::sqrt(norm);
      sys.jacobian_times(v.data(), w.data());
      double dot = 0.0;
      for (std::size_t k = 0; k < v.size(); ++k)
        dot -= v[k] * w[k];
      lambda = dot;
      for (std::size_t k = 0; k < v.size(); ++k)
        v[k] = -w[k];
    }
    std::printf("lambda_max(H / xi_s) = %.4f  ->  explicit Euler stable for dt < %.4f\n", lambda,
                2.0 / lambda);
  }
  Euler euler(0.1);
  measure(euler, "euler dt = 0.1");
  for (double rtol : {1e-4, 1e-6}) {
    CvodeOptions o;
    o.rtol = rtol;
    Cvode cv(o);
    measure(cv, rtol == 1e-4 ? "cvode rtol 1e-4" : "cvode rtol 1e-6 (default)");
  }
  CvodeOptions loose = tolerances(1e-4, 1e-4);
  Cvode cv(loose);
  measure(cv, "cvode rtol = atol = 1e-4");
  CvodeOptions plain, pcg, adams;
  plain.preconditioner = CvodeOptions::Preconditioner::kNone;
  pcg.linear_solver = CvodeOptions::LinearSolver::kPcg;
  adams.method = CvodeOptions::Method::kAdams;
  Cvode cv_plain(plain), cv_pcg(pcg), cv_adams(adams);
  measure(cv_plain, "cvode default, no precond");
  measure(cv_pcg, "cvode default, pcg");
  measure(cv_adams, "cvode default, adams");
  CvodeOptions loose_plain = loose;
  loose_plain.preconditioner = CvodeOptions::Preconditioner::kNone;
  Cvode cv_loose_plain(loose_plain);
  measure(cv_loose_plain, "cvode 1e-4/1e-4, no precond");
}

}  // namespace
}  // namespace jamflow
