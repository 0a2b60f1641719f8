// The integrator contract, run for every integrator (Euler, the RESPA configurations and CVODE)
// against every ensemble (constant volume, constant pressure):
//   - an analytic relaxation (two spheres: exp(-2t); a free piston: V = V0 - P t / xi_V);
//   - the measured convergence order on a dense sheared system against the declared one (for
//     the adaptive CVODE: the order of the error in the tolerance rtol = atol);
//   - steady-state means that agree with a reference Euler run within their errors;
//   - a piston that relaxes the volume to where <P_hat> = P;
//   - a volume that would become negative stops the run with an IntegrationError.
#include <gtest/gtest.h>

#include <unistd.h>
#include <cmath>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "driver/run.hpp"
#include "ensembles/constant_pressure.hpp"
#include "ensembles/constant_volume.hpp"
#include "ensembles/registry.hpp"
#include "integrators/euler.hpp"
#include "integrators/registry.hpp"
#include "lib/error.hpp"
#include "lib/h5.hpp"
#include "lib/init.hpp"
#include "lib/model.hpp"
#include "tests/short_tests.hpp"
#include "tests/two_spheres.hpp"

namespace jamflow {
namespace {

namespace fs = std::filesystem;

// One integrator configuration: its [integrator] keys without the step, and the step its
// steady-state run uses (chosen so that the particle sub-step is 0.05-0.1, well inside explicit
// stability). An adaptive configuration has no dt: its "step" is the tolerance rtol = atol
// (atol in units of a), and each test names the tolerance it uses in place of its dt.
struct Config {
  std::string kind;  // the registered kind
  std::string label;
  std::string keys;
  double steady_dt;
  bool adaptive = false;
};

const Config kConfigs[] = {
    {"euler", "euler", "kind = \"euler\"", 0.05},
    {"respa", "respa_particles_euler", "kind = \"respa\"\nn_inner = 4", 0.2},
    {"respa", "respa_particles_heun", "kind = \"respa\"\nn_inner = 2\ninner_scheme = \"heun\"",
     0.2},
    {"respa", "respa_piston_euler", "kind = \"respa\"\nn_inner = 4\ninner = \"piston\"", 0.1},
    {"respa", "respa_piston_heun",
     "kind = \"respa\"\nn_inner = 2\ninner = \"piston\"\ninner_scheme = \"heun\"", 0.2},
    {"respa", "respa_mixed",
     "kind = \"respa\"\nn_inner = 3\ninner_scheme = \"heun\"\nouter_scheme = \"euler\"", 0.2},
    {"cvode", "cvode_bdf_spgmr", "kind = \"cvode\"", 1e-4, true},
    {"cvode", "cvode_bdf_pcg", "kind = \"cvode\"\nlinear_solver = \"pcg\"", 1e-4, true},
    {"rkc", "rkc", "kind = \"rkc\"", 1e-4, true},
};

// The configurations of every registered kind (integrators/registry.hpp): those above, or for a
// kind without any, its defaults at a fixed step of 0.05, so that a new integrator is held to
// the contract as soon as it registers (add its configurations above if it needs other keys).
std::vector<Config> registered_configs() {
  std::vector<Config> out;
  for (const std::string& kind : integrator_kinds()) {
    bool any = false;
    for (const auto& c : kConfigs) {
      if (c.kind == kind) {
        out.push_back(c);
        any = true;
      }
    }
    if (!any)
      out.push_back({kind, kind, "kind = \"" + kind + "\"", 0.05});
  }
  return out;
}

// The step a test uses: its dt for a fixed-step configuration, its tolerance for CVODE.
double step(const Config& c, double dt, double tol) {
  return c.adaptive ? tol : dt;
}

std::string integrator_toml(const Config& c, double step) {
  const std::string s = fmt(step);
  return std::string("[integrator]\n") + c.keys +
         (c.adaptive ? "\nrtol = " + s + "\natol = " + s : "\ndt = " + s) + "\n";
}

std::unique_ptr<Integrator> make(const Config& c, double dt) {
  const Scene scene = Scene::parse(integrator_toml(c, dt), "contract.toml");
  ConfigSection sec = scene.section("integrator");
  return make_integrator(sec);
}

int declared_order(const Integrator& integ, const Ensemble& ens) {
  return integ.order(ens);
}

enum class Kind { kVolume, kPressure };

struct Case {
  Config config;
  Kind kind;
};

void PrintTo(const Case& c, std::ostream* os) {
  *os << c.config.label
      << (c.kind == Kind::kVolume ? " at constant volume" : " at constant pressure");
}

std::string case_name(const ::testing::TestParamInfo<Case>& info) {
  return info.param.config.label + (info.param.kind == Kind::kVolume ? "_NV" : "_NP");
}

// The ensemble kinds the contract knows how to set up, by registered name.
const std::map<std::string, Kind> kEnsembleKinds = {{"constant_volume", Kind::kVolume},
                                                    {"constant_pressure", Kind::kPressure}};

// Every registered integrator configuration against every registered ensemble.
std::vector<Case> all_cases() {
  std::vector<Case> out;
  for (const auto& c : registered_configs())
    for (const std::string& e : ensemble_kinds())
      if (kEnsembleKinds.count(e))
        out.push_back({c, kEnsembleKinds.at(e)});
  return out;
}

// A new ensemble kind needs its set-up here (kEnsembleKinds and the tests' branches).
TEST(ContractCoverage, EveryRegisteredEnsembleHasContractSetUp) {
  for (const std::string& e : ensemble_kinds())
    EXPECT_TRUE(kEnsembleKinds.count(e)) << "no contract set-up for ensemble kind " << e;
}

TEST(ContractCoverage, EveryRegisteredIntegratorIsTested) {
  for (const std::string& kind : integrator_kinds()) {
    int n = 0;
    for (const Case& c : all_cases())
      n += c.config.kind == kind;
    EXPECT_GE(n, 2) << kind << " has no contract cases";
  }
}

class Contract : public ::testing::TestWithParam<Case> {};

// --- analytic relaxation -----------------------------------------------------------------

using fixtures::two_spheres;  // tests/two_spheres.hpp

TEST_P(Contract, AnalyticRelaxation) {
  const Case c = GetParam();
  if (c.kind == Kind::kVolume) {
    // Two small spheres: delta(t) = 0.2 exp(-2t). At dt = 0.005 every configuration's error is
    // below 2 * (particle sub-step <= dt) relative (the Euler bound; Heun's is far smaller).
    // CVODE at rtol = atol = 1e-6 is held to the same bound.
    const ConstantVolume ens(1e-2);
    Model m(two_spheres(0.8, 1000.0), ModelOptions{2.0, 0.3, 1, 0});
    auto integ = make(c.config, step(c.config, 0.005, 1e-6));
    integ->advance(m, ens, 1.0);
    const double exact = 0.2 * std::exp(-2.0);
    const double got = 1.0 - (m.state().real(1) - m.state().real(0)).norm();
    EXPECT_NEAR(got, exact, 2.0 * 0.005 * exact * 1.05);
    EXPECT_DOUBLE_EQ(m.state().time, 1.0);
  } else {
    // No contacts, so P_hat = 0 and xi_V dV/dt = -P: V(t) = V0 - P t / xi_V, which every
    // scheme integrates exactly (the rate is constant). Strain and scaled positions are kept.
    const double p = 1e-3, xi = 0.5, v0 = 1000.0;
    const ConstantPressure ens(1e-2, p, xi);
    Model m(two_spheres(3.0, v0), ModelOptions{2.0, 0.3, 1, 0});
    const State before = m.state();
    auto integ = make(c.config, step(c.config, 0.3, 1e-4));
    integ->advance(m, ens, 10.0);
    EXPECT_NEAR(m.state().box.volume(), v0 - p * 10.0 / xi, 1e-10 * v0);
    EXPECT_NEAR(m.state().box.strain, 0.1, 1e-14);
    EXPECT_DOUBLE_EQ(m.state().box.lx, m.state().box.ly);
    EXPECT_DOUBLE_EQ(m.state().box.lx, m.state().box.lz);
    for (std::size_t k = 0; k < before.pos.size(); ++k)
      EXPECT_DOUBLE_EQ(m.state().pos[k], before.pos[k]);
  }
}

// --- measured convergence order ------------------------------------------------------------

// A dense packing (N = 48, phi = 0.66) relaxed from random so that overlaps are moderate, then
// sheared fast (gdot = 0.1) with, at constant pressure, a piston whose rate is comparable with
// the contacts' (xi_V = 5e-4: its Euler error dominates that of the particles) and a pressure
// half the initial one, so that every level moves. The runs are short (t = 0.4) and the pair
// exponent is alpha_r = 3, whose force derivative is continuous at contact: with the harmonic
// force a contact that opens or closes at slightly different times for different dt gives
// Heun an irregular O(h^2) kick, which scattered the measured slopes by +-0.3.
constexpr double kOrderAlpha = 3.0;

const State& dense_state() {
  static const State s = [] {
    Model m(random_state(48, 0.66, 21), ModelOptions{kOrderAlpha, 0.3, 1, 0});
    Euler relax(0.05);
    relax.advance(m, ConstantVolume(0.0), 20.0);
    State out = m.state();
    out.time = 0.0;
    return out;
  }();
  return s;
}

double initial_pressure() {
  Model m(dense_state(), ModelOptions{kOrderAlpha, 0.3, 1, 0});
  return m.evaluate().pressure;
}

std::unique_ptr<Ensemble> order_ensemble(Kind k) {
  if (k == Kind::kVolume)
    return std::make_unique<ConstantVolume>(0.1);
  return std::make_unique<ConstantPressure>(0.1, 0.5 * initial_pressure(), 5e-4);
}

// Real-space unwrapped positions (by particle id) and the cell edge after time t_end.
std::vector<double> final_coordinates(Integrator& integ, const Ensemble& ens, double t_end) {
  Model m(dense_state(), ModelOptions{kOrderAlpha, 0.3, 1, 0});
  integ.advance(m, ens, t_end);
  std::vector<double> out = m.state().unwrapped_by_id();
  out.push_back(std::cbrt(m.state().box.volume()));
  return out;
}

double max_difference(const std::vector<double>& a, const std::vector<double>& b) {
  double d = 0.0;
  for (std::size_t k = 0; k < a.size(); ++k)
    d = std::max(d, std::abs(a[k] - b[k]));
  return d;
}

// Least-squares slope of log(err) against log(dt).
double fitted_order(const std::vector<double>& dts, const std::vector<double>& errs) {
  double mx = 0, my = 0;
  for (std::size_t k = 0; k < dts.size(); ++k) {
    mx += std::log(dts[k]);
    my += std::log(errs[k]);
  }
  mx /= double(dts.size());
  my /= double(dts.size());
  double sxy = 0, sxx = 0;
  for (std::size_t k = 0; k < dts.size(); ++k) {
    sxy += (std::log(dts[k]) - mx) * (std::log(errs[k]) - my);
    sxx += (std::log(dts[k]) - mx) * (std::log(dts[k]) - mx);
  }
  return sxy / sxx;
}

// The nominal cost each integrator declares (force_passes_per_time) is what it spends: over 20
// steps on the dense packing, the model's force evaluations are the declared passes per unit
// time x the time, up to the one evaluation a run may start with. Adaptive integrators declare
// NaN, and their force-pass equivalents are at least the model's evaluations.
TEST_P(Contract, ForcePassesPerTimeMatchesEvaluations) {
  const Case c = GetParam();
  const auto ens = order_ensemble(c.kind);
  auto integ = make(c.config, step(c.config, 0.02, 1e-4));
  const double per_time = integ->force_passes_per_time(*ens);
  Model m(dense_state(), ModelOptions{kOrderAlpha, 0.3, 1, 0});
  const double t_end = 0.4;
  integ->advance(m, *ens, t_end);
  const double evaluations = double(m.force_evaluations());
  EXPECT_GE(integ->force_pass_equivalents(m), evaluations);
  // The CPU time a dry-run expects: finite and positive for every integrator, and the nominal
  // passes at the measured cost of one for fixed-step ones.
  const double cpu = integ->cpu_seconds_per_particle_time(*ens, Integrator::CostPoint{});
  EXPECT_TRUE(std::isfinite(cpu) && cpu > 0.0) << cpu;
  if (c.config.adaptive) {
    EXPECT_TRUE(std::isnan(per_time));
    return;
  }
  EXPECT_DOUBLE_EQ(cpu, per_time * kCpuSecondsPerParticlePass);
  ASSERT_TRUE(std::isfinite(per_time) && per_time > 0.0) << per_time;
  EXPECT_NEAR(evaluations, per_time * t_end, 1.0) << "declared " << per_time << " per unit time";
  EXPECT_EQ(integ->force_pass_equivalents(m), evaluations);
}

TEST_P(Contract, MeasuredOrderMatchesDeclared) {
  const Case c = GetParam();
  const auto ens = order_ensemble(c.kind);
  const double t_end = 0.4;
  // Reference: second-order RESPA (Heun on both levels) at a step 16x below the smallest tested.
  const Config ref_cfg{"respa", "ref", "kind = \"respa\"\nn_inner = 1\ninner_scheme = \"heun\"",
                       0.0};
  auto ref_integ = make(ref_cfg, 0.005 / 16.0);
  const auto ref = final_coordinates(*ref_integ, *ens, t_end);
  // Fixed steps: three halvings of dt against the declared order. CVODE: six decades of the
  // tolerance rtol = atol, since single decades can go the wrong way.
  const bool adaptive = c.config.adaptive;
  const std::vector<double> dts =
      adaptive ? std::vector<double>{1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9}
               : std::vector<double>{0.04, 0.02, 0.01, 0.005};
  std::vector<double> errs;
  int declared = 0;
  for (double dt : dts) {
    auto integ = make(c.config, dt);
    declared = declared_order(*integ, *ens);
    errs.push_back(max_difference(final_coordinates(*integ, *ens, t_end), ref));
  }
  const double slope = fitted_order(dts, errs);
  std::string listing;
  for (double e : errs) {
    listing += ' ';
    listing += fmt(e);
  }
  if (!adaptive) {
    // +-0.15 on the least-squares slope over three halvings of dt.
    EXPECT_NEAR(slope, double(declared), 0.15) << "errors" << listing;
  } else {
    // CVODE controls the local error of each step, so for a method of order q the global error
    // goes as tol^(q/(q+1)): between 1/2 (BDF order 1) and 5/6 (order 5), below the 1 that error
    // per unit step would give. Measured here: 0.79 (NV) and 0.75 (NP). Allowed [0.5, 1.05];
    // and, over every two decades, a smaller error.
    EXPECT_GE(slope, 0.5) << "errors" << listing;
    EXPECT_LE(slope, 1.05) << "errors" << listing;
    for (std::size_t k = 2; k < errs.size(); ++k)
      EXPECT_LT(errs[k], errs[k - 2]) << "tolerance " << dts[k] << ", errors" << listing;
  }
  // The motion is not trivial: the largest displacement error at the coarsest step is resolvable.
  EXPECT_GT(errs[0], 1e-9);
}

// --- steady-state means --------------------------------------------------------------------

std::string steady_scene(Kind k, const std::string& integ, double t_av) {
  const std::string ens = k == Kind::kVolume
                              ? "kind = \"constant_volume\"\n"
                              : "kind = \"constant_pressure\"\npressure = 1e-2\nxi_V = 1e-3\n";
  return "[system]\nN = 256\nphi = 0.6\n[ensemble]\n" + ens + "[shear]\nrate = 1e-2\n" + integ +
         "[run]\nt_eq = 500.0\nt_av = " + std::to_string(t_av) +
         "\nsample_every = 1.0\nthreads = 1\n";
}

Summary steady_summary(Kind k, const Config& c, std::uint64_t seed, double t_av) {
  const RunSpec spec = parse_run_spec(
      Scene::parse(steady_scene(k, integrator_toml(c, c.steady_dt), t_av), "steady.toml"));
  RunOptions opt;
  opt.quiet = true;
  const ReplicaResult r = run_replica(spec, seed, opt);
  EXPECT_TRUE(r.status.is_complete()) << r.status.text();
  return r.summary;
}

// The steady means of one configuration over independent seeds (one run each), with each run's
// block error, as replica_average() takes them.
struct SeedMeans {
  std::map<std::string, std::vector<double>> means, errors;
  std::vector<double> energy_balance;
};

SeedMeans seed_means(Kind k, const Config& c, std::uint64_t first_seed, int seeds, double t_av) {
  SeedMeans out;
  for (int s = 0; s < seeds; ++s) {
    const Summary sum = steady_summary(k, c, first_seed + std::uint64_t(s), t_av);
    for (const auto& [name, e] :
         {std::pair{"sigma_xy", sum.sigma_xy}, {"pressure", sum.pressure}, {"phi", sum.phi}}) {
      out.means[name].push_back(e.value);
      out.errors[name].push_back(e.err);
    }
    out.energy_balance.push_back(sum.energy_balance);
  }
  return out;
}

TEST_P(Contract, SteadyStateMeansAgreeWithReferenceEuler) {
  const Case c = GetParam();
  if (c.config.label == "euler")
    GTEST_SKIP() << "the reference itself";
  // The error is measured from independent seeds, not from one run's block errors. At this state
  // point the means of independent runs spread 2.0x (t_av = 2000, 20 blocks) to 1.5x (t_av = 8000,
  // 10 blocks of 8 strain units) more than their block errors say (16 seeds each): the stress has
  // a slowly decaying tail, and runs from different seeds stay apart for longer than a run.
  // Reference: Euler over 16 seeds, shared by every configuration; each configuration: 4 seeds.
  // Under a sanitizer (tests/short_tests.hpp) the reference has 8 seeds and the windows are half
  // as long: the same comparison with less power, at the same false-alarm probability.
  const bool shorter = testing_support::shortened(false, true);
  const int kReferenceSeeds = shorter ? 8 : 16, kSeeds = 4;
  const double t_av = shorter ? 1000.0 : 2000.0;
  static std::map<Kind, SeedMeans> reference;
  if (!reference.count(c.kind))
    reference[c.kind] = seed_means(c.kind, kConfigs[0], 1000, kReferenceSeeds, t_av);
  const SeedMeans& a = reference[c.kind];
  const SeedMeans b = seed_means(c.kind, c.config, 2000, kSeeds, t_av);
  // Pooled two-sample t statistic with 18 degrees of freedom: an integrator that samples the same
  // steady state has the same seed-to-seed spread. |t| < 4.5: a false alarm has probability
  // 3e-4 per comparison, under 1% over the 28 comparisons of this test, so a change in the last
  // bit of the dynamics (which sends every chaotic run elsewhere) does not fail it by chance.
  // With 10 degrees of freedom (shortened) the same probability is |t| < 5.4.
  const double t_limit = shorter ? 5.4 : 4.5;
  const char* observables[] = {"sigma_xy", c.kind == Kind::kVolume ? "pressure" : "phi"};
  for (const char* name : observables) {
    const ReplicaAverage ma = replica_average(a.means.at(name), a.errors.at(name));
    const ReplicaAverage mb = replica_average(b.means.at(name), b.errors.at(name));
    const double pooled = ((kReferenceSeeds - 1) * ma.replica_std * ma.replica_std +
                           (kSeeds - 1) * mb.replica_std * mb.replica_std) /
                          double(kReferenceSeeds + kSeeds - 2);
    const double err = std::sqrt(pooled * (1.0 / kReferenceSeeds + 1.0 / kSeeds));
    ASSERT_GT(err, 0.0) << name;
    EXPECT_LT(std::abs(ma.mean - mb.mean), t_limit * err)
        << name << ": " << ma.mean << " vs " << mb.mean << " +- " << err;
  }
  // The dynamics is well resolved: the energy balance (SPEC §3) holds within 3% in every run.
  for (double balance : b.energy_balance)
    EXPECT_NEAR(balance, 1.0, 0.03);
}

// --- piston relaxation -----------------------------------------------------------------

TEST_P(Contract, PistonRelaxesToImposedPressure) {
  const Case c = GetParam();
  if (c.kind == Kind::kVolume)
    GTEST_SKIP() << "no piston at constant volume";
  // Start dilute (phi = 0.5, P_hat << P): the piston compresses to the steady state.
  const std::string scene =
      "[system]\nN = 128\nphi = 0.5\nseed = 9\n[ensemble]\nkind = \"constant_pressure\"\n"
      "pressure = 1e-2\nxi_V = 1e-3\n[shear]\nrate = 1e-2\n" +
      integrator_toml(c.config, c.config.steady_dt) +
      "[run]\nt_eq = 400.0\nt_av = 1200.0\nsample_every = 1.0\nthreads = 1\n";
  const RunSpec spec = parse_run_spec(Scene::parse(scene, "piston.toml"));
  RunOptions opt;
  opt.quiet = true;
  const ReplicaResult r = run_replica(spec, spec.seed, opt);
  ASSERT_TRUE(r.status.is_complete()) << r.status.text();
  const Summary& v = r.summary;
  // Euler's piston satisfies <P_hat> - P = xi_V Delta V / T exactly at its step states, and
  // second-order RESPA nearly so. First-order RESPA samples P_hat right after a piston half-step,
  // an O(dt) bias (+0.14% here; +6% at J = 10, dt = 1, studies/ensemble/README.md): allowed
  // 0.5% of P on top of the statistical 4 standard errors.
  auto integ = make(c.config, c.config.steady_dt);
  const bool first_order_respa = integ->name() == "respa" && integ->order(*spec.ensemble) == 1;
  const double allowance = first_order_respa ? 5e-3 * 1e-2 : 0.0;
  EXPECT_LT(std::abs(v.pressure.value - 1e-2), 4.0 * v.pressure.err + allowance)
      << v.pressure.value << " +- " << v.pressure.err;
  // The volume moved far from its start (phi 0.5 -> above 0.55) and has converged: the two
  // halves of the window differ by less than a tenth of that relaxation. (A 4-sigma test on the
  // halves' block errors failed in one build: 10 blocks of 60 tau underestimate the error of
  // the slowly correlated volume.)
  const auto& ss = r.series.samples;
  EXPECT_GT(ss.back().phi, 0.55);
  std::vector<double> first, second;
  for (const auto& s : ss) {
    if (s.time <= spec.t_eq)
      continue;
    (s.time <= spec.t_eq + 0.5 * spec.t_av ? first : second).push_back(s.volume);
  }
  const BlockAverage b1 = block_average(first, 10), b2 = block_average(second, 10);
  const double relaxation = std::abs(ss.front().volume - 0.5 * (b1.mean + b2.mean));
  EXPECT_LT(std::abs(b1.mean - b2.mean), 0.1 * relaxation)
      << b1.mean << " vs " << b2.mean << " after relaxing by " << relaxation;
}

// --- a volume that would become negative -------------------------------------------------------

TEST_P(Contract, NegativeVolumeThrowsNamingTheVolume) {
  const Case c = GetParam();
  if (c.kind == Kind::kVolume)
    GTEST_SKIP() << "no piston at constant volume";
  // No contacts and P / xi_V = 1e5: one step of 0.1 (or its half) would take V = 1000 below 0.
  const ConstantPressure ens(1e-3, 10.0, 1e-4);
  Model m(two_spheres(3.0, 1000.0), ModelOptions{2.0, 0.3, 1, 0});
  auto integ = make(c.config, step(c.config, 0.1, 1e-4));
  try {
    integ->advance(m, ens, 1.0);
    FAIL() << "no IntegrationError";
  } catch (const IntegrationError& e) {
    EXPECT_NE(std::string(e.what()).find("volume"), std::string::npos) << e.what();
  }
}

TEST_P(Contract, NegativeVolumeLeavesOnlyPartialFile) {
  const Case c = GetParam();
  if (c.kind == Kind::kVolume)
    GTEST_SKIP() << "no piston at constant volume";
  const fs::path dir = fs::temp_directory_path() /
                       ("jamflow-contract-" + std::to_string(::getpid()) + "-" + c.config.label);
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string file = (dir / "collapse.h5").string();
  const std::string scene =
      "[system]\nN = 64\nphi = 0.3\nseed = 2\n[ensemble]\nkind = \"constant_pressure\"\n"
      "pressure = 10.0\nxi_V = 1e-4\n[shear]\nrate = 1e-3\n" +
      integrator_toml(c.config, step(c.config, 0.1, 1e-4)) +
      "[run]\nt_eq = 1.0\nt_av = 20.0\nsample_every = 1.0\nthreads = 1\n[output]\nfile = \"" +
      file + "\"\n";
  const RunSpec spec = parse_run_spec(Scene::parse(scene, "collapse.toml"));
  RunOptions opt;
  opt.quiet = true;
  ::testing::internal::CaptureStderr();
  const int rc = run_and_write(spec, opt);
  const std::string err = ::testing::internal::GetCapturedStderr();
  EXPECT_NE(rc, 0);
  EXPECT_NE(err.find("volume"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(file));
  ASSERT_TRUE(fs::exists(file + ".part"));
  H5Reader h(file + ".part");
  const std::string status = h.attr_string("/", "status");
  EXPECT_NE(status.find("volume"), std::string::npos) << status;
  fs::remove_all(dir);
}

// The adaptive integrators' dry-run cost grows with the contact stiffness below alpha_r = 2,
// (alpha_r - 1) delta^(alpha_r - 2) at the typical overlap delta = P^(1 / (alpha_r - 1)): more at
// alpha_r = 1.5 than at 2 by more than 10x where delta = 1e-6 (P = 1e-3), and more the smaller
// the overlap (the measured points are in cvode.cpp and rkc.cpp).
TEST(CostEstimate, AdaptiveCostGrowsWithContactStiffnessBelowHarmonic) {
  const ConstantPressure ens(0.1, 1e-3, 5e-4);
  int adaptive = 0;
  for (const std::string& kind : integrator_kinds()) {
    // Each kind at its defaults (RKC's atol in units of delta); one that needs a step is a
    // fixed-step integrator, whose cost is the same at every alpha_r.
    const Scene scene = Scene::parse("[integrator]\nkind = \"" + kind + "\"\n", "cost.toml");
    ConfigSection sec = scene.section("integrator");
    std::unique_ptr<Integrator> integ;
    try {
      integ = make_integrator(sec);
    } catch (const ConfigError&) {
      continue;
    }
    if (!std::isnan(integ->force_passes_per_time(ens)))
      continue;
    ++adaptive;
    const auto cost = [&](double alpha, double pressure) {
      Integrator::CostPoint at;
      at.alpha = alpha;
      at.pressure = pressure;
      at.shear_rate = 0.1 * pressure;
      return integ->cpu_seconds_per_particle_time(ens, at);
    };
    EXPECT_GT(cost(1.5, 1e-3), 10.0 * cost(2.0, 1e-3)) << kind;
    EXPECT_GT(cost(1.5, 1e-3) / cost(2.0, 1e-3), cost(1.5, 1e-1) / cost(2.0, 1e-1)) << kind;
    EXPECT_GT(cost(1.75, 1e-3), cost(2.0, 1e-3)) << kind;
    EXPECT_LT(cost(1.75, 1e-3), cost(1.5, 1e-3)) << kind;
  }
  EXPECT_GE(adaptive, 2);  // CVODE and RKC
}

INSTANTIATE_TEST_SUITE_P(AllIntegratorsAllEnsembles, Contract, ::testing::ValuesIn(all_cases()),
                         case_name);

}  // namespace
}  // namespace jamflow
