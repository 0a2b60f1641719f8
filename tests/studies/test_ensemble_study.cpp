// The ensemble study's quick preset end to end (what CI runs): it writes the table, the report,
// the HDF5 files and (with Debian's python3) the plot, and its numbers are sensible.
#include <gtest/gtest.h>

#include <fstream>
#include <iterator>

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

  // The report says which replicas were steady, and leaves out those that were not.
  {
    std::ifstream in(dir / "report.md");
    const std::string report((std::istreambuf_iterator<char>(in)), {});
    EXPECT_NE(report.find("## Verdicts"), std::string::npos);
  }
  H5Reader h((dir / "ensemble.h5").string());
  for (const char* e : {"/constant_pressure", "/constant_volume"})
    RecordProperty(std::string("excluded") + e, int(h.attr_int(e, "excluded_not_steady")));
  const double p = h.attr_double("/", "pressure");
  EXPECT_DOUBLE_EQ(p, 1e-5);
  const double np_std = h.attr_double("/table", "eta_block_std_np");
  const double nv_std = h.attr_double("/table", "eta_block_std_nv");
  EXPECT_GT(np_std, 0.0);
  EXPECT_GT(nv_std, 0.0);
  EXPECT_TRUE(std::isfinite(h.attr_double("/table", "eta_block_std_ratio_nv_over_np")));
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
  // Every replica's series of both ensembles is kept.
  const auto reps = h.children("/constant_pressure/replicas");
  EXPECT_GE(reps.size(), 3u);
  EXPECT_EQ(h.children("/constant_volume/replicas").size(), reps.size());
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
