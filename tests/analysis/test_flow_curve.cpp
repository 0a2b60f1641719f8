// `jamflow analyze flow-curve`: power law, Herschel–Bulkley and eta(phi) divergence recovered
// from synthetic curves of known parameters, the chi2/dof error scaling, verdict admission,
// and the exit codes of every analysis on a single flow curve (analysis/README.md: 2 for data
// that cannot support the analysis).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "analysis/analyze_cli.hpp"
#include "analysis/errors.hpp"
#include "analysis/flow_curve.hpp"
#include "analysis/json.hpp"
#include "tests/analysis/test_util.hpp"

namespace jamflow::analysis {
namespace {

using testing::CliRun;
using testing::num;
using testing::read_text;
using testing::run_analyze;
using testing::ScratchDir;

std::size_t lines(const std::string& s) {
  return static_cast<std::size_t>(std::count(s.begin(), s.end(), '\n'));
}

// A constant-volume curve at phi: sigma = f(gdot) with relative error `rel`, drawn about the
// law with the seeded generator (noise = false: exactly on the law).
std::vector<ShearPoint> curve(double phi, const std::vector<double>& rates, double rel,
                              const std::function<double(double)>& f, std::mt19937_64* rng) {
  std::vector<ShearPoint> out;
  std::normal_distribution<double> gauss;
  for (double g : rates) {
    ShearPoint p;
    p.n = 1000;
    p.phi = phi;
    p.shear_rate = g;
    const double s = f(g);
    p.sigma_err = rel * s;
    p.sigma = s + (rng ? gauss(*rng) * p.sigma_err : 0.0);
    p.set = "N=1000,phi=" + format_key(phi);
    p.source = "synthetic";
    out.push_back(p);
  }
  return out;
}

std::vector<double> decades(double lo, double hi, int n) {
  std::vector<double> out;
  for (int k = 0; k < n; ++k)
    out.push_back(lo * std::pow(hi / lo, static_cast<double>(k) / (n - 1)));
  return out;
}

// The recovered parameter within `z` of its error of the true value. One draw with a fixed
// seed: at z = 4 a correct fit fails with probability ~6e-5 per parameter, and the errors are
// required to be small as well, so a fit that merely reports huge errors fails.
void expect_recovered(const FitResult& f, const std::string& name, double truth, double z,
                      double max_rel_error) {
  const Measured m = f[name];
  EXPECT_LE(std::fabs(m.value - truth), z * m.error)
      << name << " = " << m.value << " +- " << m.error << ", truth " << truth;
  EXPECT_LT(m.error, max_rel_error * std::fabs(truth)) << name;
}

TEST(FlowCurve, PowerLawRecovered) {
  std::mt19937_64 rng(11);
  auto pts = curve(
      0.6, decades(1e-6, 1e-2, 9), 0.02, [](double g) { return 2.0 * std::pow(g, 0.45); }, &rng);
  FitOptions o;
  const FitResult f = fit_flow_power_law(pts, o);
  expect_recovered(f, "A", 2.0, 4.0, 0.1);
  expect_recovered(f, "n", 0.45, 4.0, 0.05);
  EXPECT_EQ(f.dof, 7);
}

TEST(FlowCurve, HerschelBulkleyRecoversTheYieldStress) {
  std::mt19937_64 rng(12);
  auto pts = curve(
      0.66, decades(1e-6, 1e-2, 10), 0.01, [](double g) { return 0.01 + 0.5 * std::pow(g, 0.5); },
      &rng);
  const FitResult f = fit_herschel_bulkley(pts, FitOptions{});
  expect_recovered(f, "sigma_y", 0.01, 4.0, 0.1);
  expect_recovered(f, "K", 0.5, 4.0, 0.1);
  expect_recovered(f, "n", 0.5, 4.0, 0.05);
  // The yield stress is resolved: far from zero in its error.
  EXPECT_GT(f["sigma_y"].value, 5.0 * f["sigma_y"].error);
}

TEST(FlowCurve, DivergenceRecoversPhiC) {
  std::mt19937_64 rng(13);
  std::normal_distribution<double> gauss;
  const double phi_c = 0.645, beta = 2.0, eta0 = 0.05;
  std::vector<double> phi, eta, err;
  for (double p = 0.55; p < 0.641; p += 0.0125) {
    const double e = eta0 * std::pow(phi_c - p, -beta);
    phi.push_back(p);
    err.push_back(0.02 * e);
    eta.push_back(e + gauss(rng) * 0.02 * e);
  }
  ASSERT_EQ(phi.size(), 8u);
  const FitResult f = fit_divergence(phi, eta, err, FitOptions{});
  expect_recovered(f, "phi_c", phi_c, 4.0, 0.01);
  expect_recovered(f, "beta", beta, 4.0, 0.1);
  expect_recovered(f, "ln_eta0", std::log(eta0), 4.0, 0.1);
}

// chi2/dof = 4 doubles the errors: the same data fitted with and without the scaling.
TEST(FlowCurve, ChiSquarePerDofOfFourDoublesTheErrors) {
  std::mt19937_64 rng(14);
  auto pts = curve(
      0.6, decades(1e-5, 1e-1, 8), 0.02, [](double g) { return 1.5 * std::pow(g, 0.4); }, &rng);
  FitOptions unscaled;
  unscaled.scale_errors_by_chi2 = false;
  const FitResult first = fit_flow_power_law(pts, unscaled);
  // Errors rescaled so that chi2/dof is exactly 4 at the same optimum.
  const double c = first.reduced_chi2();
  for (auto& p : pts)
    p.sigma_err *= std::sqrt(c / 4.0);
  const FitResult plain = fit_flow_power_law(pts, unscaled);
  const FitResult scaled = fit_flow_power_law(pts, FitOptions{});
  ASSERT_NEAR(scaled.reduced_chi2(), 4.0, 1e-6);
  EXPECT_TRUE(scaled.errors_scaled);
  EXPECT_FALSE(plain.errors_scaled);
  for (const char* k : {"A", "n"})
    EXPECT_NEAR(scaled[k].error / plain[k].error, 2.0, 1e-5) << k;
  // The same through the analysis, which states it.
  FlowCurveOptions o;
  const FlowCurveResult r = analyze_flow_curves(pts, o);
  ASSERT_EQ(r.curves.size(), 1u);
  ASSERT_EQ(r.curves[0].power_law.status, FlowFit::Status::kFit);
  EXPECT_TRUE(r.curves[0].power_law.fit.errors_scaled);
  EXPECT_NEAR(r.curves[0].power_law.fit["n"].error / plain["n"].error, 2.0, 1e-5);
}

// Curves below phi_c are Newtonian (sigma = eta(phi) gdot); one above has a yield stress and is
// left out of the divergence fit at each rate, with the reason.
TEST(FlowCurve, DivergenceOverConstantVolumeCurvesLeavesOutTheJammedOne) {
  const double phi_c = 0.64, beta = 2.2, eta0 = 0.03;
  const std::vector<double> rates = {1e-5, 1e-4, 1e-3, 1e-2};
  std::vector<ShearPoint> pts;
  for (double phi : {0.56, 0.58, 0.60, 0.61, 0.62, 0.63}) {
    const double eta = eta0 * std::pow(phi_c - phi, -beta);
    auto c = curve(
        phi, rates, 0.01, [eta](double g) { return eta * g; }, nullptr);
    pts.insert(pts.end(), c.begin(), c.end());
  }
  auto jammed = curve(
      0.66, rates, 0.01, [](double g) { return 0.02 + 0.4 * std::sqrt(g); }, nullptr);
  pts.insert(pts.end(), jammed.begin(), jammed.end());
  const FlowCurveResult r = analyze_flow_curves(pts, FlowCurveOptions{});
  EXPECT_EQ(r.curves.size(), 7u);
  ASSERT_EQ(r.divergences.size(), rates.size());
  for (const auto& d : r.divergences) {
    ASSERT_EQ(d.fit.status, FlowFit::Status::kFit) << d.group << ": " << d.fit.reason;
    EXPECT_EQ(d.fit.points_used, 6u);
    // Exact data: the law itself, to the fit's precision.
    EXPECT_NEAR(d.fit.fit["phi_c"].value, phi_c, 1e-6) << d.group;
    EXPECT_NEAR(d.fit.fit["beta"].value, beta, 1e-4) << d.group;
    ASSERT_EQ(d.fit.left_out.size(), 1u) << d.group;
    EXPECT_NE(d.fit.left_out[0].why.find("yield stress"), std::string::npos);
    ASSERT_EQ(d.fit.derived.size(), 1u);
    EXPECT_NEAR(d.fit.derived[0].second.value, eta0, 1e-4);
  }
}

TEST(FlowCurve, TooFewPointsThrowsInsufficientData) {
  auto pts = curve(
      0.6, {1e-4, 1e-3}, 0.02, [](double g) { return g; }, nullptr);
  EXPECT_THROW(analyze_flow_curves(pts, FlowCurveOptions{}), InsufficientDataError);
  // Three points: the power law only; Herschel–Bulkley is skipped with a warning.
  std::mt19937_64 rng(16);
  pts = curve(
      0.6, {1e-4, 1e-3, 1e-2}, 0.02, [](double g) { return std::sqrt(g); }, &rng);
  const FlowCurveResult r = analyze_flow_curves(pts, FlowCurveOptions{});
  EXPECT_EQ(r.curves[0].power_law.status, FlowFit::Status::kFit) << r.curves[0].power_law.reason;
  EXPECT_EQ(r.curves[0].herschel_bulkley.status, FlowFit::Status::kSkipped);
  EXPECT_NE(r.curves[0].herschel_bulkley.reason.find("needs at least 4 points"), std::string::npos)
      << r.curves[0].herschel_bulkley.reason;
  EXPECT_EQ(r.warnings.size(), 1u);
}

std::string cv_table(const std::vector<ShearPoint>& pts, const std::vector<std::string>& steady) {
  std::string s = "N,phi,shear_rate,sigma_xy,sigma_xy_err,replicas,steady,stable,decorrelated\n";
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const auto& p = pts[i];
    s += std::to_string(p.n) + "," + num(p.phi) + "," + num(p.shear_rate) + "," + num(p.sigma) +
         "," + num(p.sigma_err) + ",1," + steady[i] + ",1,1\n";
  }
  return s;
}

TEST(FlowCurveCli, WritesFitsAndAdmitsFailedRowsOnlyWhenAsked) {
  ScratchDir dir;
  std::mt19937_64 rng(15);
  auto pts = curve(
      0.66, decades(1e-6, 1e-2, 7), 0.01, [](double g) { return 0.01 + 0.5 * std::pow(g, 0.5); },
      &rng);
  // The row at the third rate (line 4 of the file) was not steady.
  const auto data = dir.write("t.csv", cv_table(pts, {"1", "1", "0", "1", "1", "1", "1"}));
  const std::string out = dir.file("fc.json");

  CliRun r = run_analyze({"flow-curve", data, "-o", out, "--no-plots"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("1 of 7 rows left out"), std::string::npos) << r.err;
  Json j = Json::parse(read_text(out));
  EXPECT_FALSE(j.at("include_failed").as_bool());
  ASSERT_EQ(j.at("left_out_for_verdicts").size(), 1u);
  EXPECT_EQ(j.at("left_out_for_verdicts").at(0).as_string(), data + ":4: not steady");
  const Json& c = j.at("curves").at(0);
  EXPECT_EQ(c.at("points").size(), 6u);
  const Json& hb = c.at("herschel_bulkley");
  EXPECT_EQ(hb.at("status").as_string(), "fit");
  EXPECT_EQ(hb.at("points_used").as_number(), 6.0);
  for (const char* k : {"sigma_y", "K", "n"}) {
    EXPECT_TRUE(hb.at("parameters").at(k).at("value").is_number()) << k;
    EXPECT_GT(hb.at("parameters").at(k).at("error").as_number(), 0.0) << k;
  }
  EXPECT_TRUE(hb.at("reduced_chi2").is_number());
  EXPECT_TRUE(std::filesystem::exists(dir.file("fc.md")));

  r = run_analyze({"flow-curve", data, "-o", out, "--no-plots", "--include-failed"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("1 of 7 rows included and marked although"), std::string::npos) << r.err;
  j = Json::parse(read_text(out));
  EXPECT_TRUE(j.at("include_failed").as_bool());
  EXPECT_EQ(j.at("left_out_for_verdicts").size(), 0u);
  const Json& points = j.at("curves").at(0).at("points");
  ASSERT_EQ(points.size(), 7u);
  int marked = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (points.at(i).at("verdicts_failed").as_bool()) {
      ++marked;
      EXPECT_EQ(points.at(i).at("source").as_string(), data + ":4");
      EXPECT_EQ(points.at(i).at("failed_verdicts").as_string(), "not steady");
    }
  }
  EXPECT_EQ(marked, 1);
  const Json& fit = j.at("curves").at(0).at("power_law");
  EXPECT_EQ(fit.at("points_used").as_number(), 7.0);
  ASSERT_EQ(fit.at("failed_verdicts_included").size(), 1u);
  const std::string md = read_text(dir.file("fc.md"));
  EXPECT_NE(md.find("included although its verdicts failed: " + data + ":4 (not steady)"),
            std::string::npos)
      << md;
}

// The reader's verdict admission (the one rule every analysis uses): rows left out are listed;
// admitted, they are marked, and a state point merged with a failed repeat is marked too.
TEST(FlowCurve, ReaderAdmitsFailedRowsMarkedAndListsThoseLeftOut) {
  ScratchDir dir;
  std::mt19937_64 rng(17);
  auto pts = curve(
      0.6, {1e-4, 1e-3, 1e-2}, 0.02, [](double g) { return g; }, &rng);
  const auto a = dir.write("a.csv", cv_table(pts, {"1", "0", "1"}));
  for (auto& p : pts)
    p.sigma *= 1.01;  // an independent repeat of the same state points, all steady
  const auto b = dir.write("b.csv", cv_table(pts, {"1", "1", "1"}));
  std::vector<std::string> left;
  VerdictAdmission v;
  v.left_out = &left;
  ::testing::internal::CaptureStderr();
  auto kept = read_shear({a, b}, v);
  ASSERT_EQ(left.size(), 1u);
  EXPECT_EQ(left[0], a + ":3: not steady");
  for (const auto& p : kept)
    EXPECT_TRUE(p.failed_verdicts.empty()) << p.source;
  v.include_failed = true;
  left.clear();
  auto all = read_shear({a, b}, v);
  (void)::testing::internal::GetCapturedStderr();
  EXPECT_TRUE(left.empty());
  ASSERT_EQ(all.size(), 3u);  // merged by state point
  for (const auto& p : all)
    EXPECT_EQ(p.failed_verdicts, p.shear_rate == 1e-3 ? "not steady" : "") << p.source;
}

TEST(FlowCurveCli, TooFewPointsExitsTwoWithOneLine) {
  ScratchDir dir;
  auto pts = curve(
      0.6, {1e-4, 1e-3}, 0.02, [](double g) { return g; }, nullptr);
  const auto data = dir.write("t.csv", cv_table(pts, {"1", "1"}));
  CliRun r = run_analyze({"flow-curve", data, "-o", dir.file("fc.json"), "--no-plots"});
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(lines(r.err), 1u) << r.err;
  EXPECT_NE(r.err.find("needs at least 3 points"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("fc.json")));
}

// A single flow curve cannot support hard-sphere, soft or olsson-teitel: exit 2 for each
// (README: "data that cannot support the analysis"), at constant pressure and at constant
// volume; flow-curve fits it.
TEST(FlowCurveCli, EveryAnalysisOnASingleFlowCurveExitsAsTheReadmeSays) {
  ScratchDir dir;
  std::string cp = "N,imposed_pressure,shear_rate,phi,phi_err,mu,mu_err\n";
  for (double g : decades(1e-9, 1e-5, 5)) {
    const double j = g / 1e-4;
    cp += "1000,1e-4," + num(g) + "," + num(0.645 - 0.3 * std::pow(j, 0.38)) + ",0.0005," +
          num(0.1 + 0.6 * std::pow(j, 0.36)) + ",0.002\n";
  }
  const auto cp_file = dir.write("cp.csv", cp);
  auto pts = curve(
      0.66, decades(1e-6, 1e-2, 5), 0.01, [](double g) { return 0.001 + 0.5 * std::sqrt(g); },
      nullptr);
  const auto cv_file = dir.write("cv.csv", cv_table(pts, {"1", "1", "1", "1", "1"}));
  for (const std::string& file : {cp_file, cv_file}) {
    for (const char* analysis : {"hard-sphere", "soft", "olsson-teitel"}) {
      CliRun r = run_analyze({analysis, file, "-o", dir.file("x.json"), "--no-plots"});
      EXPECT_EQ(r.code, 2) << analysis << " on " << file << ": " << r.err;
      EXPECT_NE(r.err.find("error:"), std::string::npos) << r.err;
    }
    CliRun r = run_analyze({"flow-curve", file, "-o", dir.file("fc.json"), "--no-plots"});
    EXPECT_EQ(r.code, 0) << file << ": " << r.err;
  }
}

}  // namespace
}  // namespace jamflow::analysis
