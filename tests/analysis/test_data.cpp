// Readers: CSV tables (with file/line/column messages) and HDF5 run files
// written here with the HDF5 C API, as `jamflow run` writes them; corrupt run
// files, on which libhdf5 itself may crash or hang, give one-line InputErrors.
#include <gtest/gtest.h>
#include <hdf5.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <random>
#include <string>

#include "analysis/admission.hpp"
#include "analysis/data.hpp"
#include "analysis/errors.hpp"
#include "analysis/json.hpp"
#include "tests/analysis/test_util.hpp"

namespace jamflow::analysis {
namespace {

using testing::ScratchDir;

// Expects an InputError whose message contains every fragment.
template <class F>
void expect_input_error(F&& f, std::initializer_list<std::string> fragments) {
  try {
    f();
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    for (const auto& frag : fragments) {
      EXPECT_NE(std::string(e.what()).find(frag), std::string::npos)
          << "message '" << e.what() << "' lacks '" << frag << "'";
    }
  }
}

TEST(CsvReader, ReadsGranularTableInAnyColumnOrderWithComments) {
  ScratchDir dir;
  auto path = dir.write("g.csv",
                        "# comment line\n"
                        "\n"
                        "mu,mu_err,N,imposed_pressure,shear_rate,phi,phi_err,extra\n"
                        "0.2,0.001,1000,1e-4,1e-6,0.63,1e-4,ignored\n"
                        "0.25,0.002,1000,1e-4,1e-5,0.62,2e-4,ignored\r\n");
  auto pts = read_granular({path});
  ASSERT_EQ(pts.size(), 2u);
  EXPECT_EQ(pts[0].n, 1000);
  EXPECT_DOUBLE_EQ(pts[0].j, 1e-6 / 1e-4);
  EXPECT_DOUBLE_EQ(pts[1].phi, 0.62);
  EXPECT_DOUBLE_EQ(pts[1].mu_err, 0.002);
}

// A collected sweep table: rows whose verdicts failed are left out (not steady, not stable;
// not decorrelated only with a single replica), the rest are read as usual.
// The one admission rule (tables, study reports, run diagnostics).
TEST(Admission, LeavesOutUnsteadyUnstableAndSingleReplicaShortBlocks) {
  const std::optional<bool> pass = true, fail = false, unchecked = std::nullopt;
  EXPECT_TRUE(admit({pass, pass, pass, 1.0}).admitted);
  EXPECT_TRUE(admit({unchecked, unchecked, unchecked, 0.0}).admitted);
  EXPECT_EQ(admit({fail, pass, pass, 4.0}).reason, "not steady");
  EXPECT_EQ(admit({pass, fail, pass, 4.0}).reason, "not stable");
  EXPECT_EQ(admit({fail, fail, fail, 1.0}).reason,
            "not steady, not stable, not decorrelated (one replica)");
  // Blocks shorter than 2 tau: kept from 2 replicas on, and said so.
  for (double replicas : {0.0, 1.0, std::nan("")}) {
    const Admission a = admit({pass, pass, fail, replicas});
    EXPECT_FALSE(a.admitted) << replicas;
    EXPECT_EQ(a.reason, "not decorrelated (one replica)");
  }
  for (double replicas : {2.0, 3.0}) {
    const Admission a = admit({pass, unchecked, fail, replicas});
    EXPECT_TRUE(a.admitted) << replicas;
    EXPECT_TRUE(a.short_blocks);
    EXPECT_EQ(a.reason, "");
  }
  EXPECT_FALSE(admit({pass, pass, pass, 1.0}).short_blocks);
}

TEST(CsvReader, CollectedTableRowsWithFailedVerdictsAreLeftOut) {
  ScratchDir dir;
  auto path = dir.write("sweep.csv",
                        "point,N,imposed_pressure,shear_rate,phi,phi_err,mu,mu_err,replicas,steady,"
                        "stable,decorrelated\n"
                        "a,1000,1e-4,1e-6,0.63,1e-4,0.2,0.001,3,1,1,1\n"
                        "b,1000,1e-4,1e-5,0.62,2e-4,0.25,0.002,3,0,1,1\n"
                        "c,1000,1e-4,1e-7,0.64,2e-4,0.15,0.002,3,1,0,1\n"
                        "d,1000,1e-4,1e-8,0.645,2e-4,0.13,0.002,3,1,1,0\n"
                        "e,1000,1e-4,1e-4,0.60,2e-4,0.3,0.002,1,1,1,0\n"
                        "f,1000,1e-4,1e-3,0.58,2e-4,0.4,0.002,1,1,1,\n");
  const auto pts = read_granular({path});
  std::vector<double> rates;
  for (const auto& p : pts)
    rates.push_back(p.shear_rate);
  std::sort(rates.begin(), rates.end());
  // a (all pass), d (not decorrelated, 3 replicas), f (decorrelated not checked)
  EXPECT_EQ(rates, (std::vector<double>{1e-8, 1e-6, 1e-3}));
  EXPECT_EQ(read_shear({path}).size(), 3u);
}

// A table collected with the error parts separate (<o>_block_err, <o>_replica_err): a large
// replica scatter changes a point's error with 3 replicas, never with 2, whatever <o>_err says;
// a row not decorrelated with 2 replicas keeps its block error, flagged as understated.
TEST(CsvReader, ReplicaScatterOnlyFromThreeReplicas) {
  ScratchDir dir;
  const std::string head =
      "point,N,imposed_pressure,shear_rate,phi,phi_err,mu,mu_err,replicas,steady,stable,"
      "decorrelated,folder,"
      "phi_block_err,phi_replica_err,mu_block_err,mu_replica_err\n";
  auto path = dir.write(
      "parts.csv", head +
                       // 2 replicas, scatter 100x the block error: not used
                       "a,1000,1e-4,1e-6,0.63,0.01,0.2,0.1,2,1,1,1,p/a,1e-4,0.01,1e-3,0.1\n"
                       // 3 replicas, the same numbers: the scatter is the error
                       "b,1000,1e-4,1e-5,0.62,0.01,0.25,0.1,3,1,1,1,p/b,1e-4,0.01,1e-3,0.1\n"
                       // 3 replicas, scatter below the block error: the block error
                       "c,1000,1e-4,1e-7,0.64,2e-4,0.15,2e-3,3,1,1,1,p/c,2e-4,1e-5,2e-3,1e-4\n"
                       // one replica: no scatter
                       "d,1000,1e-4,1e-4,0.60,3e-4,0.3,3e-3,1,1,1,1,p/d,3e-4,,3e-3,\n"
                       // not decorrelated with 2 replicas: the block error, flagged
                       "e,1000,1e-4,1e-3,0.58,0.01,0.4,0.1,2,1,1,0,p/e,1e-4,0.01,1e-3,0.1\n"
                       // not decorrelated with 3 replicas: kept, with the scatter
                       "f,1000,1e-4,1e-8,0.645,0.01,0.13,0.1,3,1,1,0,p/f,1e-4,0.01,1e-3,0.1\n");
  auto pts = read_granular({path});
  ASSERT_EQ(pts.size(), 6u);
  std::map<double, GranularPoint> by_rate;
  for (const auto& p : pts)
    by_rate[p.shear_rate] = p;
  EXPECT_DOUBLE_EQ(by_rate[1e-3].phi_err, 1e-4);
  EXPECT_EQ(by_rate[1e-3].error_basis, ErrorBasis::kBlockTwoShort);
  EXPECT_DOUBLE_EQ(by_rate[1e-6].phi_err, 1e-4);
  EXPECT_DOUBLE_EQ(by_rate[1e-6].mu_err, 1e-3);
  EXPECT_EQ(by_rate[1e-6].error_basis, ErrorBasis::kBlockTwo);
  EXPECT_DOUBLE_EQ(by_rate[1e-5].phi_err, 0.01);
  EXPECT_DOUBLE_EQ(by_rate[1e-5].mu_err, 0.1);
  EXPECT_EQ(by_rate[1e-5].error_basis, ErrorBasis::kScatter);
  EXPECT_DOUBLE_EQ(by_rate[1e-7].phi_err, 2e-4);
  EXPECT_DOUBLE_EQ(by_rate[1e-4].phi_err, 3e-4);
  EXPECT_EQ(by_rate[1e-4].error_basis, ErrorBasis::kBlockOne);
  EXPECT_DOUBLE_EQ(by_rate[1e-8].phi_err, 0.01);
  // The count of each basis, and the sentence the analyses' JSON and reports carry.
  const PointErrors e = point_errors_of(pts);
  EXPECT_EQ(e.points, 6u);
  std::map<ErrorBasis, std::size_t> counts(e.counts.begin(), e.counts.end());
  EXPECT_EQ(counts[ErrorBasis::kBlockTwo], 1u);
  EXPECT_EQ(counts[ErrorBasis::kScatter], 3u);
  EXPECT_EQ(counts[ErrorBasis::kBlockOne], 1u);
  EXPECT_EQ(counts[ErrorBasis::kBlockTwoShort], 1u);
  const std::string text = describe(e);
  EXPECT_NE(text.find("1 of 6 points: the block error of the mean over 2 replicas (their"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("3 of 6 points: the larger of the block error and the scatter of 3"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("1 of 6 points: the block error of the mean over 2 replicas from blocks "
                      "shorter than 2 tau"),
            std::string::npos)
      << text;
}

// A table collected before the parts were separate: its *_err (the larger of the block error
// and the scatter of 2 or more replicas) are taken as they are, and said to be so.
TEST(CsvReader, OlderCollectedTableKeepsItsErrorsAndSaysWhatTheyAre) {
  ScratchDir dir;
  auto path = dir.write("old.csv",
                        "point,N,P,gdot,phi,phi_err,mu,mu_err,replicas,steady,stable,decorrelated\n"
                        "a,1000,1e-4,1e-6,0.63,0.01,0.2,0.1,2,1,1,0\n");
  // Its columns P and gdot are the deprecated names of imposed_pressure and shear_rate.
  ::testing::internal::CaptureStderr();
  const auto pts = read_granular({path});
  const std::string warned = ::testing::internal::GetCapturedStderr();
  EXPECT_NE(warned.find("column 'gdot' is deprecated; read as 'shear_rate'"), std::string::npos);
  ASSERT_EQ(pts.size(), 1u);  // not decorrelated, but its errors include the scatter
  EXPECT_DOUBLE_EQ(pts[0].pressure, 1e-4);
  EXPECT_DOUBLE_EQ(pts[0].shear_rate, 1e-6);
  EXPECT_DOUBLE_EQ(pts[0].phi_err, 0.01);
  EXPECT_EQ(pts[0].error_basis, ErrorBasis::kCollectedMax);
  EXPECT_NE(describe(point_errors_of(pts)).find("older table"), std::string::npos);
}

TEST(CsvReader, MalformedValueNamesFileLineAndColumn) {
  ScratchDir dir;
  auto path = dir.write("bad.csv",
                        "N,imposed_pressure,shear_rate,phi,phi_err,mu,mu_err\n"
                        "1000,1e-4,1e-6,0.63,1e-4,0.2,0.001\n"
                        "1000,1e-4,1e-5,abc,1e-4,0.2,0.001\n");
  expect_input_error([&] { read_granular({path}); }, {"bad.csv:3", "column 'phi'", "abc"});
}

TEST(CsvReader, NonFiniteAndOutOfRangeValuesAreRejected) {
  ScratchDir dir;
  const std::string head = "N,imposed_pressure,shear_rate,phi,phi_err,mu,mu_err\n";
  auto nan = dir.write("nan.csv", head + "1000,1e-4,1e-6,0.63,1e-4,nan,0.001\n");
  expect_input_error([&] { read_granular({nan}); }, {"nan.csv:2", "column 'mu'", "non-finite"});
  auto inf = dir.write("inf.csv", head + "1000,1e-4,1e-6,0.63,inf,0.2,0.001\n");
  expect_input_error([&] { read_granular({inf}); }, {"inf.csv:2", "column 'phi_err'"});
  auto zero_err = dir.write("zero.csv", head + "1000,1e-4,1e-6,0.63,0,0.2,0.001\n");
  expect_input_error([&] { read_granular({zero_err}); }, {"zero.csv:2", "phi_err", "> 0"});
  auto phi = dir.write("phi.csv", head + "1000,1e-4,1e-6,1.63,1e-4,0.2,0.001\n");
  expect_input_error([&] { read_granular({phi}); }, {"phi.csv:2", "0 < phi < 1"});
  auto n = dir.write("n.csv", head + "10.5,1e-4,1e-6,0.63,1e-4,0.2,0.001\n");
  expect_input_error([&] { read_granular({n}); }, {"n.csv:2", "column 'N'"});
}

TEST(CsvReader, StructuralErrors) {
  ScratchDir dir;
  auto fields = dir.write(
      "f.csv", "N,imposed_pressure,shear_rate,phi,phi_err,mu,mu_err\n1000,1e-4,1e-6,0.63\n");
  expect_input_error([&] { read_granular({fields}); }, {"f.csv:2", "expected 7", "found 4"});
  auto cols = dir.write("c.csv", "N,imposed_pressure,shear_rate,phi\n1000,1e-4,1e-6,0.63\n");
  expect_input_error([&] { read_granular({cols}); }, {"c.csv", "missing phi_err,mu,mu_err"});
  auto empty = dir.write("e.csv", "# nothing\n");
  expect_input_error([&] { read_granular({empty}); }, {"e.csv", "empty"});
  expect_input_error([&] { read_granular({dir.file("missing.csv")}); },
                     {"missing.csv", "cannot open"});
  auto cv =
      dir.write("cv.csv", "N,phi,shear_rate,sigma_xy,sigma_xy_err\n1000,0.63,1e-6,1e-5,1e-7\n");
  expect_input_error([&] { read_granular({cv}); }, {"cv.csv", "constant-volume"});
}

TEST(CsvReader, ShearTablesAndGranularTablesForTheCollapse) {
  ScratchDir dir;
  auto cv = dir.write("cv.csv",
                      "N,phi,shear_rate,sigma_xy,sigma_xy_err\n"
                      "1000,0.63,1e-6,1e-5,1e-7\n"
                      "1000,0.64,1e-6,2e-5,1e-7\n");
  auto g = dir.write(
      "g.csv",
      "N,imposed_pressure,shear_rate,phi,phi_err,mu,mu_err\n1000,1e-4,1e-6,0.63,1e-4,0.2,0.001\n");
  auto pts = read_shear({cv, g});
  ASSERT_EQ(pts.size(), 3u);
  std::map<std::string, double> sigma_by_set;
  for (const auto& p : pts)
    sigma_by_set[p.set] = p.sigma;
  EXPECT_DOUBLE_EQ(sigma_by_set.at("N=1000,imposed_pressure=" + format_key(1e-4)),
                   0.2 * 1e-4);  // mu P
  EXPECT_EQ(sigma_by_set.count("N=1000,phi=0.63"), 1u);
  auto neg =
      dir.write("neg.csv", "N,phi,shear_rate,sigma_xy,sigma_xy_err\n1000,0.63,1e-6,-1e-5,1e-7\n");
  expect_input_error([&] { read_shear({neg}); }, {"neg.csv:2", "sigma_xy"});
}

TEST(Merging, RepeatedStatePointsAreInverseVarianceAveraged) {
  GranularPoint a{1000, 1e-4, 1e-6, 1e-2, 0.630, 1e-4, 0.20, 0.01, "a"};
  GranularPoint b{1000, 1e-4, 1e-6, 1e-2, 0.632, 2e-4, 0.22, 0.02, "b"};
  auto m = merge_repeats(std::vector<GranularPoint>{a, b});
  ASSERT_EQ(m.size(), 1u);
  // weights 1/1e-8 and 1/4e-8 -> (4*0.630 + 0.632)/5
  EXPECT_NEAR(m[0].phi, (4 * 0.630 + 0.632) / 5, 1e-15);
  EXPECT_NEAR(m[0].phi_err, 1.0 / std::sqrt(1e8 + 0.25e8), 1e-15);
  EXPECT_NEAR(m[0].mu, (4 * 0.20 + 0.22) / 5, 1e-15);
}

// One run given twice is not two runs: a file named twice (in any spelling) and a row repeated
// are refused, naming both, where they were merged as repeats and shrank the error bars.
TEST(Merging, DuplicateFilesAndIdenticalRowsAreRefused) {
  ScratchDir dir;
  const std::string header = "N,imposed_pressure,shear_rate,phi,phi_err,mu,mu_err\n";
  const std::string row1 = "100,1e-4,1e-6,0.63,1e-4,0.2,0.01\n";
  const std::string row2 = "100,1e-4,1e-6,0.632,1e-4,0.21,0.01\n";
  const auto a = dir.write("a.csv", header + row1 + row2);
  std::filesystem::create_directories(dir.file("sub"));
  expect_input_error(
      [&] {
        read_granular({a, dir.file("sub") + "/../a.csv"});
      },
      {"is the same file as '" + a + "'", "allowed each data file once"});
  expect_input_error([&] { read_shear({a, a}); }, {"is the same file as"});
  // A copy of the file under another name: its rows equal the first file's.
  const auto copy = dir.write("copy.csv", header + row1 + row2);
  expect_input_error(
      [&] {
        read_granular({a, copy});
      },
      {copy + ":2: the same record as " + a + ":2", "remove the duplicate"});
  // A row repeated in one file.
  const auto twice = dir.write("twice.csv", header + row1 + row2 + row1);
  expect_input_error([&] { read_granular({twice}); },
                     {twice + ":4: the same record as " + twice + ":2"});
  expect_input_error([&] { read_shear({twice}); }, {twice + ":4: the same record as"});
  // Two runs of one state point with different results are still merged.
  EXPECT_EQ(read_granular({a}).size(), 1u);
}

// --- HDF5 run files ------------------------------------------------------------

void put_double(hid_t obj, const char* name, double v) {
  hid_t space = H5Screate(H5S_SCALAR);
  hid_t attr = H5Acreate2(obj, name, H5T_IEEE_F64LE, space, H5P_DEFAULT, H5P_DEFAULT);
  H5Awrite(attr, H5T_NATIVE_DOUBLE, &v);
  H5Aclose(attr);
  H5Sclose(space);
}

void put_int(hid_t obj, const char* name, std::int64_t v) {
  hid_t space = H5Screate(H5S_SCALAR);
  hid_t attr = H5Acreate2(obj, name, H5T_STD_I64LE, space, H5P_DEFAULT, H5P_DEFAULT);
  H5Awrite(attr, H5T_NATIVE_INT64, &v);
  H5Aclose(attr);
  H5Sclose(space);
}

void put_string(hid_t obj, const char* name, const std::string& v, bool variable) {
  hid_t type = H5Tcopy(H5T_C_S1);
  H5Tset_size(type, variable ? H5T_VARIABLE : v.size());
  hid_t space = H5Screate(H5S_SCALAR);
  hid_t attr = H5Acreate2(obj, name, type, space, H5P_DEFAULT, H5P_DEFAULT);
  if (variable) {
    const char* p = v.c_str();
    H5Awrite(attr, type, &p);
  } else {
    H5Awrite(attr, type, v.data());
  }
  H5Aclose(attr);
  H5Sclose(space);
  H5Tclose(type);
}

struct RunSpec {
  std::string scene = "[system]\nN = 1000\n";
  std::string ensemble = "constant_pressure";
  bool variable_strings = true;
  bool with_imposed_pressure = true;
  bool with_summary = true;
  std::int64_t n = 1000;
  double phi = 0.63, shear_rate = 1e-6, imposed_pressure = 1e-4, mu = 0.2, sigma_xy = 2e-5;
  // > 0: the summary of that many replicas (combine_replicas), with replica-scatter errors 50
  // times the block errors.
  double replicas = 0.0;
};

void write_run(const std::string& path, const RunSpec& s) {
  hid_t file = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  put_string(file, "scene", s.scene, s.variable_strings);
  put_string(file, "version", "0.1.0", s.variable_strings);
  put_string(file, "git_commit", "abc", s.variable_strings);
  put_string(file, "created", "2025-01-01T00:00:00Z", s.variable_strings);
  if (s.with_summary) {
    hid_t g = H5Gcreate2(file, "summary", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    put_double(g, "sigma_xy", s.sigma_xy);
    put_double(g, "sigma_xy_err", 1e-7);
    put_double(g, "pressure", 1.01e-4);
    put_double(g, "pressure_err", 1e-7);
    put_double(g, "phi", s.phi);
    put_double(g, "phi_err", 1e-4);
    put_double(g, "eta", 20.0);
    put_double(g, "eta_err", 0.1);
    put_double(g, "mu", s.mu);
    put_double(g, "mu_err", 1e-3);
    put_double(g, "J", 1e-2);
    put_double(g, "energy_balance", 1.0);
    put_double(g, "shear_rate", s.shear_rate);
    put_double(g, "alpha", 2.0);
    put_int(g, "N", s.n);
    put_string(g, "ensemble", s.ensemble, s.variable_strings);
    if (s.with_imposed_pressure)
      put_double(g, "imposed_pressure", s.imposed_pressure);
    if (s.replicas > 0.0) {
      put_double(g, "replicas", s.replicas);
      put_double(g, "sigma_xy_replica_err", 50e-7);
      put_double(g, "pressure_replica_err", 50e-7);
      put_double(g, "phi_replica_err", 50e-4);
      put_double(g, "mu_replica_err", 50e-3);
    }
    H5Gclose(g);
  }
  H5Fclose(file);
}

TEST(RunFileReader, ReadsSummaryWithVariableAndFixedLengthStrings) {
  ScratchDir dir;
  for (bool variable : {true, false}) {
    RunSpec spec;
    spec.variable_strings = variable;
    const std::string path = dir.file(variable ? "v.h5" : "f.h5");
    write_run(path, spec);
    ASSERT_TRUE(is_hdf5_file(path));
    RunSummary s = read_run_summary(path);
    EXPECT_EQ(s.ensemble, "constant_pressure");
    EXPECT_EQ(s.scene, "[system]\nN = 1000\n");
    EXPECT_EQ(s.n, 1000);
    EXPECT_TRUE(s.has_imposed_pressure);
    EXPECT_DOUBLE_EQ(s.imposed_pressure, 1e-4);
    EXPECT_DOUBLE_EQ(s.mu, 0.2);
  }
}

TEST(RunFileReader, GranularUsesImposedPressureAndMergesRepeatedRuns) {
  ScratchDir dir;
  RunSpec a, b;
  b.mu = 0.22;
  write_run(dir.file("a.h5"), a);
  write_run(dir.file("b.h5"), b);
  auto pts = read_granular({dir.file("a.h5"), dir.file("b.h5")});
  ASSERT_EQ(pts.size(), 1u);                // same N, P, gdot: two runs of one state point
  EXPECT_DOUBLE_EQ(pts[0].pressure, 1e-4);  // imposed, not the measured 1.01e-4
  EXPECT_DOUBLE_EQ(pts[0].j, 1e-2);
  EXPECT_NEAR(pts[0].mu, 0.21, 1e-12);
  EXPECT_NE(pts[0].source.find("+1 repeats"), std::string::npos);
}

// A run file's /summary holds the block errors in *_err and the replica scatter in
// *_replica_err: the scatter enters a point's error only from 3 replicas on.
TEST(RunFileReader, ReplicaScatterEntersOnlyFromThreeReplicas) {
  ScratchDir dir;
  RunSpec two, three;
  two.replicas = 2.0;
  three.replicas = 3.0;
  three.shear_rate = 1e-5;  // another state point, not a repeat of `two`
  write_run(dir.file("two.h5"), two);
  write_run(dir.file("three.h5"), three);
  auto pts = read_granular({dir.file("two.h5"), dir.file("three.h5")});
  ASSERT_EQ(pts.size(), 2u);
  std::sort(pts.begin(), pts.end(), [](auto& a, auto& b) { return a.replicas < b.replicas; });
  EXPECT_DOUBLE_EQ(pts[0].phi_err, 1e-4);  // 2 replicas: the block error, scatter 50x ignored
  EXPECT_DOUBLE_EQ(pts[0].mu_err, 1e-3);
  EXPECT_EQ(pts[0].error_basis, ErrorBasis::kBlockTwo);
  EXPECT_DOUBLE_EQ(pts[1].phi_err, 50e-4);  // 3 replicas: the larger scatter
  EXPECT_DOUBLE_EQ(pts[1].mu_err, 50e-3);
  EXPECT_EQ(pts[1].error_basis, ErrorBasis::kScatter);
  const auto shear = read_shear({dir.file("two.h5"), dir.file("three.h5")});
  ASSERT_EQ(shear.size(), 2u);
  for (const auto& p : shear)
    EXPECT_DOUBLE_EQ(p.sigma_err, p.replicas >= 3.0 ? 50e-7 : 1e-7) << p.replicas;
}

TEST(RunFileReader, ConstantVolumeRunsFeedTheCollapseOnly) {
  ScratchDir dir;
  RunSpec cv;
  cv.ensemble = "constant_volume";
  cv.with_imposed_pressure = false;
  write_run(dir.file("cv.h5"), cv);
  auto pts = read_shear({dir.file("cv.h5")});
  ASSERT_EQ(pts.size(), 1u);
  EXPECT_DOUBLE_EQ(pts[0].sigma, 2e-5);
  EXPECT_EQ(pts[0].set, "N=1000,phi=0.63");
  expect_input_error([&] { read_granular({dir.file("cv.h5")}); },
                     {"cv.h5", "constant_volume", "constant_pressure"});
}

TEST(RunFileReader, MissingPiecesAreNamed) {
  ScratchDir dir;
  RunSpec no_summary;
  no_summary.with_summary = false;
  write_run(dir.file("ns.h5"), no_summary);
  expect_input_error([&] { read_run_summary(dir.file("ns.h5")); }, {"ns.h5", "/summary"});
  RunSpec no_p;
  no_p.with_imposed_pressure = false;
  write_run(dir.file("np.h5"), no_p);
  expect_input_error([&] { read_run_summary(dir.file("np.h5")); },
                     {"np.h5", "missing attribute 'imposed_pressure'"});
  RunSpec bad;
  bad.ensemble = "nve";
  write_run(dir.file("bad.h5"), bad);
  expect_input_error([&] { read_run_summary(dir.file("bad.h5")); }, {"bad.h5", "'nve'"});
  RunSpec nan;
  nan.mu = std::nan("");
  write_run(dir.file("nan.h5"), nan);
  expect_input_error([&] { read_granular({dir.file("nan.h5")}); }, {"nan.h5", "mu", "finite"});
}

// A string attribute holding several strings (found by fuzz_hdf5): the reader had room for one
// and HDF5 wrote all of them past it.
TEST(RunFileReader, StringArrayAttributesAreRejected) {
  ScratchDir dir;
  for (bool variable : {true, false}) {
    const std::string path = dir.file(variable ? "va.h5" : "fa.h5");
    RunSpec spec;
    spec.variable_strings = variable;
    write_run(path, spec);
    hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    hid_t g = H5Gopen2(file, "summary", H5P_DEFAULT);
    H5Adelete(g, "ensemble");
    hid_t type = H5Tcopy(H5T_C_S1);
    H5Tset_size(type, variable ? H5T_VARIABLE : 16);
    const hsize_t dims[1] = {4};
    hid_t space = H5Screate_simple(1, dims, nullptr);
    hid_t attr = H5Acreate2(g, "ensemble", type, space, H5P_DEFAULT, H5P_DEFAULT);
    if (variable) {
      const char* v[4] = {"constant_volume", "constant_volume", "constant_volume", "x"};
      H5Awrite(attr, type, v);
    } else {
      const char v[64] = "constant_volume\0constant_volume\0constant_volume\0x";
      H5Awrite(attr, type, v);
    }
    H5Aclose(attr);
    H5Sclose(space);
    H5Tclose(type);
    H5Gclose(g);
    H5Fclose(file);
    expect_input_error([&] { read_run_summary(path); },
                       {path, "attribute 'ensemble'", "4 strings", "allowed: one string"});
  }
}

// An attribute with no string in it and an absurd declared size: refused, where the reader
// used to allocate the declared gigabyte first.
TEST(RunFileReader, EmptyHugeFixedStringIsRejected) {
  ScratchDir dir;
  const std::string path = dir.file("huge.h5");
  RunSpec spec;
  spec.variable_strings = false;
  write_run(path, spec);
  hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  H5Adelete(file, "scene");
  hid_t type = H5Tcopy(H5T_C_S1);
  H5Tset_size(type, std::size_t{1} << 30);
  hid_t space = H5Screate(H5S_NULL);  // no data stored, only the declared size
  hid_t attr = H5Acreate2(file, "scene", type, space, H5P_DEFAULT, H5P_DEFAULT);
  H5Aclose(attr);
  H5Sclose(space);
  H5Tclose(type);
  H5Fclose(file);
  expect_input_error([&] { read_run_summary(path); },
                     {path, "attribute 'scene' holds 0 strings; allowed: one string"});
}

std::string bytes_of(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

void write_bytes(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

// The same bits in every field.
void expect_same_summary(const RunSummary& a, const RunSummary& b) {
  EXPECT_EQ(a.path, b.path);
  EXPECT_EQ(a.scene, b.scene);
  EXPECT_EQ(a.version, b.version);
  EXPECT_EQ(a.git_commit, b.git_commit);
  EXPECT_EQ(a.created, b.created);
  EXPECT_EQ(a.ensemble, b.ensemble);
  EXPECT_EQ(a.n, b.n);
  EXPECT_EQ(a.has_imposed_pressure, b.has_imposed_pressure);
  const std::vector<std::pair<const char*, std::pair<double, double>>> numbers{
      {"sigma_xy", {a.sigma_xy, b.sigma_xy}},
      {"sigma_xy_err", {a.sigma_xy_err, b.sigma_xy_err}},
      {"pressure", {a.pressure, b.pressure}},
      {"pressure_err", {a.pressure_err, b.pressure_err}},
      {"phi", {a.phi, b.phi}},
      {"phi_err", {a.phi_err, b.phi_err}},
      {"eta", {a.eta, b.eta}},
      {"eta_err", {a.eta_err, b.eta_err}},
      {"mu", {a.mu, b.mu}},
      {"mu_err", {a.mu_err, b.mu_err}},
      {"J", {a.j, b.j}},
      {"energy_balance", {a.energy_balance, b.energy_balance}},
      {"shear_rate", {a.shear_rate, b.shear_rate}},
      {"alpha", {a.alpha, b.alpha}},
      {"imposed_pressure", {a.imposed_pressure, b.imposed_pressure}}};
  for (const auto& [name, v] : numbers)
    EXPECT_EQ(0, std::memcmp(&v.first, &v.second, sizeof(double))) << name;
}

// Each file is read by libhdf5 in a child process that sends the summary back: the values are
// those of a read in this process, bit for bit, with a scene as large as a pipe holds at once
// (or larger) and a NaN among the numbers.
TEST(RunFileReader, ChildProcessReadGivesTheSameValuesAsAnInProcessRead) {
  ScratchDir dir;
  for (bool variable : {true, false}) {
    RunSpec spec;
    spec.variable_strings = variable;
    spec.mu = std::nan("");
    // A fixed-length attribute holds at most 64 KiB (in the object header).
    spec.scene = "[system]\nN = 1000\n" + std::string(variable ? 300000 : 60000, '#') + "\n";
    const std::string path = dir.file(variable ? "v.h5" : "f.h5");
    write_run(path, spec);
    const RunSummary child = read_run_summary(path);
    set_hdf5_isolation(Hdf5Isolation::kInProcess);
    const RunSummary here = read_run_summary(path);
    set_hdf5_isolation(Hdf5Isolation::kChildProcess);
    EXPECT_EQ(child.scene.size(), spec.scene.size());
    EXPECT_TRUE(std::isnan(child.mu));
    expect_same_summary(child, here);
  }
  // Messages about missing pieces come back unchanged.
  RunSpec no_p;
  no_p.with_imposed_pressure = false;
  write_run(dir.file("np.h5"), no_p);
  expect_input_error([&] { read_run_summary(dir.file("np.h5")); },
                     {dir.file("np.h5") + ": /summary: missing attribute 'imposed_pressure'"});
}

// Expects an InputError of one line that starts with the file's path; returns its message.
template <class F>
std::string expect_one_line_error(F&& f, const std::string& path) {
  try {
    f();
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.rfind(path, 0), 0u) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
    return what;
  }
  return "";
}

// Truncated and byte-corrupted copies of a run file: each is read or refused with a one-line
// InputError naming it, and this process goes on whatever libhdf5 does with them.
TEST(RunFileReader, TruncatedAndCorruptedCopiesGiveOneLineInputErrors) {
  ScratchDir dir;
  const std::string good = dir.file("good.h5");
  write_run(good, RunSpec{});  // variable-length strings: a global heap, as in jamflow's files
  const std::string bytes = bytes_of(good);
  ASSERT_GT(bytes.size(), 2000u);
  const std::string path = dir.file("bad.h5");
  int refused = 0, read = 0, crashed = 0;
  const auto check = [&](const std::string& copy) {
    write_bytes(path, copy);
    const std::string what = expect_one_line_error([&] { read_run_summary(path); }, path);
    crashed += what.find("the HDF5 library crashed") != std::string::npos;
    (what.empty() ? read : refused) += 1;
    expect_one_line_error([&] { read_shear({path}); }, path);
  };
  for (std::size_t size = 0; size < bytes.size(); size += bytes.size() / 16)
    check(bytes.substr(0, size));
  // Four bytes changed at a time, in a fixed sequence. (Further on, its 134th copy keeps libhdf5
  // busy for 14 s.)
  std::mt19937 rng(20);
  for (int k = 0; k < 100; ++k) {
    std::string copy = bytes;
    for (int j = 0; j < 4; ++j)
      copy[8 + rng() % (copy.size() - 8)] = static_cast<char>(rng() % 256);
    check(copy);
  }
  RecordProperty("refused", refused);
  RecordProperty("read", read);
  RecordProperty("crashed_libhdf5", crashed);
  EXPECT_GE(refused, 16);  // every truncated copy
}

// A corrupt run file on which libhdf5 1.10.8 itself crashes: a SIGSEGV in H5HG_read (the global
// heap of a variable-length string attribute). Found by mutating fuzz/corpus/hdf5/
// constant_volume.h5; data/README.md. The crash stays in the reading child and becomes an
// InputError naming the file.
TEST(RunFileReader, CrashInsideLibhdf5IsAnInputError) {
  const std::string path = std::string(JAMFLOW_ANALYSIS_TEST_DATA) + "/h5hg_read_sigsegv.h5";
  ASSERT_TRUE(std::filesystem::exists(path)) << path;
  for (int reader = 0; reader < 3; ++reader) {
    const std::string what = expect_one_line_error(
        [&] {
          if (reader == 0)
            read_run_summary(path);
          else if (reader == 1)
            read_shear({path});
          else
            read_granular({path});
        },
        path);
    // "could not be read: the HDF5 library crashed (signal 11, SIGSEGV)"; a sanitizer build
    // reports the bad read and exits instead ("... crashed (exit status 1)").
    EXPECT_NE(what.find(": could not be read: the HDF5 library crashed ("), std::string::npos)
        << what;
  }
}

}  // namespace
}  // namespace jamflow::analysis
