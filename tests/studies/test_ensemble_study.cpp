// The ensemble study's quick preset end to end (what CI runs): it writes the table, the report,
// the HDF5 files and (with Debian's python3) the plot; only steady replicas enter the comparison
// and the report lists those left out; the NV/NP ratio and its error follow from the replicas;
// constant volume holds phi at the constant-pressure mean; and its numbers are sensible.
#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <string>
#include <utility>

#include <unistd.h>
#include <cmath>
#include <cstdlib>
#include <filesystem>

#include "lib/h5.hpp"
#include "studies/study.hpp"
#include "tests/driver/temp_dir.hpp"
#include "tests/studies/jamflow_exe.hpp"

namespace jamflow::studies {
namespace {

namespace fs = std::filesystem;

bool python_can_plot() {
  const char* env = std::getenv("JAMFLOW_PYTHON");
  const std::string python = env && *env ? env : "/usr/bin/python3";
  const std::string cmd = "'" + python + "' -c 'import matplotlib, h5py' >/dev/null 2>&1";
  return std::system(cmd.c_str()) == 0;
}

TEST(EnsembleStudy, QuickPresetWritesTablePlotAndSensibleNumbers) {
  const StudyInfo* info = nullptr;
  const auto studies = registry();
  for (const auto& s : studies)
    if (s.name == "ensemble")
      info = &s;
  ASSERT_NE(info, nullptr) << "the ensemble study is not registered";

  const testing_support::TempDir scratch("jamflow-ensemble-");  // removed however the test ends
  const fs::path dir = scratch.path();
  fs::remove_all(dir);
  use_test_jamflow();
  StudyOptions opt;
  opt.preset = "quick";
  opt.out_dir = dir.string();
  opt.quiet = true;
  ASSERT_EQ(info->run(opt), 0);
  // Every run is a point file of the sweep engine; a rerun reads them back, computing nothing.
  const auto files = point_files(dir.string());
  EXPECT_GE(files.size(), 2u);
  opt.no_plots = true;  // the plots of the first run stay
  ASSERT_EQ(info->run(opt), 0);
  EXPECT_EQ(point_files(dir.string()), files);

  for (const char* f :
       {"table.md", "report.md", "ensemble.h5", "constant_pressure.h5", "constant_volume.h5"}) {
    EXPECT_TRUE(fs::exists(dir / f)) << f;
  }
  if (python_can_plot()) {
    EXPECT_TRUE(fs::exists(dir / "timeseries.png"));
    EXPECT_GT(fs::file_size(dir / "timeseries.png"), 10000u);
  }

  std::string report;
  {
    std::ifstream in(dir / "report.md");
    report.assign(std::istreambuf_iterator<char>(in), {});
  }
  H5Reader h((dir / "ensemble.h5").string());
  const auto reps = h.children("/constant_pressure/replicas");
  ASSERT_EQ(reps.size(), 4u);  // the quick preset's replicas
  ASSERT_EQ(h.children("/constant_volume/replicas").size(), reps.size());

  // Only steady replicas enter the comparison: the replicas whose own steady verdict failed are
  // counted, listed under "## Verdicts", and absent from the per-replica block deviations and
  // the combined means (all are kept, with a warning, if none is steady).
  const auto at = report.find("## Verdicts");
  ASSERT_NE(at, std::string::npos);
  std::size_t used[2] = {0, 0};
  int side = 0;
  for (const std::string e : {"constant_pressure", "constant_volume"}) {
    std::size_t not_steady = 0;
    for (const auto& r : reps)
      if (h.attr_double("/" + e + "/replicas/" + r + "/summary", "steady") != 1.0)
        ++not_steady;
    const bool none_steady = not_steady == reps.size();
    const std::size_t left_out = none_steady ? 0 : not_steady;
    used[side++] = reps.size() - left_out;
    RecordProperty("excluded_" + e, int(left_out));
    EXPECT_EQ(std::size_t(h.attr_int("/" + e, "excluded_not_steady")), left_out) << e;
    EXPECT_EQ(h.read_doubles("/" + e + "/eta_block_std").size(), reps.size() - left_out) << e;
    EXPECT_EQ(h.attr_double("/" + e, "replicas"), double(reps.size() - left_out)) << e;
    const auto line_at = report.find("\n- " + e + ": ", at);
    ASSERT_NE(line_at, std::string::npos) << e;
    const std::string line = report.substr(line_at + 1, report.find('\n', line_at + 1) - line_at);
    if (left_out > 0) {
      EXPECT_NE(line.find("left out of the comparison above as not steady"), std::string::npos)
          << line;
      std::size_t listed = 0;
      for (auto k = line.find("replica "); k != std::string::npos; k = line.find("replica ", k + 1))
        ++listed;
      EXPECT_EQ(listed, left_out) << line;
    } else if (!none_steady) {
      EXPECT_NE(line.find("every replica is steady"), std::string::npos) << line;
    }
  }
  EXPECT_NE(
      report.find("the comparison uses " + std::to_string(used[0]) + " at constant pressure and " +
                  std::to_string(used[1]) + " at constant volume"),
      std::string::npos);

  const double p = h.attr_double("/", "imposed_pressure");
  EXPECT_DOUBLE_EQ(p, 1e-5);
  // The ratio NV/NP of the block std of eta is the ratio of the two ensembles' means over their
  // replicas, and its error is propagated from the scatter of those replicas (each mean's
  // relative error std / sqrt(K) / mean, combined in quadrature), which is not zero with several
  // replicas.
  const auto mean_and_rel_error = [&](const std::string& e) {
    const auto v = h.read_doubles("/" + e + "/eta_block_std");
    const double k = double(v.size());
    double m = 0.0, ss = 0.0;
    for (double x : v)
      m += x / k;
    for (double x : v)
      ss += (x - m) * (x - m);
    return std::pair<double, double>{m, std::sqrt(ss / (k - 1.0)) / std::sqrt(k) / m};
  };
  const auto [np_std, np_rel] = mean_and_rel_error("constant_pressure");
  const auto [nv_std, nv_rel] = mean_and_rel_error("constant_volume");
  EXPECT_GT(np_std, 0.0);
  EXPECT_GT(nv_std, 0.0);
  EXPECT_NEAR(h.attr_double("/table", "eta_block_std_np"), np_std, 1e-12 * np_std);
  EXPECT_NEAR(h.attr_double("/table", "eta_block_std_nv"), nv_std, 1e-12 * nv_std);
  const double ratio = h.attr_double("/table", "eta_block_std_ratio_nv_over_np");
  const double ratio_err = h.attr_double("/table", "eta_block_std_ratio_nv_over_np_err");
  EXPECT_NEAR(ratio, nv_std / np_std, 1e-12 * ratio);
  EXPECT_NEAR(ratio_err, ratio * std::hypot(np_rel, nv_rel), 1e-9 * ratio_err);
  EXPECT_GT(ratio_err, 0.0);
  RecordProperty("eta_block_std_ratio", std::to_string(ratio) + " +- " + std::to_string(ratio_err));
  // Constant volume imposes phi: each replica's phi is constant (block std 0 up to rounding) at
  // the packing fraction the steady constant-pressure replicas reached on average.
  const auto nv_phi_std = h.read_doubles("/constant_volume/phi_block_std");
  const auto nv_phi = h.read_doubles("/constant_volume/phi_mean");
  ASSERT_EQ(nv_phi.size(), used[1]);
  for (double v : nv_phi_std)
    EXPECT_LT(v, 1e-12);
  const auto np_phi = h.read_doubles("/constant_pressure/phi_mean");
  double np_phi_mean = 0.0;
  for (double v : np_phi)
    np_phi_mean += v / double(np_phi.size());
  for (double v : nv_phi)
    EXPECT_NEAR(v, np_phi_mean, 1e-12);
  // At constant pressure phi does fluctuate, within and across the replicas.
  for (double v : h.read_doubles("/constant_pressure/phi_block_std"))
    EXPECT_GT(v, 0.0);
  EXPECT_GT(h.attr_double("/table", "phi_spread_np"), 0.0);
  // The constant-volume runs sit at the packing fraction the constant-pressure runs reached.
  const double phi = h.attr_double("/table", "phi_np");
  EXPECT_GT(phi, 0.3);
  EXPECT_LT(phi, 0.65);
  EXPECT_DOUBLE_EQ(h.attr_double("/", "phi_constant_volume"), phi);
  EXPECT_NEAR(h.attr_double("/constant_volume", "phi"), phi, 1e-12);
  // The piston holds <P_hat> at the imposed P. In the quick preset's short dilute runs phi still
  // wanders over strains of ~1, so the check is 5% of P rather than a few standard errors.
  EXPECT_NEAR(h.attr_double("/table", "pressure_np"), p, 0.05 * p);
  const double eta_np = h.attr_double("/table", "eta_np");
  const double eta_nv = h.attr_double("/table", "eta_nv");
  EXPECT_GT(eta_np, 0.0);
  EXPECT_NEAR(eta_nv / eta_np, 1.0, 0.2);  // same state point: viscosities within 20%
  // Every replica's series of both ensembles is kept, those left out of the comparison too.
  for (const auto& r : reps) {
    for (const char* e : {"/constant_pressure/replicas/", "/constant_volume/replicas/"}) {
      const auto sigma = h.read_doubles(std::string(e) + r + "/timeseries/sigma_xy");
      EXPECT_GT(sigma.size(), 1000u);
      for (double v : sigma)
        ASSERT_TRUE(std::isfinite(v));
    }
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace jamflow::studies
