// The reports of the studies on the analysis JSON are renderings of it: a committed
// studies/*/results/standard/analysis.json (with its table and sweep file) is copied into a
// scratch folder, one number in it is changed, the report is rebuilt by the study's own report
// code, and the new number appears in it with the verdict that depends on it. No sentence or
// verdict of these reports is typed in.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include "analysis/json.hpp"
#include "analysis/seed.hpp"
#include "framework/table_report.hpp"
#include "studies/common.hpp"
#include "studies/granular_report.hpp"
#include "studies/olsson-teitel/points.hpp"
#include "studies/olsson-teitel/report.hpp"
#include "studies/soft-rheology/points.hpp"
#include "studies/soft-rheology/report.hpp"
#include "sweep/plan.hpp"

namespace jamflow::studies {
namespace {
namespace fs = std::filesystem;
using analysis::Json;

// A scratch folder holding copies of a committed result folder's files.
class Scratch {
 public:
  Scratch() {
    path_ = fs::temp_directory_path() /
            ("jamflow-reports-" + std::to_string(::getpid()) + "-" + std::to_string(count_++));
    fs::create_directories(path_);
  }
  ~Scratch() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  Scratch(const Scratch&) = delete;
  Scratch& operator=(const Scratch&) = delete;
  // Copies studies/<results>/<file> to <scratch>/<sub>/<file>.
  std::string copy(const std::string& results, const std::string& file,
                   const std::string& sub = "") {
    const fs::path from = fs::path(JAMFLOW_SOURCE_DIR) / "studies" / results / file;
    const fs::path dir = path_ / sub;
    fs::create_directories(dir);
    const fs::path to = dir / file;
    fs::copy_file(from, to, fs::copy_options::overwrite_existing);
    return to.string();
  }
  std::string dir(const std::string& sub = "") const { return (path_ / sub).string(); }

 private:
  fs::path path_;
  static inline int count_ = 0;
};

Json load(const std::string& path) {
  return Json::parse(read_file(path));
}

// The line of `text` that starts with `start` ("" if none).
std::string line_starting(const std::string& text, const std::string& start) {
  std::size_t pos = 0;
  while (pos < text.size()) {
    const std::size_t end = text.find('\n', pos);
    const std::string line =
        text.substr(pos, end == std::string::npos ? std::string::npos : end - pos);
    if (line.rfind(start, 0) == 0)
      return line;
    if (end == std::string::npos)
      break;
    pos = end + 1;
  }
  return "";
}

// --- hard-sphere and finite-size (one report code) ---------------------------------------------

struct GridInputs {
  Scratch scratch;
  SweepStudy run;
  Table table;
  Json result;
};

void load_grid(GridInputs& in, const std::string& study) {
  const std::string results = study + "/results/standard";
  const std::string json = in.scratch.copy(results, "analysis.json");
  in.scratch.copy(results, "table.csv");
  in.scratch.copy(results, "sweep.toml");
  in.run = existing_sweep(in.scratch.dir());
  in.table = read_table(in.run.table);
  in.result = load(json);
}

std::string grid_report(const std::string& study, const GridInputs& in, const Json& result) {
  const GridPreset grid =
      study == "finite-size" ? finite_size_preset("standard") : grid_preset("standard");
  return granular::report_markdown(study, grid, in.run, in.table, result, 0, 0.0);
}

// The phi_J row of size N in the per-N fits: its value and its verdict against the seed's law at
// that N follow the JSON's phi_J.
void expect_phi_j_drives_the_verdict(const std::string& study, const GridInputs& in, Json result,
                                     const std::string& n) {
  Json& phi_j = result["sizes"][n]["phi_J"];
  const double e = phi_j.at("error").as_number();
  const double sys = phi_j.at("systematic").is_number() ? phi_j.at("systematic").as_number() : 0.0;
  const double paper = seed::table2("phi_J").at(std::stod(n));
  // Ten combined errors above the paper's law: disagrees.
  const double far = paper + 10.0 * std::hypot(e, sys);
  phi_j["value"] = far;
  const std::string report_far = grid_report(study, in, result);
  // On the paper's law: agrees.
  phi_j["value"] = paper;
  const std::string report_on = grid_report(study, in, result);

  const std::string row_far = line_starting(report_far, "| phi_J |");
  const std::string row_on = line_starting(report_on, "| phi_J |");
  ASSERT_FALSE(row_far.empty()) << report_far;
  EXPECT_NE(row_far.find(pm(far, e)), std::string::npos) << row_far;
  EXPECT_NE(row_far.find("+10.0 sigma (disagrees)"), std::string::npos) << row_far;
  EXPECT_NE(row_on.find(pm(paper, e)), std::string::npos) << row_on;
  EXPECT_NE(row_on.find("+0.0 sigma"), std::string::npos) << row_on;
  EXPECT_EQ(row_on.find("disagrees"), std::string::npos) << row_on;
}

TEST(ReportsFromJson, FiniteSizePhiJChangesTheReport) {
  GridInputs in;
  load_grid(in, "finite-size");
  ASSERT_TRUE(in.result.at("sizes").contains("500"));
  // Only the N = 500 section: the per-N table of another size has its own phi_J row.
  Json result = in.result;
  Json sizes = Json::object();
  sizes["500"] = result.at("sizes").at("500");
  result["sizes"] = sizes;
  expect_phi_j_drives_the_verdict("finite-size", in, result, "500");
}

TEST(ReportsFromJson, HardSpherePhiJChangesTheReport) {
  GridInputs in;
  load_grid(in, "hard-sphere");
  // The committed N = 1000 analysis fitted nothing (too few points in the envelope), and the
  // report says why, from the JSON.
  const std::string committed = grid_report("hard-sphere", in, in.result);
  const Json& n1000 = in.result.at("sizes").at("1000");
  if (n1000.contains("fitted") && !n1000.at("fitted").as_bool()) {
    EXPECT_NE(committed.find("Not fitted: " + n1000.at("reason").as_string()), std::string::npos);
  }
  // A fitted size in the same JSON (the finite-size study's N = 500 entry, the same analysis'
  // output) is rendered from its numbers.
  GridInputs fs_in;
  load_grid(fs_in, "finite-size");
  Json result = in.result;
  Json sizes = Json::object();
  sizes["1000"] = fs_in.result.at("sizes").at("500");
  result["sizes"] = sizes;
  expect_phi_j_drives_the_verdict("hard-sphere", in, result, "1000");
}

// A resolved N -> infinity value is compared with the seed's with its systematic error: ten
// statistical errors from the seed is a disagreement alone, and 1.0 sigma with a systematic of
// ten (10 / sqrt(101)).
TEST(ReportsFromJson, FiniteSizeInfinityVerdictCarriesItsSystematic) {
  GridInputs in;
  load_grid(in, "finite-size");
  const double paper = seed::table2("phi_J").inf;
  const double e = 0.001;
  const auto report_with = [&](double sys) {
    Json result = in.result;
    Json ex = Json::object();
    Json pe = Json::object();
    Json inf = Json::object();
    inf["value"] = paper + 10.0 * e;
    inf["error"] = e;
    inf["systematic"] = sys;
    pe["status"] = "fit";
    pe["inf"] = inf;
    pe["resolved"] = true;
    pe["resolution"] = "resolved";
    ex["phi_J"] = pe;
    result["extrapolated"] = ex;
    return line_starting(grid_report("finite-size", in, result),
                         "| phi_J | " + pm(paper + 10.0 * e, e));
  };
  const std::string small = report_with(0.0);
  const std::string large = report_with(10.0 * e);
  ASSERT_FALSE(small.empty());
  EXPECT_NE(small.find("+10.0 sigma (disagrees)"), std::string::npos) << small;
  EXPECT_NE(large.find("± 0.01 (systematic)"), std::string::npos) << large;
  EXPECT_NE(large.find("+1.0 sigma"), std::string::npos) << large;
  EXPECT_EQ(large.find("disagrees"), std::string::npos) << large;
}

// `result` with its extrapolated.<parameter> entry changed by `change`.
template <class Change>
Json with_extrapolation(const Json& result, const std::string& parameter, const Change& change) {
  Json out = result;
  Json ex = out.at("extrapolated");
  Json pe = ex.contains(parameter) ? ex.at(parameter) : Json::object();
  change(pe);
  ex[parameter] = pe;
  out["extrapolated"] = ex;
  return out;
}

// What the sizes could resolve is read from the JSON's sensitivity: its chance, its error scale
// (shown as how much smaller the errors must be, and the replicas that takes) and alpha_O's
// error, which bounds nu's precision.
TEST(ReportsFromJson, FiniteSizeSensitivityComesFromTheJson) {
  GridInputs in;
  load_grid(in, "finite-size");
  ASSERT_TRUE(in.result.contains("extrapolated"));
  ASSERT_TRUE(in.result.at("extrapolated").contains("phi_J"));
  const auto report_with = [&](double z, double chance, double scale, double sigma_alpha) {
    Json sv = Json::object();
    sv["A"] = seed::table2("phi_J").a;
    sv["alpha"] = seed::table2("phi_J").alpha;
    sv["A_over_sigma"] = z;
    sv["chance_resolved"] = chance;
    sv["error_scale_for_target"] = scale;
    sv["sigma_alpha"] = sigma_alpha;
    sv["threshold_sigma"] = 2.0;
    sv["target_chance"] = 0.8;
    return grid_report("finite-size", in, with_extrapolation(in.result, "phi_J", [&](Json& pe) {
                         pe["sensitivity"] = sv;
                       }));
  };
  const std::string low = report_with(0.52, 0.075, 0.18, 0.41);
  const std::string high = report_with(3.5, 0.93, 1.23, 0.1);
  EXPECT_NE(
      line_starting(low, "| phi_J | -0.323 | 0.52 | 0.075 | 5.6 (replicas x 31) | 0.41 (0.852) |")
          .size(),
      0u)
      << low;
  EXPECT_NE(low.find("no better than ±48% from phi"), std::string::npos) << low;
  // Errors already small enough: nothing to shrink.
  EXPECT_NE(line_starting(high, "| phi_J | -0.323 | 3.5 | 0.93 | - | 0.1 (0.852) |").size(), 0u)
      << high;
  EXPECT_NE(high.find("no better than ±12% from phi"), std::string::npos) << high;
}

// The unit-free readings and the viscosity range are the JSON's: a changed delta chi2, p and
// sigma_alpha / alpha appear in the table, and a changed seed_decades in the sentence.
TEST(ReportsFromJson, UnitFreeReadingsAndViscosityRangeComeFromTheJson) {
  GridInputs in;
  load_grid(in, "finite-size");
  Json result = with_extrapolation(in.result, "phi_J", [](Json& pe) {
    Json u = Json::object();
    u["delta_chi2"] = 1.25;
    u["p_constant"] = 0.535;
    u["alpha_relative_error"] = 0.123;
    pe["unit_free"] = u;
  });
  Json sizes = result.at("sizes");
  Json n500 = sizes.at("500");
  Json ee = n500.at("envelope_eta");
  ee["seed_decades"] = 7.77;
  ee["J_min"] = 0.0042;
  ee["J_max"] = 1.0;
  n500["envelope_eta"] = ee;
  sizes["500"] = n500;
  result["sizes"] = sizes;
  const std::string report = grid_report("finite-size", in, result);
  EXPECT_NE(line_starting(report, "| phi_J | 1.25 | 0.54 | 0.12 |").size(), 0u) << report;
  const std::string line = line_starting(report, "N = 500: the P -> 0 envelope reaches");
  EXPECT_NE(line.find("(J = 1 to 0.0042)"), std::string::npos) << line;
  EXPECT_NE(line.find("the seed's Table 2 law at N = 500 spans 7.77 decades over the same J"),
            std::string::npos)
      << line;
}

// A '|' in a cell's text (as in "needs |A| > 2 sigma") is escaped: the row keeps its five cells.
TEST(ReportsFromJson, APipeInACellDoesNotSplitIt) {
  GridInputs in;
  load_grid(in, "finite-size");
  const Json result = with_extrapolation(in.result, "phi_J", [](Json& pe) {
    pe["resolved"] = false;
    pe["resolution"] = "A = -0.4 ± 1.2: not resolved (needs |A| > 2 sigma)";
  });
  const std::string row = line_starting(grid_report("finite-size", in, result), "| phi_J | - |");
  ASSERT_FALSE(row.empty());
  int delimiters = 0;
  for (std::size_t k = 0; k < row.size(); ++k)
    delimiters += row[k] == '|' && (k == 0 || row[k - 1] != '\\');
  EXPECT_EQ(delimiters, 6) << row;
  EXPECT_NE(row.find("needs \\|A\\| > 2 sigma"), std::string::npos) << row;
}

// The resolution rule the report states is the analysis' (its options in the JSON).
TEST(ReportsFromJson, FiniteSizeRuleComesFromTheOptions) {
  GridInputs in;
  load_grid(in, "finite-size");
  Json result = in.result;
  Json options = result.at("options");
  options["resolved_amplitude_sigma"] = 3.0;
  options["min_sizes_for_extrapolation"] = 5.0;
  result["options"] = options;
  const std::string report = grid_report("finite-size", in, result);
  EXPECT_NE(report.find("over at least 5 sizes whose A_O differs from 0 by more than 3 sigma"),
            std::string::npos)
      << report;
}

// The integrators the header and the cost table name are those of the table's integrator column,
// RKC by its tolerance in units of delta = P: a row that ran at ten times the tolerance is named
// apart, and counted apart.
TEST(ReportsFromJson, IntegratorNamesComeFromTheTable) {
  GridInputs in;
  load_grid(in, "hard-sphere");
  const int col = in.table.column("integrator");
  ASSERT_GE(col, 0);
  const std::size_t rows = in.table.rows.size();
  ASSERT_GE(rows, 3u);
  const std::string all = "rkc atol=0.1 delta (" + std::to_string(rows) + ")";
  EXPECT_NE(grid_report("hard-sphere", in, in.result).find(all), std::string::npos);

  const double p = in.table.number(0, "imposed_pressure");
  in.table.rows[0][std::size_t(col)] = "atol" + num(p, 6) + "_kindrkc";
  in.table.rows[1][std::size_t(col)] = "dt0.5_kindrespa";
  in.table.rows[2][std::size_t(col)] = "kindrkc";  // its default atol (1e-2 delta)
  const std::string changed = grid_report("hard-sphere", in, in.result);
  const std::string header = line_starting(changed, "Constant pressure");
  EXPECT_NE(header.find("rkc atol=1 delta (1)"), std::string::npos) << header;
  EXPECT_NE(header.find("respa dt 0.5 (1)"), std::string::npos) << header;
  EXPECT_NE(header.find("rkc (default atol) (1)"), std::string::npos) << header;
  EXPECT_NE(header.find("rkc atol=0.1 delta (" + std::to_string(rows - 3) + ")"), std::string::npos)
      << header;
  EXPECT_NE(line_starting(changed, "| rkc atol=1 delta | 1 |"), "") << changed;
}

// The asymptotic viscosity exponent's verdict against the seed carries the systematic error the
// JSON gives it: the same value is a disagreement with statistical errors alone and not with a
// systematic ten times larger.
TEST(ReportsFromJson, HardSphereViscosityExponentVerdictCarriesItsSystematic) {
  GridInputs in;
  load_grid(in, "hard-sphere");
  ASSERT_TRUE(in.result.contains("viscosity"));
  Json result = in.result;
  Json& e1 = result["viscosity"]["exponent_1"];
  const double stat = e1.at("error").as_number();
  const double value = seed::kViscosityExponentHigh + 5.0 * stat;
  e1["value"] = value;
  e1["systematic"] = 0.0;
  const std::string alone =
      line_starting(grid_report("hard-sphere", in, result), "Asymptotic exponent 1/b_phi = ");
  ASSERT_FALSE(alone.empty());
  EXPECT_NE(alone.find("+5.0 sigma (disagrees)"), std::string::npos) << alone;
  e1["systematic"] = 10.0 * stat;
  const std::string both =
      line_starting(grid_report("hard-sphere", in, result), "Asymptotic exponent 1/b_phi = ");
  EXPECT_NE(
      both.find(pm(value, stat) + " (statistical) ± " + num(10.0 * stat, 2) + " (systematic)"),
      std::string::npos)
      << both;
  EXPECT_NE(both.find("+0.5 sigma"), std::string::npos) << both;
  EXPECT_EQ(both.find("disagrees"), std::string::npos) << both;
}

// --- soft-rheology -------------------------------------------------------------------------------

struct SoftInputs {
  Scratch scratch;
  SweepStudy cp, cv;
  Table cp_table, cv_table;
  Json result;
};

void load_soft(SoftInputs& in) {
  const std::string results = "soft-rheology/results/standard";
  const std::string json = in.scratch.copy(results, "analysis.json");
  for (const char* sub : {"constant-pressure", "constant-volume"}) {
    in.scratch.copy(results + "/" + sub, "table.csv", sub);
    in.scratch.copy(results + "/" + sub, "sweep.toml", sub);
  }
  in.cp = existing_sweep(in.scratch.dir("constant-pressure"));
  in.cv = existing_sweep(in.scratch.dir("constant-volume"));
  in.cp_table = read_table(in.cp.table);
  in.cv_table = read_table(in.cv.table);
  in.result = load(json);
}

std::string soft_report(const SoftInputs& in, const Json& result) {
  return soft_rheology::report_markdown(soft_rheology::preset("standard"), in.cp, in.cv,
                                        in.cp_table, in.cv_table, result, 0, "");
}

TEST(ReportsFromJson, SoftRheologyPhiJ0ChangesTheReport) {
  SoftInputs in;
  load_soft(in);
  Json result = in.result;
  ASSERT_TRUE(result.at("sizes").contains("1000"));
  Json& joint = result["sizes"]["1000"]["joint"];
  Json& phi = joint["phi_J0"];
  const double stat = phi.at("error").as_number();
  const double sys = phi.contains("systematic") && phi.at("systematic").is_number()
                         ? phi.at("systematic").as_number()
                         : 0.0;
  // The paper's value at the data's N, the one the report compares with.
  const double paper = seed::table2("phi_J").at(1000.0);
  phi["value"] = paper + 10.0 * std::hypot(stat, sys);
  const std::string far = soft_report(in, result);
  phi["value"] = paper;
  const std::string on = soft_report(in, result);
  const std::string far_line = line_starting(far, "- phi_J0 = ");
  const std::string on_line = line_starting(on, "- phi_J0 = ");
  ASSERT_FALSE(far_line.empty()) << far;
  EXPECT_NE(far_line.find(pm(paper + 10.0 * std::hypot(stat, sys), stat)), std::string::npos)
      << far_line;
  EXPECT_NE(far_line.find(num(paper, 4)), std::string::npos) << far_line;
  EXPECT_NE(far_line.find("Table 2 law at N = 1000"), std::string::npos) << far_line;
  EXPECT_NE(far_line.find("differs from the paper's value beyond the systematics"),
            std::string::npos)
      << far_line;
  EXPECT_NE(on_line.find("consistent with the paper's value"), std::string::npos) << on_line;
  // The table row shows the same paper value as the sentence: one reference for phi_J0.
  EXPECT_NE(line_starting(on, "| phi_J0 |").find(num(paper, 4)), std::string::npos);
}

TEST(ReportsFromJson, SoftRheologyLocalExponentDriftFollowsTheJson) {
  SoftInputs in;
  load_soft(in);
  Json result = in.result;
  Json& joint = result["sizes"]["1000"]["joint"];
  ASSERT_TRUE(joint.contains("local_exponents")) << "regenerate the committed analysis.json";
  Json& drift = joint["local_exponents"]["drift_x"];
  ASSERT_TRUE(drift.at("defined").as_bool());
  // A resolved rise toward the lowest pressures, up to 1 ...
  drift["lowest_window"] = 0.987;
  drift["lowest_window_error"] = 0.02;
  drift["highest_window"] = 0.75;
  drift["highest_window_error"] = 0.02;
  drift["difference_sigma"] = (0.987 - 0.75) / std::hypot(0.02, 0.02);
  drift["lowest_window_minus_1_sigma"] = (0.987 - 1.0) / 0.02;
  drift["resolved"] = true;
  const std::string rises = soft_report(in, result);
  EXPECT_NE(rises.find("The local x rises toward the lowest pressures"), std::string::npos);
  EXPECT_NE(rises.find("0.987"), std::string::npos);
  EXPECT_NE(rises.find("within 2 sigma of 1"), std::string::npos);
  // ... and none.
  drift["lowest_window"] = 0.76;
  drift["difference_sigma"] = (0.76 - 0.75) / std::hypot(0.02, 0.02);
  drift["lowest_window_minus_1_sigma"] = (0.76 - 1.0) / 0.02;
  drift["resolved"] = false;
  const std::string flat = soft_report(in, result);
  EXPECT_EQ(flat.find("The local x rises"), std::string::npos);
  EXPECT_NE(flat.find("No drift is resolved"), std::string::npos);
}

// --- olsson-teitel -------------------------------------------------------------------------------

struct OtInputs {
  Scratch scratch;
  SweepStudy run;
  Table table;
  Json result;
};

void load_ot(OtInputs& in) {
  const std::string results = "olsson-teitel/results/standard";
  const std::string json = in.scratch.copy(results, "analysis.json");
  in.run.table = in.scratch.copy(results, "table.csv");
  in.table = read_table(in.run.table);
  in.run.finished = in.table.rows.size();
  in.run.plan = sweep::parse_plan(volume_sweep_text(olsson_teitel::preset("standard")),
                                  "<standard preset>", in.scratch.dir(), in.scratch.dir("runs"));
  in.result = load(json);
}

std::string ot_report(const OtInputs& in, const Json& result) {
  return olsson_teitel::report_markdown(olsson_teitel::preset("standard"), in.run, in.table, result,
                                        0, "");
}

// `result` with the S of `measure` at the entry `label` of "measures" set to `value`, and its
// acceptability as the analysis decides it (S <= threshold).
Json with_measure(const Json& result, const std::string& label, const std::string& measure,
                  double value) {
  Json out = result;
  Json ms = Json::array();
  const Json& old = result.at("measures");
  for (std::size_t i = 0; i < old.size(); ++i) {
    Json m = old.at(i);
    if (m.at("label").as_string() == label) {
      Json& q = m[measure];
      q["value"] = value;
      q["acceptable"] = value <= q.at("threshold").as_number();
    }
    ms.push_back(m);
  }
  out["measures"] = ms;
  return out;
}

double measure_threshold(const Json& result, const std::string& label, const std::string& measure) {
  const Json& ms = result.at("measures");
  for (std::size_t i = 0; i < ms.size(); ++i) {
    if (ms.at(i).at("label").as_string() == label)
      return ms.at(i).at(measure).at("threshold").as_number();
  }
  throw std::out_of_range("no measure " + label);
}

TEST(ReportsFromJson, OlssonTeitelVerdictNeedsBothMeasures) {
  OtInputs in;
  load_ot(in);
  ASSERT_TRUE(in.result.contains("measures")) << "regenerate the committed analysis.json";
  const std::string label = "pairwise-interpolation optimum", key = "pairwise_interpolation";
  const double threshold = measure_threshold(in.result, label, key);
  const bool hh_ok = in.result.at("best").at("quality").at("acceptable").as_bool();
  // The pairwise measure under its threshold, then above it: the verdict follows.
  const std::string under = ot_report(in, with_measure(in.result, label, key, threshold - 0.1));
  const std::string over = ot_report(in, with_measure(in.result, label, key, threshold + 0.5));
  EXPECT_NE(under.find(num(threshold - 0.1, 3) + " ±"), std::string::npos) << under;
  EXPECT_NE(over.find(num(threshold + 0.5, 3) + " ±"), std::string::npos) << over;
  if (!hh_ok) {
    EXPECT_NE(under.find("the collapse is measure-dependent"), std::string::npos) << under;
    EXPECT_NE(over.find("do **not** collapse onto two branches over the whole range under both "
                        "measures"),
              std::string::npos)
        << over;
    EXPECT_EQ(over.find("measure-dependent"), std::string::npos) << over;
  } else {
    EXPECT_NE(over.find("the collapse is measure-dependent"), std::string::npos) << over;
    EXPECT_NE(under.find("collapse onto two branches over the whole range under both measures"),
              std::string::npos)
        << under;
  }
}

}  // namespace
}  // namespace jamflow::studies
