// The verdicts every run gets (steady, stable, decorrelated), --strict, and the scene checks made
// before anything runs (dt against sample_every, steps and memory up front).
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>

#include "driver/run.hpp"
#include "driver/verdicts.hpp"
#include "lib/error.hpp"

namespace jamflow {
namespace {

std::string scene(const std::string& ensemble, double phi, double gdot, double dt, double t_eq,
                  double t_av, double sample_every = 1.0) {
  return "[system]\nN = 200\nphi = " + std::to_string(phi) + "\nseed = 4\n[ensemble]\n" + ensemble +
         "\n[shear]\nrate = " + std::to_string(gdot) +
         "\n[integrator]\nkind = \"euler\"\ndt = " + std::to_string(dt) +
         "\n[run]\nt_eq = " + std::to_string(t_eq) + "\nt_av = " + std::to_string(t_av) +
         "\nsample_every = " + std::to_string(sample_every) + "\nthreads = 1\n";
}

const char* const kVolume = "kind = \"constant_volume\"";

RunSpec spec_of(const std::string& text, const std::vector<std::string>& sets = {}) {
  Scene s = Scene::parse(text, "test.toml");
  for (const auto& a : sets)
    s.set(a);
  return parse_run_spec(s);
}

std::string config_error(const std::string& text, const std::vector<std::string>& sets = {});

Summary run(const RunSpec& spec) {
  RunOptions opt;
  opt.quiet = true;
  const ReplicaResult r = run_replica(spec, spec.seed, opt);
  EXPECT_TRUE(r.status.is_complete()) << r.status.text();
  return r.summary;
}

// A verdict round-trips through its run-file text, and older texts read as what they say.
TEST(Verdicts, TextRoundTrip) {
  for (const Verdict& v : {Verdict::pass(), Verdict::fail("phi drifts"), Verdict::not_checked("no"),
                           Verdict::not_checked("")}) {
    EXPECT_EQ(Verdict::parse(v.text()), v) << v.text();
  }
  EXPECT_EQ(Verdict::fail("x: y").text(), "fail: x: y");
  EXPECT_EQ(Verdict::not_checked("").text(), "not checked");
  EXPECT_TRUE(Verdict::parse("pass").passed());
  EXPECT_EQ(Verdict::parse("fail: blocks too short").why, "blocks too short");
  EXPECT_FALSE(Verdict::parse("failed").failed());  // not a verdict's text: not checked
  EXPECT_EQ(Verdict::parse("failed").why, "failed");
  EXPECT_EQ(Verdict::pass().value(), 1.0);
  EXPECT_EQ(Verdict::fail("x").value(), 0.0);
  EXPECT_TRUE(std::isnan(Verdict::not_checked("x").value()));
}

// The run file's status texts, written before the type, read back as the same kind and detail,
// and written again unchanged.
TEST(RunStatus, TheFileTextsRoundTrip) {
  struct Case {
    const char* text;
    RunStatus::Kind kind;
    const char* detail;
  };
  for (const Case& c : {
           Case{"complete", RunStatus::Kind::kComplete, ""},
           Case{"running", RunStatus::Kind::kRunning, ""},
           Case{"interrupted at t = 2285.46 by SIGTERM", RunStatus::Kind::kInterrupted,
                "at t = 2285.46 by SIGTERM"},
           Case{"failed at t = 12: forces became non-finite", RunStatus::Kind::kFailed,
                "at t = 12: forces became non-finite"},
           Case{"budget: stopped at t = 3 after 300 force-pass equivalents",
                RunStatus::Kind::kBudget, "stopped at t = 3 after 300 force-pass equivalents"},
           Case{"not run", RunStatus::Kind::kNotRun, ""},
           Case{"aborted: jamflow: error: cell too small", RunStatus::Kind::kAborted,
                "jamflow: error: cell too small"},
           Case{"unreadable: cannot open", RunStatus::Kind::kUnreadable, "cannot open"},
       }) {
    const RunStatus s = RunStatus::parse(c.text);
    EXPECT_EQ(s.kind, c.kind) << c.text;
    EXPECT_EQ(s.detail, c.detail) << c.text;
    EXPECT_EQ(s.text(), c.text);
  }
  // Text that names no kind is unreadable, and says what it was; a longer word is not a kind.
  EXPECT_EQ(RunStatus::parse("").kind, RunStatus::Kind::kUnreadable);
  EXPECT_EQ(RunStatus::parse("completed").kind, RunStatus::Kind::kUnreadable);
  EXPECT_NE(RunStatus::parse("completed").detail.find("completed"), std::string::npos);
  EXPECT_TRUE(RunStatus::budget("x").is_finished());
  EXPECT_FALSE(RunStatus::interrupted("x").is_finished());
}

TEST(TrendT, SeesALineAndNotNoise) {
  std::vector<double> line(20), flat(20, 3.0), noise(20);
  std::mt19937 rng(1);
  std::normal_distribution<double> g(0.0, 1.0);
  for (int k = 0; k < 20; ++k) {
    line[k] = 1.0 + 0.01 * k + 0.001 * g(rng);
    noise[k] = 5.0 + g(rng);
  }
  EXPECT_GT(trend_t(line), 50.0);
  EXPECT_EQ(trend_t(flat), 0.0);
  EXPECT_LT(std::abs(trend_t(noise)), 4.0);
  EXPECT_TRUE(std::isnan(trend_t({1.0, 2.0})));
  // The false-alarm rate at |t| > 4 for independent Gaussian blocks (t with 18 degrees of
  // freedom: p = 8e-4): at most 5 of 2000 noise series (expected 1.7; P(> 5) < 1%).
  int alarms = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    for (auto& x : noise)
      x = g(rng);
    alarms += std::abs(trend_t(noise)) > 4.0;
  }
  EXPECT_LE(alarms, 5);
}

// A healthy run: dt = 0.1 (well inside Euler's stability edge, dt ~ 0.41 here), blocks of 100
// against tau_sigma_xy of a few tau at gdot = 1e-2, and a window that starts after the transient.
TEST(Verdicts, PassAHealthyRun) {
  const Summary s = run(spec_of(scene(kVolume, 0.62, 1e-2, 0.1, 500.0, 2000.0)));
  EXPECT_TRUE(s.stable.passed()) << s.stable.text();
  EXPECT_TRUE(s.steady.passed()) << s.steady.text();
  EXPECT_TRUE(s.decorrelated.passed()) << s.decorrelated.text();
  EXPECT_FALSE(s.failed());
  EXPECT_GT(*s.force_step_correlation, 0.99);
  for (const auto& w : s.warnings)
    ADD_FAILURE() << "unexpected warning: " << w;
}

// dt = 0.5 is past Euler's stability edge: a period-2 oscillation takes most of the force power
// and the energy balance collapses (0.12 at N = 200, where the dissipation is inflated).
TEST(Verdicts, FlagAnUnstableRun) {
  const Summary s = run(spec_of(scene(kVolume, 0.62, 1e-3, 0.5, 100.0, 1000.0)));
  EXPECT_TRUE(s.stable.failed()) << s.stable.text();
  EXPECT_EQ(s.stable.value(), 0.0);
  EXPECT_LT(*s.force_step_correlation, 0.0);
  EXPECT_LT(s.energy_balance_corrected.value, 0.5);
  std::size_t lines = 0;
  for (const auto& w : s.warnings)
    lines += w.rfind("not stable: ", 0) == 0;
  EXPECT_EQ(lines, 1u);
}

// Compressed from phi = 0.45 at an imposed pressure with no equilibration: phi still rises
// through the averaging window.
TEST(Verdicts, FlagAStatePointThatIsStillDrifting) {
  const Summary s = run(spec_of(scene("kind = \"constant_pressure\"\npressure = 1e-3\nxi_V = 1",
                                      0.45, 1e-3, 0.1, 0.0, 200.0)));
  EXPECT_TRUE(s.steady.failed());
  EXPECT_EQ(s.steady.why.rfind("phi drifts from", 0), 0u) << s.steady.why;
  EXPECT_GT(s.trend_t_phi, 4.0);
  EXPECT_TRUE(s.failed());
}

// A summary value that is not a number fails its verdict. A window of samples with no contacts
// (sigma_xy = P = D = 0): mu = 0 / 0 and the energy balance 0 / 0 are NaN, J = gdot / 0 is inf.
// Before, steady and stable passed (NaN slips through every test written as !(x > limit)),
// stable on the step-to-step correlation alone.
TEST(Verdicts, NonFiniteValuesFailTheirVerdicts) {
  const RunSpec spec = spec_of(scene(kVolume, 0.62, 1e-3, 0.1, 0.0, 40.0));
  Series series;
  for (int k = 0; k <= 40; ++k)
    series.samples.push_back(Sample{double(k), 1e-3 * k, 1e3, 1e-9, 0.0, 0.0, 0.0, 0.0, 0.0});
  StepPairs steps;
  steps.cross = steps.norm = 1.0;
  steps.pairs = 10;
  const Summary s = summarize(spec, series, &steps);
  EXPECT_TRUE(std::isnan(s.mu.value));
  EXPECT_TRUE(std::isinf(*s.J));
  ASSERT_TRUE(s.steady.failed());
  const std::string steady = s.steady.text();
  EXPECT_EQ(steady.rfind("fail: ", 0), 0u) << steady;
  EXPECT_NE(steady.find("mu = "), std::string::npos) << steady;
  EXPECT_NE(steady.find("J = inf"), std::string::npos) << steady;
  EXPECT_NE(steady.find("not finite"), std::string::npos) << steady;
  ASSERT_TRUE(s.stable.failed());
  const std::string stable = s.stable.text();
  EXPECT_EQ(stable.rfind("fail: energy balance = ", 0), 0u) << stable;
  EXPECT_NE(stable.find("not finite"), std::string::npos) << stable;
  EXPECT_EQ(s.steady.value(), 0.0);
  EXPECT_EQ(s.stable.value(), 0.0);
  EXPECT_TRUE(s.failed());

  // The same from a run: phi = 1e-9 has no contacts.
  RunOptions opt;
  opt.quiet = true;
  const RunSpec dilute = spec_of(scene(kVolume, 0.6, 1e-3, 0.1, 0.0, 20.0), {"system.phi=1e-9"});
  const ReplicaResult r = run_replica(dilute, 1, opt);
  ASSERT_TRUE(r.status.is_complete()) << r.status.text();
  EXPECT_TRUE(r.summary.steady.failed()) << r.summary.steady.text();
  EXPECT_TRUE(r.summary.stable.failed()) << r.summary.stable.text();
}

// t_av = "auto" at gdot = 1e-2, N = 200: eta's relative block error falls below 2% within a few
// thousand tau (about 1.4% at t_av = 900 on this seed); a target of 1e-4 would need ~1e8 tau,
// so the run stops at max_time and says so.
TEST(AutoLength, TavReachesItsTargetOrStopsAtMaxTime) {
  const std::string base = scene(kVolume, 0.62, 1e-2, 0.1, 200.0, 10.0);
  const RunSpec reach =
      spec_of(base, {"run.t_av=\"auto\"", "run.target_error=0.02", "run.max_time=20000.0"});
  const Summary a = run(reach);
  EXPECT_EQ(a.run_length.value_or("").rfind("target reached: relative error of eta", 0), 0u)
      << a.run_length.value_or("");
  EXPECT_LE(a.eta->err / a.eta->value, 0.02);
  EXPECT_TRUE(a.decorrelated.passed()) << a.decorrelated.text();
  EXPECT_LT(*a.t_eq + *a.t_av, 20000.0);
  const RunSpec out_of_reach =
      spec_of(base, {"run.t_av=\"auto\"", "run.target_error=1e-4", "run.max_time=1500.0"});
  const Summary b = run(out_of_reach);
  EXPECT_EQ(b.run_length.value_or("").rfind("max_time reached: relative error of eta", 0), 0u)
      << b.run_length.value_or("");
  EXPECT_DOUBLE_EQ(*b.t_eq + *b.t_av, 1500.0);
  bool warned = false;
  for (const auto& w : b.warnings)
    warned = warned || w.rfind("t_av = \"auto\": max_time reached", 0) == 0;
  EXPECT_TRUE(warned);
  // The keys belong together.
  EXPECT_NE(config_error(base, {"run.target_error=0.01"}).find("used only with [run] t_av = "),
            std::string::npos);
  EXPECT_NE(config_error(base, {"run.t_av=\"long\""}).find("or \"auto\""), std::string::npos);
}

// t_eq = "auto" from a random start at constant volume: P_hat relaxes from 0.074 (the random
// overlaps) to 0.010 within about 50 tau at gdot = 1e-2. MSER-5 puts the transient's end there
// (51 on this seed), and the window of t_av after it is steady.
TEST(AutoLength, TeqFindsTheEndOfTheStartUpTransient) {
  const RunSpec spec = spec_of(scene(kVolume, 0.62, 1e-2, 0.1, 0.0, 1500.0), {"run.t_eq=\"auto\""});
  const Summary s = run(spec);
  EXPECT_GT(*s.t_eq, 10.0);
  EXPECT_LT(*s.t_eq, 300.0);
  EXPECT_EQ(s.t_eq_method.value_or("").rfind("MSER-5", 0), 0u);
  EXPECT_GE(*s.t_av, 1500.0 - 1e-9);
  EXPECT_TRUE(s.steady.passed()) << s.steady.text();
}

std::string config_error(const std::string& text, const std::vector<std::string>& sets) {
  try {
    spec_of(text, sets);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "no error";
}

TEST(SceneChecks, DtIsNeverChangedSilently) {
  const std::string base = scene(kVolume, 0.6, 1e-3, 0.1, 10.0, 40.0);
  EXPECT_EQ(config_error(base, {"integrator.dt=0.3"}),
            "[run] sample_every = 1 is not a whole number of [integrator] dt = 0.3 (3.33333 "
            "steps); allowed multiples of dt, such as 0.9, or set [run] round_sample_every = true");
  EXPECT_NE(config_error(base, {"integrator.dt=100"}).find("(0.01 steps)"), std::string::npos);
  // A sampling interval far below dt (the ETA of 2025 hours) is the same error.
  EXPECT_NE(config_error(base, {"run.sample_every=1e-9"})
                .find("[run] sample_every = 1e-09 is not a whole number of [integrator] dt"),
            std::string::npos);
  // Asked for: sample_every becomes 3 steps, dt stays, and the stored scene says so.
  const RunSpec r = spec_of(base, {"integrator.dt=0.3", "run.round_sample_every=true"});
  EXPECT_EQ(r.sample_every, 3 * 0.3);
  EXPECT_EQ(r.make_integrator()->nominal_dt(), 0.3);
  const Scene stored = Scene::parse(r.scene_text, "stored");
  EXPECT_EQ(stored.section("run").number("sample_every", Range::positive()), 3 * 0.3);
}

TEST(SceneChecks, RunsThatCannotEndOrFitAreRefusedUpFront) {
  const std::string base = scene(kVolume, 0.6, 1e-3, 0.1, 10.0, 40.0);
  EXPECT_NE(config_error(base, {"integrator.dt=1e-300"}).find("steps per replica"),
            std::string::npos);
  EXPECT_NE(config_error(base, {"system.N=134217727"}).find("GB of memory; this machine has"),
            std::string::npos);
  // A dilute cell runs: the cell grid is sized by the particles, not by the volume.
  const RunSpec dilute = spec_of(base, {"system.phi=1e-9", "run.t_eq=0.0", "run.t_av=20.0"});
  RunOptions opt;
  opt.quiet = true;
  EXPECT_TRUE(run_replica(dilute, 1, opt).status.is_complete());
}

TEST(SceneChecks, StrictTurnsAFailedVerdictIntoExitStatus3) {
  const auto dir =
      std::filesystem::temp_directory_path() / ("jamflow-strict-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string toml = (dir / "u.toml").string();
  std::ofstream(toml) << scene(kVolume, 0.62, 1e-3, 0.5, 100.0, 1000.0) + "[output]\nfile = \"" +
                             (dir / "u.h5").string() + "\"\n";
  const std::string cmd = std::string(JAMFLOW_CLI) + " run -q " + toml;
  EXPECT_EQ(WEXITSTATUS(std::system((cmd + " > /dev/null 2>&1").c_str())), 0);
  EXPECT_EQ(WEXITSTATUS(std::system((cmd + " --force --strict > /dev/null 2>&1").c_str())), 3);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace jamflow
