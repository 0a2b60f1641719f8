// Ensemble comparison (the seed's Fig. 1, sec. "Model and numerical methods"): a comparison plan
// run by `jamflow compare` (framework/compare.hpp). Each preset is a compare file in this
// folder (quick.toml, standard.toml, paper.toml): relaxed random starts, constant pressure
// P = 1e-5 (Kolb–Dünweg piston) from them, and constant volume continued from each
// constant-pressure replica at the packing fraction they reached. The comparison reports the
// block and replica spreads of the viscosity, phi and P_hat in each ensemble and their ratios;
// this file adds the seed's numbers beside them. See README.md.
#include <cmath>
#include <string>

#include "analysis/seed.hpp"
#include "framework/compare.hpp"
#include "framework/study.hpp"
#include "framework/table_report.hpp"
#include "studies/common.hpp"

namespace jamflow::studies {
namespace {

const analysis::ObservableResult* observable(const ComparePlan& plan,
                                             const analysis::CompareResult& res,
                                             const std::string& setting, const std::string& name) {
  for (std::size_t s = 0; s < res.settings.size(); ++s) {
    if (res.settings[s].label != setting)
      continue;
    for (std::size_t o = 0; o < plan.observables.size(); ++o)
      if (plan.observables[o] == name && o < res.settings[s].observables.size())
        return &res.settings[s].observables[o];
  }
  return nullptr;
}

// The seed's Fig. 1 numbers beside this comparison's: the ratio NV/NP of the viscosity's block
// standard deviation, and the spread of phi over the constant-pressure replicas. In sigma only
// at the seed's state point (J = 3.98e-9 / 1e-5); elsewhere side by side.
std::string seed_section(const std::vector<CompareCaseOutcome>& cases) {
  const ComparePlan& plan = *cases.front().plan;
  const analysis::CompareResult& res = *cases.front().result;
  const Scene np = plan.setting_scene(plan.reference);
  const double gdot = np.section("shear").number("rate", 0.0, Range::non_negative());
  const double pressure = np.section("ensemble").number("pressure", 0.0, Range::non_negative());
  const double j = pressure > 0.0 ? gdot / pressure : std::nan("");
  const double seed_j = seed::kEnsembleRate / seed::kEnsemblePressure;
  const bool seed_point = std::abs(j / seed_j - 1.0) < 0.05;
  const auto* eta = observable(plan, res, "constant_volume", "eta");
  const auto* phi = observable(plan, res, "constant_pressure", "phi");
  std::string md = "## The seed's Fig. 1\n\n";
  md += "Seed (N = 1000, gdot = " + num(seed::kEnsembleRate, 3) + ", J = " + num(seed_j, 3) +
        "): the block standard deviation of the viscosity is about " +
        num(seed::kEnsembleStdRatio, 2) +
        "x smaller at constant pressure, and the standard deviation of phi over three "
        "constant-pressure runs is about " +
        num(seed::kEnsemblePhiSpread, 2) + ".\n\n";
  md += "Here (J = " + num(j, 3) + "): block std of eta, constant volume over constant pressure = ";
  if (eta && std::isfinite(eta->block_std_ratio.value)) {
    md += pm(eta->block_std_ratio.value, eta->block_std_ratio.error, 3);
    md += seed_point
              ? " (" +
                    sigma_text(eta->block_std_ratio.value, eta->block_std_ratio.error,
                               seed::kEnsembleStdRatio) +
                    " from the seed's " + num(seed::kEnsembleStdRatio, 2) + ")"
              : " (not compared in sigma with the seed's ~" + num(seed::kEnsembleStdRatio, 2) +
                    ": that was measured at J = " + num(seed_j, 3) + ", another state point)";
  } else {
    md += "not measured (a setting did not finish)";
  }
  md += "; standard deviation of phi over the constant-pressure replicas = ";
  md += phi && std::isfinite(phi->replica_std.value)
            ? pm(phi->replica_std.value, phi->replica_std.error, 3) + " (" +
                  std::to_string(plan.replicas) + " replicas)"
            : std::string("not measured (needs 2 replicas)");
  md +=
      ". The block standard deviation depends on the block length against the correlation "
      "time τ of each ensemble (the fluctuation table gives both).\n\n";
  return md;
}

int run_ensemble_study(const StudyOptions& options) {
  return run_compare(study_compare_plan("ensemble", options.preset), options, seed_section);
}

const Registrar registrar{
    {"ensemble",
     "constant pressure vs constant volume at the same shear rate (the seed's Fig. 1): block "
     "and replica spreads of the viscosity, phi and P_hat in each ensemble (a compare plan)",
     run_ensemble_study}};

}  // namespace
}  // namespace jamflow::studies
