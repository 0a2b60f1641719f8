// The staged-run framework of the studies (framework/stage.hpp run_stage), once, on a toy
// study of two stages defined by its requests alone: a preparation, then two runs that continue
// from its final state. --dry-run counts both stages and runs nothing; the run reads every point
// back; a rerun finds them and redoes none; the admission rule leaves the run whose blocks are
// shorter than 2 tau out, and says why. The eight studies rely on this and need not test it
// again each.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "framework/stage.hpp"
#include "tests/studies/jamflow_exe.hpp"

namespace jamflow::studies {
namespace {

// The toy state point: 64 harmonic spheres at phi = 0.6 under shear, explicit Euler at dt = 0.05,
// the window [t_eq, t_eq + t_av] sampled every 1.
std::string toy_scene(double t_eq, double t_av) {
  return "[system]\nN = 64\nphi = 0.6\nseed = 5\n[ensemble]\nkind = \"constant_volume\"\n"
         "[shear]\nrate = 0.01\n[integrator]\nkind = \"euler\"\ndt = 0.05\n[run]\nt_eq = " +
         std::to_string(t_eq) + "\nt_av = " + std::to_string(t_av) + "\nsample_every = 1.0\n";
}

struct ToyStudy {
  std::vector<DiagnosedRun> prep, main;
  std::optional<int> prep_status, main_status;
};

// The toy study's plan: stage "prep" (one run from a random state), stage "main" (a short and a
// long run from the prepared state: blocks of 1 tau_0, and of 1000 tau_0, several times the
// correlation time of sigma_xy here, which was 10-200 tau_0 in runs of this point).
ToyStudy run_toy(const StudyOptions& o) {
  ToyStudy t;
  RunRequest prep;
  prep.label = "prep";
  prep.scene = toy_scene(200.0, 100.0);
  prep.seed = 5;
  prep.window = false;
  t.prep_status = run_stage("toy", "prep", {prep}, o, t.prep, false);
  if (t.prep_status)
    return t;
  std::vector<RunRequest> main;
  for (const auto& [label, t_av] : {std::pair{"short", 20.0}, std::pair{"long", 20000.0}}) {
    RunRequest r;
    r.label = label;
    r.scene = toy_scene(20.0, t_av);
    r.seed = 5;
    r.init = t.prep.front().final_xyz;
    r.window = false;
    main.push_back(std::move(r));
  }
  t.main_status = run_stage("toy", "main", main, o, t.main, true);
  return t;
}

TEST(StageFramework, ToyStudyDryRunRunResumeAndAdmission) {
  use_test_jamflow();
  // The portable kernel: the same bits on every machine, so that the verdicts below do not
  // depend on the machine's vector unit.
  ::setenv("JAMFLOW_KERNEL", "portable", 1);
  StudyOptions o;
  o.out_dir = ::testing::TempDir() + "jamflow_toy_study";
  std::filesystem::remove_all(o.out_dir);
  o.quiet = true;
  o.jobs = 2;

  // --dry-run: both stages counted (the second from a stand-in start), nothing run.
  o.dry_run = true;
  const ToyStudy dry = run_toy(o);
  EXPECT_FALSE(dry.prep_status.has_value());  // a stage before the last goes on to the next
  ASSERT_EQ(dry.prep.size(), 1u);
  EXPECT_EQ(dry.prep.front().final_xyz, kCountedStart);
  ASSERT_TRUE(dry.main_status.has_value());
  EXPECT_EQ(*dry.main_status, 0);
  EXPECT_TRUE(point_files(o.out_dir).empty());

  // The run: both stages, every point read back from its file.
  o.dry_run = false;
  const ToyStudy run = run_toy(o);
  ASSERT_FALSE(run.prep_status.has_value());
  ASSERT_TRUE(run.prep.front().result.status.is_complete()) << run.prep.front().verdict_text();
  ASSERT_FALSE(run.main_status.has_value());
  ASSERT_EQ(run.main.size(), 2u);
  for (const DiagnosedRun& d : run.main) {
    EXPECT_TRUE(d.result.status.is_complete()) << d.label << ": " << d.verdict_text();
    EXPECT_EQ(d.n, 64);
  }
  const auto files = point_files(o.out_dir);
  EXPECT_EQ(files.size(), 3u);

  // A rerun finds every point: no file is written again, and the numbers are the same.
  const ToyStudy again = run_toy(o);
  ASSERT_FALSE(again.main_status.has_value());
  EXPECT_EQ(point_files(o.out_dir), files);
  for (std::size_t k = 0; k < 2; ++k)
    EXPECT_EQ(again.main[k].result.summary.sigma_xy.value,
              run.main[k].result.summary.sigma_xy.value);

  // Admission: the short run (20 blocks of 1 tau_0, just after its start) is left out, as not
  // steady or as correlated (blocks shorter than 2 tau with one replica), with why; the long one
  // is in.
  const DiagnosedRun& short_run = run.main[0];
  const DiagnosedRun& long_run = run.main[1];
  EXPECT_TRUE(short_run.cls.verdict == Verdict::kCorrelated ||
              short_run.cls.verdict == Verdict::kNotSteady)
      << short_run.verdict_text();
  EXPECT_EQ(long_run.cls.verdict, Verdict::kStable) << long_run.verdict_text();
  const std::string section = excluded_section({&short_run, &long_run});
  EXPECT_NE(section.find("- short: " + short_run.verdict_text()), std::string::npos) << section;
  EXPECT_EQ(section.find("- long:"), std::string::npos) << section;
  std::filesystem::remove_all(o.out_dir);
  ::unsetenv("JAMFLOW_KERNEL");
}

// A scene the engine rejects is not run: its diagnosed run says "not available".
TEST(StageFramework, RejectedSceneIsNotAvailable) {
  RunRequest req;
  req.label = "cvode";
  req.scene = R"([system]
N = 20
phi = 0.5
[ensemble]
kind = "constant_volume"
[shear]
rate = 1e-3
[integrator]
kind = "euler"
dt = -1.0
[run]
t_eq = 1
t_av = 20
sample_every = 1
)";
  StudyOptions o;
  o.out_dir = ::testing::TempDir() + "jamflow_rejected_scene";
  o.quiet = true;
  std::vector<DiagnosedRun> out;
  // Nothing to run: the stage returns at once, without the jamflow binary.
  EXPECT_FALSE(run_stage("test", "only", {req}, o, out, true).has_value());
  ASSERT_EQ(out.size(), 1u);
  const DiagnosedRun& d = out.front();
  EXPECT_EQ(d.cls.verdict, Verdict::kNotAvailable);
  EXPECT_NE(d.verdict_text().find("not available"), std::string::npos);
}

}  // namespace
}  // namespace jamflow::studies
