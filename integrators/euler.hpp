// Explicit (forward) Euler, first order:
//   r <- r + dt (F / xi_s + gdot y e_x),  strain += gdot dt,  V += dt dV/dt.
// Stable for dt below about 2 / (largest contact stiffness); SPEC §4 documents that period-2
// oscillations inflate the dissipation well before the run diverges.
#pragma once
#include "integrators/integrator.hpp"

namespace jamflow {

class Euler final : public Integrator {
 public:
  explicit Euler(double dt);
  std::string name() const override { return "euler"; }
  using Integrator::order;
  int order() const override { return 1; }
  // One force pass per step.
  double force_passes_per_time(const Ensemble& ensemble) const override;
  void advance(Model& model, const Ensemble& ensemble, double t_end) override;
  std::vector<std::pair<std::string, double>> statistics() const override;
  void restore_statistics(const std::vector<std::pair<std::string, double>>& stats) override {
    steps_ = static_cast<long long>(statistic(stats, "steps"));
  }
  double nominal_dt() const override { return dt_; }

 private:
  double dt_;
  long long steps_ = 0;
};

}  // namespace jamflow
