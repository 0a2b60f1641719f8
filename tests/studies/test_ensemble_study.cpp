// The ensemble study's quick preset end to end (what CI runs): a comparison plan
// (studies/ensemble/quick.toml) run by the compare engine. It writes the table, the report, the
// HDF5 file and (with Debian's python3) the plots; constant volume continues from each
// constant-pressure replica at one packing fraction, the mean over the steady constant-pressure
// replicas; the block-spread ratio NV/NP is the ratio of the two ensembles' block spreads; the
// report puts the seed's numbers beside the measured ones, and not in sigma at another state
// point; and the numbers are sensible.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "framework/study.hpp"
#include "lib/h5.hpp"
#include "studies/common.hpp"
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

std::string read_text(const fs::path& p) {
  std::ifstream in(p);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

TEST(EnsembleStudy, QuickPresetIsAComparisonAtOnePackingFraction) {
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
  EXPECT_EQ(files.size(), 12u);  // 4 preparations, 4 constant-pressure, 4 constant-volume runs
  opt.no_plots = true;           // the plots of the first run stay
  ASSERT_EQ(info->run(opt), 0);
  EXPECT_EQ(point_files(dir.string()), files);

  for (const char* f : {"table.csv", "report.md", "compare.h5"})
    EXPECT_TRUE(fs::exists(dir / f)) << f;
  if (python_can_plot()) {
    for (const char* f : {"timeseries.png", "work_precision_eta.png"}) {
      EXPECT_TRUE(fs::exists(dir / f)) << f;
      EXPECT_GT(fs::file_size(dir / f), 10000u) << f;
    }
  }

  // Constant volume runs at one packing fraction: the mean of the window-mean phi over the
  // constant-pressure replicas that passed their steady verdict (all of them if none did), read
  // here from the runs' own files.
  double phi_sum = 0.0, phi_all = 0.0;
  int steady = 0;
  for (int k = 0; k < 4; ++k) {
    const fs::path f =
        dir / "settings/runs/points" / ("constant_pressure_r" + std::to_string(k)) / "r0.h5";
    ASSERT_TRUE(fs::exists(f)) << f;
    H5Reader run(f.string());
    const double phi = run.attr_double("/summary", "phi");
    phi_all += phi / 4.0;
    if (run.attr_double("/summary", "steady") == 1.0) {
      phi_sum += phi;
      ++steady;
    }
  }
  const double phi_nv = steady > 0 ? phi_sum / steady : phi_all;
  RecordProperty("steady_constant_pressure_replicas", steady);
  H5Reader h((dir / "compare.h5").string());
  ASSERT_EQ(h.children("/settings/constant_volume/replicas").size(), 4u);
  for (const auto& k : h.children("/settings/constant_volume/replicas")) {
    const auto phi = h.read_doubles("/settings/constant_volume/replicas/" + k + "/phi");
    ASSERT_GT(phi.size(), 1000u);
    for (double v : phi)
      ASSERT_NEAR(v, phi_nv, 1e-12) << "replica " << k;
  }
  // At constant pressure phi fluctuates, within and across the replicas.
  EXPECT_GT(h.attr_double("/settings/constant_pressure/phi", "block_std"), 0.0);
  EXPECT_GT(h.attr_double("/settings/constant_pressure/phi", "replica_std"), 0.0);

  // The block-spread ratio of the viscosity NV/NP is the ratio of the ensembles' block spreads.
  const double np_std = h.attr_double("/settings/constant_pressure/eta", "block_std");
  const double nv_std = h.attr_double("/settings/constant_volume/eta", "block_std");
  const double ratio = h.attr_double("/settings/constant_volume/eta", "block_std_ratio");
  const double ratio_err = h.attr_double("/settings/constant_volume/eta", "block_std_ratio_err");
  EXPECT_GT(np_std, 0.0);
  EXPECT_NEAR(ratio, nv_std / np_std, 1e-12 * ratio);
  EXPECT_GT(ratio_err, 0.0);
  RecordProperty("eta_block_std_ratio", std::to_string(ratio) + " +- " + std::to_string(ratio_err));

  // The report: where constant volume started, and the seed's section with the measured ratio,
  // not compared in sigma (the quick preset's J = 10 is not the seed's 4e-4).
  const std::string report = read_text(dir / "report.md");
  EXPECT_NE(report.find("`constant_volume` continues from replica k of `constant_pressure`"),
            std::string::npos);
  EXPECT_NE(report.find("phi = " + num(phi_nv, 6)), std::string::npos);
  const auto seed = report.find("## The seed's Fig. 1");
  ASSERT_NE(seed, std::string::npos);
  EXPECT_NE(report.find(pm(ratio, ratio_err, 3), seed), std::string::npos);
  EXPECT_NE(report.find("not compared in sigma", seed), std::string::npos);
  EXPECT_EQ(report.find("sigma (disagrees)", seed), std::string::npos);
  // phi does not fluctuate at constant volume: no spreads or ratios of rounding noise.
  EXPECT_NE(report.find("| constant_volume | constant_volume | phi | 0 (constant) | — |"),
            std::string::npos);

  // The piston holds <P_hat> at the imposed P. In the quick preset's short dilute runs phi still
  // wanders over strains of ~1, so the check is 5% of P rather than a few standard errors.
  EXPECT_NEAR(h.attr_double("/settings/constant_pressure/pressure", "mean"), 1e-5, 5e-7);
  const double eta_np = h.attr_double("/settings/constant_pressure/eta", "mean");
  const double eta_nv = h.attr_double("/settings/constant_volume/eta", "mean");
  EXPECT_GT(eta_np, 0.0);
  EXPECT_NEAR(eta_nv / eta_np, 1.0, 0.2);  // same state point: viscosities within 20%
}

TEST(EnsembleStudy, AnUnknownPresetNamesTheCompareFilesThereAre) {
  const auto studies = registry();
  for (const auto& s : studies) {
    if (s.name != "ensemble")
      continue;
    StudyOptions opt;
    opt.preset = "huge";
    opt.out_dir = (fs::temp_directory_path() / "jamflow-ensemble-no-preset").string();
    try {
      s.run(opt);
      ADD_FAILURE() << "an unknown preset ran";
    } catch (const std::exception& e) {
      EXPECT_EQ(std::string(e.what()), "--preset huge; allowed paper, quick, standard");
    }
    EXPECT_FALSE(fs::exists(opt.out_dir));
    return;
  }
  FAIL() << "the ensemble study is not registered";
}

}  // namespace
}  // namespace jamflow::studies
