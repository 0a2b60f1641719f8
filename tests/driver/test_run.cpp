// The run driver end to end: steady-state energy balance, reproducibility, the HDF5 layout,
// scene validation, and what a failed run leaves behind.
#include <gtest/gtest.h>
#include <hdf5.h>

#include <unistd.h>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "driver/checkpoint.hpp"
#include "driver/run.hpp"
#include "lib/error.hpp"
#include "lib/forces.hpp"
#include "lib/h5.hpp"
#include "lib/xyz.hpp"
#include "tests/driver/temp_dir.hpp"

namespace jamflow {
namespace {

namespace fs = std::filesystem;

// Each test's files in a directory of its own.
class TempDir : public testing_support::TempDir {
 public:
  TempDir() : testing_support::TempDir("jamflow-run-") {}
};

std::string scene_text(int n, double phi, double rate, double dt, double t_eq, double t_av,
                       const std::string& extra_run = "") {
  return "[system]\nN = " + std::to_string(n) + "\nphi = " + std::to_string(phi) +
         "\nseed = 3\n[ensemble]\nkind = \"constant_volume\"\n[shear]\nrate = " +
         std::to_string(rate) + "\n[integrator]\nkind = \"euler\"\ndt = " + std::to_string(dt) +
         "\n[run]\nt_eq = " + std::to_string(t_eq) + "\nt_av = " + std::to_string(t_av) +
         "\nsample_every = 1.0\nthreads = 1\n" + extra_run;
}

RunSpec spec_of(const std::string& text, const std::vector<std::string>& sets = {}) {
  Scene s = Scene::parse(text, "test.toml");
  for (const auto& a : sets)
    s.set(a);
  return parse_run_spec(s);
}

// SPEC §3: in the steady state at constant volume <sigma_xy> gdot V = <D>. At dt = 0.1 the
// discretisation bias is far below 1% (SPEC §4 measured 1.00 within 0.7% up to dt = 0.3); the
// 2% tolerance covers the statistical error of a window of 2 strain units at N = 200.
TEST(Run, SteadyStateEnergyBalance) {
  const RunSpec spec = spec_of(scene_text(200, 0.62, 1e-3, 0.1, 1000.0, 2000.0));
  RunOptions opt;
  opt.quiet = true;
  const ReplicaResult r = run_replica(spec, spec.seed, opt);
  ASSERT_TRUE(r.status.is_complete()) << r.status.text();
  const Summary& v = r.summary;
  EXPECT_NEAR(v.energy_balance, 1.0, 0.02);
  EXPECT_GT(v.sigma_xy.value, 0.0);  // sigma_xy gdot >= 0
  EXPECT_GT(v.pressure.value, 0.0);
  EXPECT_NEAR(v.phi.value, 0.62, 1e-12);
  EXPECT_NEAR(v.eta->value, v.sigma_xy.value / 1e-3, 1e-9 * v.eta->value);
  EXPECT_NEAR(v.mu.value, v.sigma_xy.value / v.pressure.value, 1e-3 * v.mu.value);
  EXPECT_NEAR(*v.J, 1e-3 / v.pressure.value, 1e-12);
}

TEST(Run, SameSceneAndSeedGiveBitwiseIdenticalSeries) {
  const RunSpec spec = spec_of(scene_text(300, 0.63, 1e-2, 0.1, 20.0, 40.0));
  RunOptions opt;
  opt.quiet = true;
  const ReplicaResult a = run_replica(spec, 7, opt);
  const ReplicaResult b = run_replica(spec, 7, opt);
  ASSERT_EQ(a.series.samples.size(), b.series.samples.size());
  for (std::size_t k = 0; k < a.series.samples.size(); ++k) {
    const Sample& x = a.series.samples[k];
    const Sample& y = b.series.samples[k];
    ASSERT_EQ(std::memcmp(&x, &y, sizeof(Sample)), 0) << "sample " << k;
  }
  const ReplicaResult c = run_replica(spec, 8, opt);  // another seed: another run
  EXPECT_NE(a.series.samples.back().sigma_xy, c.series.samples.back().sigma_xy);
}

TEST(Run, ThreadCountChangesOnlyRoundOff) {
  RunSpec one = spec_of(scene_text(1000, 0.63, 1e-2, 0.1, 2.0, 4.0, "blocks = 2\n"));
  RunSpec two =
      spec_of(scene_text(1000, 0.63, 1e-2, 0.1, 2.0, 4.0, "blocks = 2\n"), {"run.threads=2"});
  RunOptions opt;
  opt.quiet = true;
  const ReplicaResult a = run_replica(one, 1, opt);
  const ReplicaResult b = run_replica(two, 1, opt);
  // 60 steps of a contracting dynamics: round-off stays at round-off level.
  for (std::size_t k = 0; k < a.series.samples.size(); ++k) {
    EXPECT_NEAR(a.series.samples[k].pressure, b.series.samples[k].pressure,
                1e-9 * std::abs(a.series.samples[k].pressure));
  }
}

TEST(Run, WritesTheDocumentedHdf5Layout) {
  TempDir dir;
  const std::string out = dir.file("run.h5");
  RunSpec spec =
      spec_of(scene_text(64, 0.55, 1e-3, 0.1, 5.0, 20.0), {"output.file=\"" + out + "\""});
  RunOptions opt;
  opt.quiet = true;
  ASSERT_EQ(run_and_write(spec, opt), 0);
  ASSERT_TRUE(fs::exists(out));
  EXPECT_FALSE(fs::exists(out + ".part"));
  H5Reader h(out);
  const std::vector<std::string> series = {"time",     "strain",   "volume", "phi",
                                           "pressure", "sigma_xy", "energy", "dissipation"};
  for (const auto& name : series) {
    const auto v = h.read_doubles("/timeseries/" + name);
    EXPECT_EQ(v.size(), 26u) << name;  // t = 0, 1, ..., 25
  }
  EXPECT_EQ(h.read_doubles("/timeseries/time").front(), 0.0);
  EXPECT_DOUBLE_EQ(h.attr_double("/timeseries", "t_eq"), 5.0);
  for (const char* a : {"sigma_xy", "sigma_xy_err", "pressure", "pressure_err", "phi", "phi_err",
                        "eta", "eta_err", "mu", "mu_err", "J", "energy_balance"}) {
    EXPECT_TRUE(std::isfinite(h.attr_double("/summary", a))) << a;
  }
  EXPECT_EQ(h.dims("/final/positions"), (std::vector<std::size_t>{64, 3}));
  EXPECT_EQ(h.dims("/final/diameters"), (std::vector<std::size_t>{64}));
  EXPECT_EQ(h.dims("/final/cell"), (std::vector<std::size_t>{3, 3}));
  EXPECT_NEAR(h.attr_double("/final", "strain"), 25.0 * 1e-3, 1e-12);
  // Cell rows are lattice vectors: b = (strain L, L, 0) for this small strain.
  const auto cell = h.read_doubles("/final/cell");
  EXPECT_NEAR(cell[3], 25e-3 * cell[4], 1e-12);
  for (const char* a : {"scene", "version", "git_commit", "created"}) {
    EXPECT_FALSE(h.attr_string("/", a).empty()) << a;
  }
  EXPECT_NE(h.attr_string("/", "scene").find("rate = 0.001"), std::string::npos);
  // Provenance of the force pass: the backend and target this machine gave, and the default of
  // one thread.
  const ForceField field(spec.alpha, 1);
  EXPECT_EQ(h.attr_string("/", "kernel"), field.kernel());
  EXPECT_EQ(h.attr_string("/", "kernel_target"), field.target());
  EXPECT_EQ(h.attr_int("/", "threads"), 1);
  // The final configuration is also an extended XYZ file that reads back to the same cell.
  const State fin = read_xyz(dir.file("run.final.xyz"));
  EXPECT_EQ(fin.size(), 64u);
  EXPECT_NEAR(fin.box.strain, 25e-3, 1e-12);
}

// The scene at constant pressure P with piston friction xi_V instead of constant volume.
std::string with_piston(std::string text, double pressure, double xi_v) {
  const std::string nvt = "kind = \"constant_volume\"";
  text.replace(text.find(nvt), nvt.size(),
               "kind = \"constant_pressure\"\npressure = " + std::to_string(pressure) +
                   "\nxi_V = " + std::to_string(xi_v));
  return text;
}

// run_and_write of the scene into `out`, quietly: its exit status and what it wrote to stderr.
std::pair<int, std::string> run_quietly(const std::string& text, const std::string& out) {
  const RunSpec spec = spec_of(text, {"output.file=\"" + out + "\""});
  RunOptions opt;
  opt.quiet = true;
  testing::internal::CaptureStderr();
  const int rc = run_and_write(spec, opt);
  return {rc, testing::internal::GetCapturedStderr()};
}

TEST(Run, DivergingRunKeepsOnlyAPartialFileThatSaysSo) {
  TempDir dir;
  const std::string out = dir.file("bad.h5");
  // A stiff piston far from balance: xi_V dV/dt = P_hat - P with P = 0.1, xi_V = 1e-6 asks
  // for dV = -1e5 dt, so the first step of dt = 1 would make the volume negative. (Explicit
  // Euler at a huge dt on the particles alone does not go non-finite: the contact forces have
  // compact support, so unstable modes scatter particles instead of growing without bound.)
  const auto [rc, err] =
      run_quietly(with_piston(scene_text(200, 0.6, 1e-3, 1.0, 20.0, 40.0), 0.1, 1e-6), out);
  EXPECT_EQ(rc, 1);
  EXPECT_NE(err.find("volume became"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(out));
  ASSERT_TRUE(fs::exists(out + ".part"));
  H5Reader h(out + ".part");
  EXPECT_NE(h.attr_string("/", "status").find("failed at t ="), std::string::npos);
  EXPECT_GE(h.read_doubles("/timeseries/time").size(), 1u);  // what was computed is kept
}

// A piston that compresses the box until it is narrower than twice the neighbour list's reach:
// the list then refuses the state (a ConfigError, which before the run means bad input). After
// the run has started it is the run's failure: exit 1 (not 2, bad input), and a .part whose
// status says so, so that a sweep records it as failed instead of rerunning it.
TEST(Run, BoxCollapsingBelowTheListCellIsAFailedRun) {
  TempDir dir;
  const std::string out = dir.file("collapse.h5");
  const auto [rc, err] =
      run_quietly(with_piston(scene_text(64, 0.3, 1e-3, 0.01, 1.0, 20.0), 10.0, 1.0), out);
  EXPECT_EQ(rc, 1);
  EXPECT_NE(err.find("cell too small"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(out));
  ASSERT_TRUE(fs::exists(out + ".part"));
  H5Reader h(out + ".part");
  const std::string status = h.attr_string("/", "status");
  EXPECT_EQ(status.rfind("failed at t = ", 0), 0u) << status;
  EXPECT_NE(status.find("cell too small"), std::string::npos) << status;
}

// [run] max_force_evaluations: the run stops at the first sample at which its force evaluations
// reach the budget (a count: the same sample on every machine), and its file is final, not a
// checkpoint, with the status saying where it stopped and no summary.
TEST(Run, ForceEvaluationBudgetStopsAtTheSameSampleAndFinishesTheFile) {
  TempDir dir;
  const std::string text = scene_text(60, 0.6, 1e-3, 0.1, 10.0, 40.0);
  // 10 Euler steps per sample, one force evaluation each (plus the sampling's): 300 stops the
  // run long before t_eq + t_av = 50 samples.
  RunSpec spec = spec_of(text, {"run.max_force_evaluations=300"});
  EXPECT_EQ(spec.max_force_evaluations, 300);
  RunOptions opt;
  opt.quiet = true;
  const ReplicaResult a = run_replica(spec, 3, opt);
  const ReplicaResult b = run_replica(spec, 3, opt);
  EXPECT_TRUE(a.status.is_budget()) << a.status.text();
  EXPECT_TRUE(a.status.is_finished());
  EXPECT_NE(a.status.text().find("[run] max_force_evaluations = 300"), std::string::npos)
      << a.status.text();
  EXPECT_EQ(a.status, b.status);
  ASSERT_EQ(a.series.samples.size(), b.series.samples.size());
  EXPECT_LT(a.series.samples.size(), 50u);
  EXPECT_GT(a.series.samples.size(), 5u);
  EXPECT_FALSE(a.summary.computed);
  EXPECT_TRUE(a.summary.values().empty());

  // Through run_and_write: the file is final (not .part), exit status 0, and it reads back.
  const std::string out = dir.file("budget.h5");
  spec = spec_of(text, {"run.max_force_evaluations=300", "output.file=\"" + out + "\""});
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  EXPECT_EQ(run_and_write(spec, opt), 0);
  testing::internal::GetCapturedStdout();
  testing::internal::GetCapturedStderr();
  ASSERT_TRUE(fs::exists(out));
  EXPECT_FALSE(fs::exists(out + ".part"));
  const RunFile f = read_run_file(out);
  EXPECT_EQ(f.status, a.status);
  ASSERT_EQ(f.replicas.size(), 1u);
  EXPECT_EQ(f.replicas[0].status, a.status);
  EXPECT_EQ(f.replicas[0].series.samples.size(), a.series.samples.size());
  EXPECT_FALSE(f.replicas[0].summary.computed);

  // Without a budget (0, the default) the run completes.
  EXPECT_EQ(spec_of(text).max_force_evaluations, 0);
}

// read_run_file gives back what the run computed: series, summary and verdicts, final state.
TEST(Run, RunFileReadsBackTheRun) {
  TempDir dir;
  const std::string out = dir.file("r.h5");
  RunSpec spec =
      spec_of(scene_text(60, 0.6, 1e-3, 0.1, 10.0, 40.0), {"output.file=\"" + out + "\""});
  RunOptions opt;
  opt.quiet = true;
  const ReplicaResult r = run_replica(spec, spec.seed, opt);
  ASSERT_TRUE(write_run_file(spec, {r}, out));
  for (const bool everything : {true, false}) {
    const RunFile f = read_run_file(out, everything);
    EXPECT_TRUE(f.status.is_complete()) << f.status.text();
    EXPECT_EQ(f.scene, spec.scene_text);
    ASSERT_EQ(f.replicas.size(), 1u);
    const ReplicaResult& b = f.replicas[0];
    EXPECT_TRUE(b.status.is_complete()) << b.status.text();
    EXPECT_EQ(b.summary.sigma_xy.value, r.summary.sigma_xy.value);
    for (const auto& [name, v] : kVerdicts)
      EXPECT_EQ(b.summary.*v, r.summary.*v) << name;
    EXPECT_EQ(b.summary.run_length, r.summary.run_length);
    EXPECT_EQ(b.summary.t_eq_method, r.summary.t_eq_method);
    if (everything) {
      ASSERT_EQ(b.series.samples.size(), r.series.samples.size());
      EXPECT_EQ(b.series.samples.back().sigma_xy, r.series.samples.back().sigma_xy);
      EXPECT_EQ(b.final_state.size(), r.final_state.size());
      using Stats = std::map<std::string, double>;
      EXPECT_EQ(Stats(b.integrator_stats.begin(), b.integrator_stats.end()),
                Stats(r.integrator_stats.begin(), r.integrator_stats.end()));
    }
  }
}

// A constant-volume run and a two-replica constant-pressure run of 60 particles, written into
// `dir` (cv.h5, np.h5), with their specs and replicas as run.
struct WrittenRun {
  std::string name, path;
  RunSpec spec;
  std::vector<ReplicaResult> runs;
};
std::vector<WrittenRun> write_cv_and_np_runs(const TempDir& dir) {
  RunOptions opt;
  opt.quiet = true;
  std::vector<WrittenRun> out;
  for (const auto& [name, sets] :
       {std::pair<std::string, std::vector<std::string>>{"cv.h5", {}},
        {"np.h5",
         {"ensemble.kind=\"constant_pressure\"", "ensemble.pressure=1e-2", "run.replicas=2"}}}) {
    WrittenRun w{name, dir.file(name), {}, {}};
    std::vector<std::string> all = sets;
    all.push_back("output.file=\"" + w.path + "\"");
    w.spec = spec_of(scene_text(60, 0.6, 1e-3, 0.1, 5.0, 20.0), all);
    for (std::int64_t k = 0; k < w.spec.replicas; ++k)
      w.runs.push_back(run_replica(w.spec, w.spec.seed + static_cast<std::uint64_t>(k), opt));
    EXPECT_TRUE(write_run_file(w.spec, w.runs, w.path)) << name;
    out.push_back(std::move(w));
  }
  return out;
}

// A checkpoint names the timeseries group that holds its replica's series instead of storing
// it a second time (only piston_dissipation, which a constant-volume timeseries lacks, is
// kept); it reads back every sample bit for bit, and a file written before that (the whole
// series under /checkpoint) still reads.
TEST(Run, CheckpointStoresTheSeriesOnce) {
  TempDir dir;
  const auto same_series = [](const ReplicaResult& a, const ReplicaResult& b) {
    if (a.series.samples.size() != b.series.samples.size())
      return false;
    for (std::size_t s = 0; s < a.series.samples.size(); ++s)
      for (const auto& [name, field] : kSeriesFields)
        if (std::memcmp(&(a.series.samples[s].*field), &(b.series.samples[s].*field),
                        sizeof(double)) != 0)
          return false;
    return true;
  };
  for (const WrittenRun& w : write_cv_and_np_runs(dir)) {
    const std::string& out = w.path;
    const auto& runs = w.runs;
    const RunSpec& spec = w.spec;
    struct {
      std::string name;
      std::size_t replicas;
    } c{w.name, runs.size()};
    {
      H5Reader h(out);
      for (std::size_t k = 0; k < c.replicas; ++k) {
        const std::string g = "/checkpoint/replicas/" + std::to_string(k);
        const std::string ts =
            c.replicas > 1 ? "/replicas/" + std::to_string(k) + "/timeseries" : "/timeseries";
        EXPECT_EQ(h.attr_string(g, "series"), ts) << c.name;
        EXPECT_FALSE(h.exists(g + "/series/time")) << c.name;
        EXPECT_EQ(h.exists(g + "/series/piston_dissipation"), !spec.ensemble->has_piston())
            << c.name;
      }
    }
    const RunFile f = read_run_file(out, true);
    ASSERT_EQ(f.replicas.size(), c.replicas);
    for (std::size_t k = 0; k < c.replicas; ++k)
      EXPECT_TRUE(same_series(f.replicas[k], runs[k])) << c.name << " replica " << k;
  }
  // The earlier layout: the series copied under /checkpoint, no "series" attribute.
  const std::string cv = dir.file("cv.h5");
  const RunFile before = read_run_file(cv, true);
  {
    const hid_t file = H5Fopen(cv.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    ASSERT_GE(file, 0);
    EXPECT_GE(H5Adelete_by_name(file, "/checkpoint/replicas/0", "series", H5P_DEFAULT), 0);
    for (const auto& [name, field] : kSeriesFields) {
      (void)field;
      if (std::string(name) == "piston_dissipation")
        continue;
      const std::string to = std::string("/checkpoint/replicas/0/series/") + name;
      EXPECT_GE(H5Ocopy(file, (std::string("/timeseries/") + name).c_str(), file, to.c_str(),
                        H5P_DEFAULT, H5P_DEFAULT),
                0)
          << name;
    }
    EXPECT_GE(H5Ldelete(file, "/timeseries/time", H5P_DEFAULT), 0);  // not read from there
    H5Fclose(file);
  }
  const RunFile old = read_run_file(cv, true);
  ASSERT_EQ(old.replicas.size(), 1u);
  EXPECT_TRUE(same_series(old.replicas[0], before.replicas[0]));
}

// Every run records its CPU seconds beside its wall seconds, and its cost in force-pass
// equivalents beside its force evaluations (for Euler the same count).
TEST(Run, RecordsCpuSecondsAndForcePassEquivalents) {
  TempDir dir;
  const std::string out = dir.file("cpu.h5");
  RunSpec spec = spec_of(scene_text(60, 0.6, 1e-3, 0.1, 10.0, 40.0, "replicas = 2\n"),
                         {"output.file=\"" + out + "\""});
  RunOptions opt;
  opt.quiet = true;
  testing::internal::CaptureStdout();
  ASSERT_EQ(run_and_write(spec, opt), 0);
  const std::string printed = testing::internal::GetCapturedStdout();
  EXPECT_NE(printed.find("cpu time"), std::string::npos) << printed;
  EXPECT_NE(printed.find("force-pass equivalents"), std::string::npos) << printed;
  H5Reader h(out);
  double total = 0.0;
  for (const std::string g : {"/replicas/0/summary", "/replicas/1/summary"}) {
    const double cpu = h.attr_double(g, "cpu_seconds");
    EXPECT_TRUE(std::isfinite(cpu) && cpu > 0.0) << g << ": " << cpu;
    total += cpu;
    EXPECT_EQ(h.attr_double(g, "integrator_force_pass_equivalents"),
              h.attr_double(g, "integrator_force_evaluations"))
        << g;
  }
  EXPECT_EQ(h.attr_double("/summary", "cpu_seconds"),
            h.attr_double("/replicas/0/summary", "cpu_seconds"));
  EXPECT_DOUBLE_EQ(h.attr_double("/summary", "cpu_seconds_total"), total);
  EXPECT_FALSE(h.has_attr("/summary", "cpu_seconds_note"));
  for (const bool everything : {true, false}) {
    const RunFile f = read_run_file(out, everything);
    ASSERT_EQ(f.replicas.size(), 2u);
    EXPECT_EQ(f.replicas[0].cpu_seconds, h.attr_double("/replicas/0/summary", "cpu_seconds"));
    EXPECT_FALSE(f.replicas[0].cpu_from_wall);
    // Not a summary value: it describes the run.
    EXPECT_TRUE(std::isnan(f.replicas[0].summary.value("cpu_seconds")));
  }
}

// Whether attribute `name` of `object` is text (a string) rather than a number.
bool is_text(const H5Reader& h, const std::string& object, const std::string& name) {
  try {
    h.attr_string(object, name);
    return true;
  } catch (const IoError&) {
    return false;
  }
}

// Every dataset under `group`, recursively.
void datasets_under(const H5Reader& h, const std::string& group, std::vector<std::string>& out) {
  for (const auto& name : h.children(group)) {
    const std::string path = (group == "/" ? "" : group) + "/" + name;
    if (h.is_group(path))
      datasets_under(h, path, out);
    else
      out.push_back(path);
  }
}

// A run file is self-describing: every dataset has the attribute "unit", and every numeric
// attribute of each /summary group its unit in <summary>/units under the same name, at constant
// volume and at constant pressure with replicas (a summary value added without a unit fails
// here). The readers of /summary see the same values as before.
TEST(Run, EveryDatasetAndSummaryValueOfARunFileHasAUnit) {
  TempDir dir;
  for (const WrittenRun& w : write_cv_and_np_runs(dir)) {
    const std::string& out = w.path;
    const auto& runs = w.runs;
    struct {
      std::string name;
      std::size_t replicas;
    } c{w.name, runs.size()};
    const H5Reader h(out);
    std::vector<std::string> datasets;
    datasets_under(h, "/", datasets);
    EXPECT_GE(datasets.size(), c.replicas > 1 ? 3 * 13u : 13u) << c.name;
    for (const auto& d : datasets) {
      ASSERT_TRUE(h.has_attr(d, "unit")) << c.name << ": " << d;
      EXPECT_FALSE(h.attr_string(d, "unit").empty()) << c.name << ": " << d;
    }
    std::vector<std::string> summaries = {"/summary"};
    for (std::size_t k = 0; c.replicas > 1 && k < c.replicas; ++k)
      summaries.push_back("/replicas/" + std::to_string(k) + "/summary");
    for (const auto& g : summaries) {
      ASSERT_TRUE(h.is_group(g + "/units")) << c.name << ": " << g;
      std::size_t numbers = 0;
      for (const auto& name : h.attr_names(g)) {
        if (is_text(h, g, name)) {
          EXPECT_FALSE(h.has_attr(g + "/units", name)) << c.name << ": " << g << " " << name;
          continue;
        }
        ++numbers;
        ASSERT_TRUE(h.has_attr(g + "/units", name)) << c.name << ": " << g << " " << name;
        EXPECT_FALSE(h.attr_string(g + "/units", name).empty()) << g << " " << name;
      }
      EXPECT_EQ(h.attr_names(g + "/units").size(), numbers) << c.name << ": " << g;
      EXPECT_EQ(h.attr_string(g + "/units", "eta"), "xi_s/a");
      EXPECT_EQ(h.attr_string(g + "/units", "eta_err"), "xi_s/a");
      EXPECT_EQ(h.attr_string(g + "/units", "sigma_xy"), "eps/a^3");
      EXPECT_EQ(h.attr_string(g + "/units", "shear_rate"), "1/tau_0");
      EXPECT_EQ(h.attr_string(g + "/units", "tau_sigma_xy"), "tau_0");
      EXPECT_EQ(h.attr_string(g + "/units", "J"), "1");
      EXPECT_EQ(h.attr_string(g + "/units", "cpu_seconds"), "s");
    }
    EXPECT_EQ(h.attr_string("/timeseries/time", "unit"), "tau_0");
    EXPECT_EQ(h.attr_string("/timeseries/pressure", "unit"), "eps/a^3");
    EXPECT_EQ(h.attr_string("/timeseries/dissipation", "unit"), "eps/tau_0");
    EXPECT_EQ(h.attr_string("/final/positions", "unit"), "a");
    EXPECT_EQ(h.attr_string("/final/species", "unit"), "1");
    if (c.replicas > 1) {
      EXPECT_EQ(h.attr_string("/summary/units", "xi_V"), "xi_s/a^4");
      EXPECT_EQ(h.attr_string("/summary/units", "imposed_pressure"), "eps/a^3");
      EXPECT_EQ(h.attr_string("/summary/units", "wall_seconds_total"), "s");
      EXPECT_EQ(h.attr_string("/replicas/1/timeseries/piston_dissipation", "unit"), "eps/tau_0");
    }
    // The readers of /summary take its attributes only: the same values as the run's.
    const RunFile f = read_run_file(out, true);
    ASSERT_EQ(f.replicas.size(), c.replicas);
    for (std::size_t k = 0; k < c.replicas; ++k) {
      const auto read = f.replicas[k].summary.values(), ran = runs[k].summary.values();
      ASSERT_EQ(read.size(), ran.size()) << c.name;
      for (std::size_t i = 0; i < read.size(); ++i) {
        EXPECT_EQ(read[i].first, ran[i].first) << c.name;
        EXPECT_TRUE(read[i].second == ran[i].second ||
                    (std::isnan(read[i].second) && std::isnan(ran[i].second)))
            << c.name << ": " << read[i].first;
      }
    }
  }
}

// The units of every integrator's summary counters (Integrator::statistics): a counter added
// to an integrator without a unit in unit_of fails here. Text has none.
TEST(Run, EveryIntegratorsSummaryValuesHaveUnits) {
  RunOptions opt;
  opt.quiet = true;
  for (const std::string integrator :
       {"kind = \"euler\"\ndt = 0.1", "kind = \"respa\"\ndt = 0.1\nn_inner = 2",
        "kind = \"rkc\"\nrtol = 1e-3\natol = 1e-4", "kind = \"cvode\"\nrtol = 1e-5"}) {
    const RunSpec spec = spec_of(
        "[system]\nN = 60\nphi = 0.6\nseed = 3\n[ensemble]\nkind = \"constant_pressure\"\n"
        "pressure = 1e-2\nxi_V = 0.05\n[shear]\nrate = 1e-2\n[integrator]\n" +
        integrator + "\n[run]\nt_eq = 1.0\nt_av = 4.0\nsample_every = 1.0\nblocks = 2\n");
    const ReplicaResult r = run_replica(spec, spec.seed, opt);
    ASSERT_TRUE(r.status.is_complete()) << integrator << ": " << r.status.text();
    ASSERT_FALSE(r.integrator_stats.empty()) << integrator;
    for (const auto& [name, value] : summary_attributes(spec, r)) {
      if (std::holds_alternative<std::string>(value))
        EXPECT_EQ(unit_of(name), "") << integrator << ": " << name;
      else
        EXPECT_FALSE(unit_of(name).empty()) << integrator << ": " << name;
    }
  }
  EXPECT_EQ(unit_of("integrator_step_last"), "tau_0");
  EXPECT_EQ(unit_of("integrator_spectral_radius"), "1/tau_0");
  EXPECT_EQ(unit_of("integrator_atol"), "a");
  EXPECT_EQ(unit_of("tau_nothing"), "");
  EXPECT_EQ(unit_of("nothing_err"), "");
}

// A run file written before CPU time was recorded (no cpu_seconds) is read with its wall
// seconds in their place, marked as such; a file written from it says so.
TEST(Run, OlderRunFileWithoutCpuSecondsFallsBackToWallSeconds) {
  TempDir dir;
  const std::string out = dir.file("old.h5");
  RunSpec spec =
      spec_of(scene_text(60, 0.6, 1e-3, 0.1, 10.0, 20.0), {"output.file=\"" + out + "\""});
  RunOptions opt;
  opt.quiet = true;
  ASSERT_TRUE(write_run_file(spec, {run_replica(spec, spec.seed, opt)}, out));
  {
    const hid_t file = H5Fopen(out.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    ASSERT_GE(file, 0);
    EXPECT_GE(H5Adelete_by_name(file, "/summary", "cpu_seconds", H5P_DEFAULT), 0);
    EXPECT_GE(H5Adelete_by_name(file, "/checkpoint/replicas/0", "cpu_seconds", H5P_DEFAULT), 0);
    EXPECT_GE(H5Adelete_by_name(file, "/checkpoint/replicas/0", "cpu_from_wall", H5P_DEFAULT), 0);
    H5Fclose(file);
  }
  double wall = 0.0;
  {
    H5Reader h(out);
    wall = h.attr_double("/summary", "wall_seconds");
  }
  for (const bool everything : {true, false}) {
    const RunFile f = read_run_file(out, everything);
    ASSERT_EQ(f.replicas.size(), 1u);
    EXPECT_EQ(f.replicas[0].cpu_seconds, wall);
    EXPECT_TRUE(f.replicas[0].cpu_from_wall);
  }
  const std::string again = dir.file("again.h5");
  ASSERT_TRUE(write_run_file(spec, read_run_file(out, true).replicas, again));
  H5Reader h(again);
  EXPECT_EQ(h.attr_double("/summary", "cpu_seconds"), wall);
  EXPECT_FALSE(h.attr_string("/summary", "cpu_seconds_note").empty());
}

// CVODE's budget counts force-pass equivalents, its Jacobian-vector products included: it stops
// at the first sample at which they reach the budget, which is earlier than counting the model's
// force passes alone would.
TEST(Run, CvodeBudgetCountsForcePassEquivalents) {
  const std::string text =
      "[system]\nN = 100\nphi = 0.62\nseed = 3\n[ensemble]\nkind = \"constant_volume\"\n"
      "[shear]\nrate = 1e-3\n[integrator]\nkind = \"cvode\"\nrtol = 1e-6\n"
      "[run]\nt_eq = 10.0\nt_av = 40.0\nsample_every = 1.0\nthreads = 1\n";
  RunOptions opt;
  opt.quiet = true;
  const ReplicaResult full = run_replica(spec_of(text), 3, opt);
  ASSERT_TRUE(full.status.is_complete()) << full.status.text();
  const auto stat = [](const ReplicaResult& r, const char* name) {
    return statistic(r.integrator_stats, name, std::nan(""));
  };
  // Jacobian-vector products are a large part of the work: the equivalents count them.
  EXPECT_GE(stat(full, "force_pass_equivalents"),
            stat(full, "force_evaluations") + stat(full, "jtimes_evaluations"));
  EXPECT_GT(stat(full, "jtimes_evaluations"), 0.2 * stat(full, "force_evaluations"));

  const auto budget = static_cast<std::int64_t>(0.7 * stat(full, "force_pass_equivalents"));
  const ReplicaResult cut =
      run_replica(spec_of(text, {"run.max_force_evaluations=" + std::to_string(budget)}), 3, opt);
  ASSERT_TRUE(cut.status.is_budget()) << cut.status.text();
  EXPECT_NE(cut.status.detail.find("force-pass equivalents"), std::string::npos)
      << cut.status.text();
  const double equivalents = stat(cut, "force_pass_equivalents");
  RecordProperty("cut", "equivalents " + std::to_string(equivalents) + ", force evaluations " +
                            std::to_string(stat(cut, "force_evaluations")) + ", jtimes " +
                            std::to_string(stat(cut, "jtimes_evaluations")) + ", jtimes setups " +
                            std::to_string(stat(cut, "jtimes_setups")));
  EXPECT_GE(equivalents, double(budget));
  EXPECT_GE(equivalents, stat(cut, "force_evaluations") + stat(cut, "jtimes_evaluations"));
  // Counting force passes alone, the run would have gone on.
  EXPECT_LT(stat(cut, "force_evaluations"), double(budget));
  // Within one sample past the budget: the same run ended one sample earlier had not reached it.
  const std::size_t samples = cut.series.samples.size();  // t = 0, 1, ..., samples - 1
  ASSERT_GT(samples, 16u);
  const double t_before = double(samples - 2);
  const ReplicaResult before = run_replica(
      spec_of(text, {"run.t_av=" + std::to_string(t_before - 10.0), "run.blocks=4"}), 3, opt);
  ASSERT_EQ(before.series.samples.size(), samples - 1);
  EXPECT_LT(stat(before, "force_pass_equivalents"), double(budget));
}

std::string config_error(const std::string& text, const std::vector<std::string>& sets = {}) {
  try {
    spec_of(text, sets);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "no error";
}

TEST(Run, SceneValidationNamesKeyValueAndRange) {
  const std::string base = scene_text(100, 0.6, 1e-3, 0.1, 10.0, 40.0);
  EXPECT_NE(config_error(base, {"system.phi=1.5"}).find("[system] phi = 1.5 is out of range"),
            std::string::npos);
  EXPECT_NE(config_error(base, {"system.alpha=3.5"}).find("[system] alpha = 3.5"),
            std::string::npos);
  EXPECT_NE(config_error(base, {"integrator.dt=-1"}).find("[integrator] dt = -1"),
            std::string::npos);
  EXPECT_NE(config_error(base, {"integrator.n_inner=4"}).find("unknown key [integrator] n_inner"),
            std::string::npos);
  EXPECT_NE(config_error(base, {"run.blocks=100"}).find("fewer than [run] blocks = 100"),
            std::string::npos);
  // Unknown kinds list the registered ones (ensembles/registry.hpp, integrators/registry.hpp).
  EXPECT_NE(config_error(base, {"ensemble.kind=npt"})
                .find("allowed \"constant_pressure\", \"constant_volume\""),
            std::string::npos);
  EXPECT_NE(config_error(base, {"integrator.kind=rk4"})
                .find("[integrator] kind = \"rk4\" is not allowed; allowed \"cvode\", \"euler\", "
                      "\"respa\""),
            std::string::npos)
      << config_error(base, {"integrator.kind=rk4"});
  // A constant-volume scene gets no piston: piston keys are unknown there.
  EXPECT_NE(config_error(base, {"ensemble.pressure=1e-3"}).find("unknown key [ensemble] pressure"),
            std::string::npos);
  EXPECT_NE(config_error("[system]\nN = 10\n").find("missing section"), std::string::npos);
  EXPECT_NE(config_error(base, {"run.max_force_evaluations=-5"})
                .find("[run] max_force_evaluations = -5 is out of range; allowed"),
            std::string::npos);
}

TEST(Run, InitFromXyzMustAgreeWithScene) {
  TempDir dir;
  const std::string out = dir.file("a.h5");
  RunSpec spec =
      spec_of(scene_text(64, 0.55, 1e-3, 0.1, 0.0, 20.0), {"output.file=\"" + out + "\""});
  RunOptions opt;
  opt.quiet = true;
  ASSERT_EQ(run_and_write(spec, opt), 0);
  const std::string xyz = dir.file("a.final.xyz");
  std::string text = scene_text(64, 0.55, 1e-3, 0.1, 0.0, 20.0);
  EXPECT_NO_THROW(spec_of(text, {"system.init=\"" + xyz + "\""}));
  EXPECT_NE(config_error(text, {"system.init=\"" + xyz + "\"", "system.N=65"}).find("disagrees"),
            std::string::npos);
  EXPECT_NE(
      config_error(text, {"system.init=\"" + xyz + "\"", "system.phi=0.56"}).find("disagrees"),
      std::string::npos);
  // A run continued from the file starts from its strain.
  const RunSpec cont = spec_of(text, {"system.init=\"" + xyz + "\""});
  EXPECT_NEAR(cont.init_state->box.strain, 20e-3, 1e-12);
}

}  // namespace
}  // namespace jamflow
