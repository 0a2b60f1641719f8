// RKC: the method's coefficients (stage times, stability interval, order of the stability
// polynomial), the spectral-radius estimate against power iteration on the analytic Hessian
// product, agreement with a tiny-step Euler reference through Lees–Edwards remaps, large
// tolerances that stay stable, the interrupt flag, and bad keys. The contract suite
// (test_contract.cpp) and the resume tests (tests/driver/test_checkpoint.cpp) cover the rest.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <complex>

#include "driver/run.hpp"
#include "driver/verdicts.hpp"
#include "ensembles/constant_pressure.hpp"
#include "ensembles/constant_volume.hpp"
#include "integrators/euler.hpp"
#include "integrators/motion.hpp"
#include "integrators/registry.hpp"
#include "integrators/rkc.hpp"
#include "lib/config.hpp"
#include "lib/error.hpp"
#include "lib/init.hpp"
#include "lib/model.hpp"

namespace jamflow {
namespace {

// The stability polynomial R_s(z) of the s-stage method: the step applied to y' = lambda y
// with z = h lambda, by the same recursion as the integrator.
std::complex<double> stability_polynomial(const RkcCoefficients& c, int s, std::complex<double> z) {
  std::complex<double> ym2 = 1.0, ym1 = 1.0 + c.mu_tilde[1] * z;
  for (int j = 2; j <= s; ++j) {
    const std::complex<double> yj = (1.0 - c.mu[j] - c.nu[j]) + c.mu[j] * ym1 + c.nu[j] * ym2 +
                                    c.mu_tilde[j] * z * ym1 + c.gamma_tilde[j] * z;
    ym2 = ym1;
    ym1 = yj;
  }
  return ym1;
}

TEST(RkcCoefficients, StageTimesStabilityIntervalAndOrder) {
  for (int s : {2, 3, 5, 10, 40, 200}) {
    const RkcCoefficients c = rkc_coefficients(s);
    EXPECT_DOUBLE_EQ(c.c[s], 1.0) << s;
    for (int j = 1; j <= s; ++j)
      EXPECT_GT(c.c[j], c.c[j - 1]) << "stage " << j << " of " << s;
    // The stage count the integrator picks, s^2 >= 1 + 1.54 h rho, stays inside the interval.
    EXPECT_GE(c.beta, (double(s) * s - 1.0) / 1.54) << s;
    // |R(z)| <= 1 on the real interval [-beta, 0] (damped: below 1 - eps/3 inside).
    for (int k = 1; k <= 400; ++k) {
      const double z = -c.beta * k / 400.0;
      EXPECT_LE(std::abs(stability_polynomial(c, s, z)), 1.0 + 1e-12) << s << " at " << z;
    }
    // Second order: R(z) - exp(z) = O(z^3), so halving z divides the difference by 8 (+-10%).
    const double z1 = -1e-2, z2 = -0.5e-2;
    const double d1 = std::abs(stability_polynomial(c, s, z1) - std::exp(z1));
    const double d2 = std::abs(stability_polynomial(c, s, z2) - std::exp(z2));
    EXPECT_NEAR(d1 / d2, 8.0, 0.8) << s;
  }
  // Past the interval the polynomial grows: beta is the edge, not a bound far inside it.
  const RkcCoefficients c = rkc_coefficients(10);
  EXPECT_GT(std::abs(stability_polynomial(c, 10, -1.05 * c.beta)), 1.0);
  // beta ~ 0.653 s^2 for the damping 2/13 (Sommeijer, Shampine & Verwer 1998).
  const RkcCoefficients big = rkc_coefficients(200);
  EXPECT_NEAR(big.beta / (200.0 * 200.0), 0.653, 0.01);
}

// A packing relaxed at constant volume.
State dense_packing(std::size_t n, double phi) {
  Model m(random_state(n, phi, 17), ModelOptions{2.0, 0.3, 1, 0});
  Euler relax(0.1);
  relax.advance(m, ConstantVolume(0.0), 200.0);
  State out = m.state();
  out.time = 0.0;
  return out;
}

// The largest |eigenvalue| of the equation of motion's Jacobian by plain power iteration on the
// analytic Jacobian-vector product (many iterations from a random start).
double analytic_radius(Model& m, const Ensemble& ens) {
  m.evaluate();
  EquationOfMotion sys(m, ens, false);
  std::vector<double> y(sys.size(), 0.0), v(sys.size()), jv(sys.size());
  sys.jacobian_setup(m.state().time, y.data());
  for (std::size_t k = 0; k < v.size(); ++k)
    v[k] = std::sin(1.0 + 7.3 * double(k));
  double lambda = 0.0;
  for (int it = 0; it < 3000; ++it) {
    sys.jacobian_times(v.data(), jv.data());
    double norm = 0.0;
    for (double x : jv)
      norm += x * x;
    norm = std::sqrt(norm);
    double vn = 0.0;
    for (double x : v)
      vn += x * x;
    lambda = norm / std::sqrt(vn);
    for (std::size_t k = 0; k < v.size(); ++k)
      v[k] = jv[k] / norm;
  }
  return lambda;
}

TEST(RkcSpectralRadius, AgreesWithPowerIterationOnTheAnalyticHessianProduct) {
  const State packing = dense_packing(300, 0.66);
  const ConstantVolume volume(1e-4);
  Model probe(packing, ModelOptions{2.0, 0.3, 1, 0});
  const double p = probe.evaluate().pressure;
  // The piston's mode counts: xi_V small enough (1e-4 N-free units here) that it is the stiff one.
  const ConstantPressure pressure(1e-4, p, 1e-4);
  const ConstantPressure soft_piston(1e-4, p, 10.0);
  for (const Ensemble* ens :
       {static_cast<const Ensemble*>(&volume), static_cast<const Ensemble*>(&soft_piston),
        static_cast<const Ensemble*>(&pressure)}) {
    Model m(packing, ModelOptions{2.0, 0.3, 1, 0});
    const double exact = analytic_radius(m, *ens);
    long long evaluations = 0;
    const double estimate = rkc_spectral_radius(m, *ens, &evaluations);
    // Within 10%; measured: 5.05 against 5.15 (no piston or xi_V = 10), 5.84 against 6.05
    // (xi_V = 1e-4). Power iteration approaches from below.
    EXPECT_NEAR(estimate / exact, 1.0, 0.10)
        << ens->name() << " xi_V " << ens->piston_friction() << ": exact " << exact;
    EXPECT_GT(evaluations, 1);
    EXPECT_LE(evaluations, 50);
  }
  // A stiff piston raises the radius above the particles' own (measured: 6.05 against 5.15).
  Model a(packing, ModelOptions{2.0, 0.3, 1, 0}), b(packing, ModelOptions{2.0, 0.3, 1, 0});
  EXPECT_GT(analytic_radius(a, pressure), 1.1 * analytic_radius(b, volume));
}

// Through several Lees–Edwards remaps and list rebuilds (strain 3 at gdot = 0.05), at both
// ensembles: at a tight tolerance the positions agree with Euler extrapolated to dt -> 0.
TEST(Rkc, FollowsTheZeroStepLimitOfEulerThroughRemaps) {
  const State packing = dense_packing(100, 0.64);
  Model probe(packing, ModelOptions{2.0, 0.3, 1, 0});
  const double p = probe.evaluate().pressure;
  const ConstantVolume volume(5e-2);
  const ConstantPressure pressure(5e-2, p, 1.0);
  const double t_end = 60.0;
  for (const Ensemble* ens :
       {static_cast<const Ensemble*>(&volume), static_cast<const Ensemble*>(&pressure)}) {
    // Euler at dt and dt / 2; Richardson: 2 x(dt / 2) - x(dt) is exact to O(dt^2).
    std::vector<double> euler[2];
    double volumes[2];
    for (int k = 0; k < 2; ++k) {
      Model ref(packing, ModelOptions{2.0, 0.3, 1, 0});
      Euler e(k == 0 ? 0.002 : 0.001);
      e.advance(ref, *ens, t_end);
      euler[k] = ref.state().unwrapped_by_id();
      volumes[k] = ref.state().box.volume();
    }
    RkcOptions o;
    o.rtol = 1e-8;
    o.atol = 1e-8;
    Rkc rkc(o);
    Model m(packing, ModelOptions{2.0, 0.3, 1, 0});
    m.evaluate();
    const std::int64_t flips0 = m.state().box.flips;
    rkc.advance(m, *ens, t_end);
    EXPECT_EQ(m.state().time, t_end);
    EXPECT_GE(m.state().box.flips - flips0, 2) << "no remap was crossed";
    const auto x = m.state().unwrapped_by_id();
    double euler_error = 0.0, worst = 0.0;
    for (std::size_t k = 0; k < x.size(); ++k) {
      const double exact = 2.0 * euler[1][k] - euler[0][k];
      euler_error = std::max(euler_error, std::abs(euler[1][k] - exact));
      worst = std::max(worst, std::abs(x[k] - exact));
    }
    // Euler's own error at dt = 0.001 is about 1.5e-3 a here (the motion is chaotic, so errors
    // grow along the run); RKC at 1e-8 is held to a tenth of it.
    EXPECT_GT(euler_error, 1e-4) << ens->name();
    EXPECT_LT(worst, 0.1 * euler_error) << ens->name();
    const double v_exact = 2.0 * volumes[1] - volumes[0];
    EXPECT_LT(std::abs(m.state().box.volume() - v_exact),
              0.1 * std::abs(volumes[1] - v_exact) + 1e-12 * v_exact)
        << ens->name();
  }
}

// The correlations of the forces at the ends of steps one and two steps apart, over `steps`
// steps each taken by one advance() to exactly the step the integrator proposes (RKC) or its
// fixed dt: c(lag) = sum F_n . F_{n+lag} / sum (|F_n|^2 + |F_{n+lag}|^2) / 2, as the stable
// verdict's oscillation test (driver/verdicts.hpp). A period-2 oscillation makes the forces two
// steps apart more alike than those one step apart; long smooth steps only decorrelate them.
struct LagCorrelations {
  double one = 0.0, two = 0.0;
};
LagCorrelations step_correlations(Integrator& integ, Model& m, const Ensemble& ens, int steps) {
  std::vector<std::vector<double>> forces;
  for (int k = 0; k < steps; ++k) {
    double h = integ.nominal_dt();
    if (h == 0.0) {
      h = statistic(integ.statistics(), "step_next");
      if (h == 0.0)
        h = 0.1;  // the first step: no proposal yet
    }
    integ.advance(m, ens, m.state().time + h);
    forces.push_back(m.evaluate().forces.force);
  }
  LagCorrelations out;
  for (int lag : {1, 2}) {
    StepCorrelation corr;
    for (std::size_t k = 0; k < forces.size(); k += lag)
      corr.add(forces[k]);
    (lag == 1 ? out.one : out.two) = corr.correlation();
  }
  return out;
}

// However loose the tolerance, the stage count follows the spectral radius, so the long steps
// do not excite the period-2 oscillation of an explicit step past its stability limit. The
// same measure sees it for Euler at dt = 0.6 (its limit is about 0.4).
TEST(Rkc, LooseTolerancesNeverOscillate) {
  const State packing = dense_packing(200, 0.64);
  const ConstantVolume ens(1e-3);
  {
    Model m(packing, ModelOptions{2.0, 0.3, 1, 0});
    Euler unstable(0.6);
    const LagCorrelations c = step_correlations(unstable, m, ens, 200);
    EXPECT_LT(c.one, 0.9);
    EXPECT_GT(c.two, c.one);
  }
  for (double atol : {1e-3, 1e-2, 1e-1}) {
    Model m(packing, ModelOptions{2.0, 0.3, 1, 0});
    RkcOptions o;
    o.rtol = 0.9;
    o.atol = atol;  // 0.05, 0.5 and 5 typical overlaps
    Rkc rkc(o);
    const LagCorrelations c = step_correlations(rkc, m, ens, 200);
    RecordProperty("atol_" + std::to_string(atol),
                   std::to_string(c.one) + " (lag 1), " + std::to_string(c.two) + " (lag 2)");
    EXPECT_GT(c.one, c.two) << "atol " << atol;
    EXPECT_GT(statistic(rkc.statistics(), "max_stages_used"), 3.0) << "atol " << atol;
    EXPECT_TRUE(std::isfinite(m.evaluate().pressure));
  }
}

TEST(Rkc, StopsOnTheInterruptFlagAndContinues) {
  const State packing = dense_packing(100, 0.64);
  Model a(packing, ModelOptions{2.0, 0.3, 1, 0}), b(packing, ModelOptions{2.0, 0.3, 1, 0});
  const ConstantVolume ens(1e-3);
  Rkc straight(RkcOptions{}), stopped(RkcOptions{});
  straight.advance(a, ens, 100.0);
  std::atomic<bool> flag{true};
  stopped.set_interrupt(&flag);
  stopped.advance(b, ens, 100.0);
  EXPECT_EQ(b.state().time, 0.0);  // the flag is polled before each step
  flag = false;
  stopped.advance(b, ens, 100.0);
  EXPECT_EQ(b.state().pos, a.state().pos);
  EXPECT_EQ(b.state().time, 100.0);
}

TEST(Rkc, BadKeysNameTheKeyAndTheRange) {
  const auto error_of = [](const std::string& keys) {
    std::string text = "kind = \"rkc\"\n";
    text += keys;
    IntegratorSettings s = IntegratorSettings::from_table(toml::parse(text));
    try {
      make_integrator(s);
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(error_of("rtol = 2.0").find("rtol"), std::string::npos);
  EXPECT_NE(error_of("atol = -1.0").find("atol"), std::string::npos);
  EXPECT_NE(error_of("max_stages = 1").find("max_stages"), std::string::npos);
  EXPECT_NE(error_of("dom_eig_safety = 0.5").find("dom_eig_safety"), std::string::npos);
  EXPECT_NE(error_of("dom_eig_frequency = 0").find("dom_eig_frequency"), std::string::npos);
  EXPECT_NE(error_of("dt = 0.1").find("dt"), std::string::npos);  // not a key of rkc
}

}  // namespace
}  // namespace jamflow
