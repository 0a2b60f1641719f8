// The summary of a run: block averages, errors, verdicts, the combination of replicas, and the
// summary printed at the end of `jamflow run`.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <type_traits>

#include "driver/run.hpp"
#include "driver/run_detail.hpp"
#include "driver/verdicts.hpp"
#include "lib/error.hpp"
#include "lib/statistics.hpp"

namespace jamflow {

using detail::short_num;

std::vector<double> Series::column(double Sample::*field) const {
  std::vector<double> v;
  v.reserve(samples.size());
  for (const auto& s : samples)
    v.push_back(s.*field);
  return v;
}

Verdict Verdict::parse(const std::string& text) {
  if (text == "pass")
    return pass();
  if (text.rfind("fail: ", 0) == 0)
    return fail(text.substr(6));
  if (text.rfind("not checked: ", 0) == 0)
    return not_checked(text.substr(13));
  return not_checked(text == "not checked" ? std::string() : text);
}

std::string Verdict::text() const {
  switch (outcome) {
    case Outcome::kPass:
      return "pass";
    case Outcome::kFail:
      return "fail: " + why;
    case Outcome::kNotChecked:
      break;
  }
  return why.empty() ? "not checked" : "not checked: " + why;
}

double Verdict::value() const {
  return passed() ? 1.0 : failed() ? 0.0 : std::numeric_limits<double>::quiet_NaN();
}

bool Summary::failed() const {
  return steady.failed() || stable.failed() || decorrelated.failed();
}

Verdict* Summary::verdict(std::string_view name) {
  for (const auto& [n, v] : kVerdicts)
    if (n == name)
      return &(this->*v);
  return nullptr;
}

namespace {

// Calls f(name, number) for every number of a summary under its name in run files: number is a
// double (always present) or a std::optional<double> (present where it applies). The one list
// of those names.
template <class S, class F>
void for_each_number(S& s, F&& f) {
  const auto estimate = [&](const std::string& name, auto& e, const std::string& err) {
    f(name, e.value);
    f(err, e.err);
    f(name + "_replica_err", e.replica_err);
  };
  for (auto [name, e] :
       {std::pair{"sigma_xy", &s.sigma_xy}, std::pair{"pressure", &s.pressure},
        std::pair{"phi", &s.phi}, std::pair{"energy", &s.energy}, std::pair{"mu", &s.mu}})
    estimate(name, *e, std::string(name) + "_err");
  estimate("energy_balance_corrected", s.energy_balance_corrected, "energy_balance_err");
  if (s.eta)
    estimate("eta", *s.eta, "eta_err");
  f("eta_block_std", s.eta_block_std);
  f("J", s.J);
  f("phi_block_std", s.phi_block_std);
  f("dissipation", s.dissipation);
  f("energy_balance", s.energy_balance);
  f("samples", s.samples);
  f("block_length", s.block_length);
  f("tau_sigma_xy", s.tau_sigma_xy);
  f("tau_pressure", s.tau_pressure);
  f("tau_phi", s.tau_phi);
  f("trend_t_phi", s.trend_t_phi);
  f("trend_t_sigma_xy", s.trend_t_sigma_xy);
  f("trend_t_pressure", s.trend_t_pressure);
  f("force_step_correlation", s.force_step_correlation);
  f("t_eq", s.t_eq);
  f("t_av", s.t_av);
  f("replicas", s.replicas);
  f("wall_seconds_total", s.wall_seconds_total);
  f("cpu_seconds_total", s.cpu_seconds_total);
}

}  // namespace

std::vector<std::pair<std::string, double>> Summary::values() const {
  std::vector<std::pair<std::string, double>> out;
  if (!computed)
    return out;
  for_each_number(*this, [&](const std::string& name, const auto& v) {
    if constexpr (std::is_same_v<std::decay_t<decltype(v)>, double>) {
      out.emplace_back(name, v);
    } else if (v) {
      out.emplace_back(name, *v);
    }
  });
  for (const auto& [name, v] : kVerdicts)
    out.emplace_back(name, (this->*v).value());
  std::sort(out.begin(), out.end());
  return out;
}

double Summary::value(std::string_view name) const {
  for (const auto& [n, v] : values())
    if (n == name)
      return v;
  return kNaN;
}

bool Summary::set(std::string_view name, double v) {
  const bool eta_name = name == "eta" || name == "eta_err" || name == "eta_replica_err";
  if (eta_name && !eta)
    eta.emplace();
  bool found = false;
  for_each_number(*this, [&](const std::string& n, auto& number) {
    if (n == name) {
      number = v;
      found = true;
    }
  });
  computed = computed || found;
  return found;
}

Summary summarize(const RunSpec& spec, const Series& series, const StepPairs* steps) {
  Summary sum;
  sum.computed = true;
  std::vector<Sample> win;
  const double t0 = spec.t_eq - 1e-9 * spec.sample_every;
  for (const auto& s : series.samples) {
    if (s.time >= t0)
      win.push_back(s);
  }
  // The t = t_eq sample closes equilibration; averages use the samples after it.
  if (!win.empty() && std::abs(win.front().time - spec.t_eq) < 1e-9 * spec.sample_every &&
      spec.t_eq > 0.0) {
    win.erase(win.begin());
  }
  const std::size_t nb = static_cast<std::size_t>(spec.blocks);
  if (win.size() < nb) {
    throw IntegrationError(
        "only " + std::to_string(win.size()) +
        " samples in the averaging window, fewer than blocks = " + std::to_string(nb));
  }
  Series w{win};
  const auto sigma = w.column(&Sample::sigma_xy);
  const auto press = w.column(&Sample::pressure);
  const auto phi = w.column(&Sample::phi);
  const auto energy = w.column(&Sample::energy);
  const double gdot = spec.shear_rate;
  std::vector<double> work(win.size()), loss(win.size());
  for (std::size_t k = 0; k < win.size(); ++k) {
    work[k] = win[k].sigma_xy * gdot * win[k].volume;
    loss[k] = win[k].dissipation + win[k].piston_dissipation;
  }
  const BlockAverage bs = block_average(sigma, nb);
  const BlockAverage bp = block_average(press, nb);
  const BlockAverage bphi = block_average(phi, nb);
  const BlockAverage be = block_average(energy, nb);
  const BlockAverage bw = block_average(work, nb);
  const BlockAverage bl = block_average(loss, nb);
  sum.sigma_xy = {bs.mean, bs.error, {}};
  sum.pressure = {bp.mean, bp.error, {}};
  sum.phi = {bphi.mean, bphi.error, {}};
  sum.phi_block_std = bphi.block_std;
  sum.energy = {be.mean, be.error, {}};
  sum.dissipation = bl.mean;
  sum.energy_balance = bl.mean > 0.0 ? bw.mean / bl.mean : Summary::kNaN;
  sum.samples = double(win.size());
  sum.block_length = double(win.size() / nb) * spec.sample_every;

  const std::optional<double> imposed = spec.ensemble->imposed_pressure();
  // mu = sigma / P: with the imposed P at constant pressure, else the block ratio.
  std::vector<double> mu_blocks(nb);
  for (std::size_t b = 0; b < nb; ++b) {
    mu_blocks[b] = bs.blocks[b] / (imposed ? *imposed : bp.blocks[b]);
  }
  const BlockAverage bmu = block_average(mu_blocks, nb);
  sum.mu = {imposed ? bs.mean / *imposed : bs.mean / bp.mean, bmu.error, {}};
  const double p_ref = imposed ? *imposed : bp.mean;
  if (gdot > 0.0) {
    sum.eta = Estimate{bs.mean / gdot, bs.error / gdot, {}};
    sum.eta_block_std = bs.block_std / gdot;
    sum.J = gdot / p_ref;  // J = gdot eta_0 / P with eta_0 = xi_s / a = 1
  }
  // Integrated autocorrelation times (in time units) of the main observables. Block errors
  // are only trustworthy when a block spans at least about 2 of them. A constant series (phi
  // at constant volume) has tau = half a sample and never warns.
  const std::tuple<const char*, const std::vector<double>*, double*> correlated[] = {
      {"sigma_xy", &sigma, &sum.tau_sigma_xy},
      {"pressure", &press, &sum.tau_pressure},
      {"phi", &phi, &sum.tau_phi}};
  const VerdictThresholds limits;
  std::string too_short;
  for (const auto& [name, series_ptr, tau_out] : correlated) {
    const double tau = integrated_autocorrelation(*series_ptr) * spec.sample_every;
    *tau_out = tau;
    if (!std::isfinite(tau) && too_short.empty()) {
      too_short = std::string("tau_") + name + " = " + short_num(tau) + " not finite";
    } else if (!(sum.block_length >= limits.decorrelation_blocks * tau) && too_short.empty()) {
      // How much too small the block errors are, for correlations that decay exponentially
      // (more if slower).
      const double low = 1.0 - block_error_ratio(sum.block_length, tau);
      char text[240];
      std::snprintf(text, sizeof text,
                    "blocks of %.4g are shorter than %g tau_%s = %.4g, so block errors are "
                    "about %.0f%% too small (more if correlations decay slower than "
                    "exponentially)",
                    sum.block_length, limits.decorrelation_blocks, name,
                    limits.decorrelation_blocks * tau, 100.0 * low);
      too_short = text;
    }
  }
  auto verdict = [&](const std::string& name, bool pass, const std::string& why) {
    *sum.verdict(name) = pass ? Verdict::pass() : Verdict::fail(why);
  };
  // A value that is not a number (0 / 0 with no contacts, say) fails the verdict that rests on
  // it: NaN would pass every test written as !(x > limit).
  const auto not_finite = [&](std::initializer_list<const char*> keys) {
    std::string bad;
    const auto present = sum.values();  // an absent number (eta without shear) is not checked
    for (const char* key : keys)
      for (const auto& [name, v] : present)
        if (name == key && !std::isfinite(v))
          bad += (bad.empty() ? "" : ", ") + name + " = " + short_num(v);
    return bad.empty() ? bad : bad + " not finite";
  };
  // decorrelated: every block at least 2 tau long.
  const bool undefined_tau = too_short.find(" not finite") != std::string::npos;
  verdict("decorrelated", too_short.empty(), too_short + (undefined_tau ? "" : "; lengthen t_av"));

  // steady: no significant trend of the block means.
  std::string drift;
  double worst = 0.0;
  for (const auto& [name, b, t_out] :
       {std::tuple<const char*, const BlockAverage*, double*>{"phi", &bphi, &sum.trend_t_phi},
        {"sigma_xy", &bs, &sum.trend_t_sigma_xy},
        {"pressure", &bp, &sum.trend_t_pressure}}) {
    const double t = trend_t(b->blocks);
    *t_out = t;
    if (std::abs(t) > worst || !std::isfinite(t)) {
      worst = std::isfinite(t) ? std::abs(t) : std::numeric_limits<double>::infinity();
      if (!(std::abs(t) <= limits.trend_t_max)) {
        char text[200];
        std::snprintf(text, sizeof text,
                      "%s drifts from %.6g (first block) to %.6g (last), trend t = %.3g over "
                      "%zu blocks (allowed |t| <= %g)",
                      name, b->blocks.front(), b->blocks.back(), t, nb, limits.trend_t_max);
        drift = text;
      }
    }
  }
  if (const std::string bad = not_finite({"sigma_xy", "sigma_xy_err", "pressure", "pressure_err",
                                          "phi", "phi_err", "eta", "eta_err", "mu", "mu_err", "J"});
      drift.empty() && !bad.empty())
    verdict("steady", false, bad);
  else
    verdict("steady", drift.empty(), drift + "; lengthen t_eq");

  // stable: energy balance and no step-to-step oscillation of the forces.
  const EnergyBalance eb = energy_balance(series.samples, spec.t_eq, gdot, imposed, nb);
  sum.energy_balance_corrected = {eb.ratio, eb.error, {}};
  std::string unstable, unchecked;
  if (gdot > 0.0 && !std::isfinite(sum.energy_balance)) {
    char text[200];
    std::snprintf(text, sizeof text,
                  "energy balance = %s not finite (work %.4g / dissipation %.4g)",
                  short_num(sum.energy_balance).c_str(), bw.mean, bl.mean);
    unstable = text;
  } else if (eb.valid) {
    const double allowed = std::max(limits.balance_tolerance, limits.balance_sigmas * eb.error);
    if (eb.residual > allowed) {
      char text[200];
      std::snprintf(text, sizeof text,
                    "energy balance %.4g +- %.2g (work / dissipation, enthalpy drift removed); "
                    "allowed within %.3g of 1",
                    eb.ratio, eb.error, allowed);
      unstable = text;
    }
  } else {
    unchecked = gdot > 0.0 ? "energy balance not available" : "no shear: no energy balance";
  }
  if (steps && steps->pairs > 0) {
    sum.force_step_correlation = steps->correlation();
    if (!(steps->correlation() >= limits.force_correlation_min) && unstable.empty()) {
      char text[200];
      std::snprintf(text, sizeof text,
                    "forces at consecutive steps correlate %.3g (period-2 share of the force "
                    "power %.1f%%); allowed >= %g: lower dt",
                    steps->correlation(), 50.0 * (1.0 - steps->correlation()),
                    limits.force_correlation_min);
      unstable = text;
    }
  } else if (!unchecked.empty()) {
    unchecked += "; adaptive integrator: no step-to-step test";
  }
  if (!unstable.empty()) {
    verdict("stable", false, unstable);
  } else if (!unchecked.empty() && !(steps && steps->pairs > 0)) {
    sum.stable = Verdict::not_checked(unchecked);
  } else {
    verdict("stable", true, "");
  }
  for (const auto& [name, v] : kVerdicts) {
    if ((sum.*v).failed())
      sum.warnings.push_back("not " + std::string(name) + ": " + (sum.*v).why);
  }
  return sum;
}

Summary combine_replicas(const std::vector<Summary>& summaries) {
  if (summaries.empty())
    throw std::invalid_argument("combine_replicas: no replicas");
  const auto k = summaries.size();
  Summary out;
  out.computed = true;
  // An estimate: mean, propagated block error and replica scatter; absent unless every
  // replica has it.
  const auto estimate = [&](auto of) -> std::optional<Estimate> {
    std::vector<double> means, errors;
    for (const auto& s : summaries) {
      const std::optional<Estimate> e = of(s);
      if (!e)
        return std::nullopt;
      means.push_back(e->value);
      errors.push_back(e->err);
    }
    const ReplicaAverage ra = replica_average(means, errors);
    return Estimate{ra.mean, ra.block_error, ra.replica_error};
  };
  for (Estimate Summary::*m : {&Summary::sigma_xy, &Summary::pressure, &Summary::phi,
                               &Summary::energy, &Summary::mu, &Summary::energy_balance_corrected})
    out.*m = *estimate([m](const Summary& s) { return std::optional<Estimate>(s.*m); });
  out.eta = estimate([](const Summary& s) { return s.eta; });
  // A number without an error: the plain mean (absent unless every replica has it).
  const auto mean = [&](auto of) -> std::optional<double> {
    double sum = 0.0;
    for (const auto& s : summaries) {
      const std::optional<double> v = of(s);
      if (!v)
        return std::nullopt;
      sum += *v;
    }
    return sum / double(k);
  };
  for (double Summary::*m :
       {&Summary::phi_block_std, &Summary::dissipation, &Summary::energy_balance, &Summary::samples,
        &Summary::block_length, &Summary::tau_sigma_xy, &Summary::tau_pressure, &Summary::tau_phi,
        &Summary::trend_t_phi, &Summary::trend_t_sigma_xy, &Summary::trend_t_pressure})
    out.*m = *mean([m](const Summary& s) { return std::optional<double>(s.*m); });
  for (std::optional<double> Summary::*m :
       {&Summary::eta_block_std, &Summary::J, &Summary::force_step_correlation, &Summary::t_eq,
        &Summary::t_av})
    out.*m = mean([m](const Summary& s) { return s.*m; });
  out.replicas = double(k);
  // A verdict of the replicas passes only if it passes for each of them.
  for (const auto& named : kVerdicts) {
    const auto member = named.second;
    Verdict combined = Verdict::pass();
    for (std::size_t r = 0; r < k; ++r) {
      const Verdict& v = summaries[r].*member;
      if (v.failed()) {
        combined = Verdict::fail("replica " + std::to_string(r) + ": " + v.why);
        break;
      }
      if (!v.passed() && combined.passed())
        combined = v;
    }
    out.*member = combined;
  }
  for (std::size_t r = 0; r < k; ++r) {
    for (const auto& w : summaries[r].warnings)
      out.warnings.push_back("replica " + std::to_string(r) + ": " + w);
  }
  return out;
}

Summary combined_summary(const std::vector<ReplicaResult>& replicas) {
  if (replicas.size() == 1)
    return replicas.front().summary;
  std::vector<Summary> sums;
  for (const auto& r : replicas)
    sums.push_back(r.summary);
  return combine_replicas(sums);
}

namespace detail {

// Prints the summary; returns whether a verdict failed.
bool print_summary(const RunSpec& spec, const std::vector<ReplicaResult>& results) {
  std::vector<Summary> sums;
  double wall = 0.0, cpu = 0.0, equivalents = 0.0;
  bool cpu_from_wall = false;
  for (const auto& r : results) {
    sums.push_back(r.summary);
    wall += r.wall_seconds;
    cpu += r.cpu_seconds;
    cpu_from_wall = cpu_from_wall || r.cpu_from_wall;
    equivalents += statistic(r.integrator_stats, "force_pass_equivalents");
  }
  const std::size_t count = results.size();
  const Summary combined = count > 1 ? combine_replicas(sums) : results.front().summary;
  for (const auto& wmsg : combined.warnings)
    std::fprintf(stderr, "warning: %s\n", wmsg.c_str());
  std::printf("jamflow run: N = %lld, %s, %s, gdot = %g -> %s\n", (long long)spec.n,
              spec.ensemble->name().c_str(), spec.integrator.kind.c_str(), spec.shear_rate,
              spec.file.c_str());
  std::printf("  kernel         = %s on %s, %d thread%s\n", results.front().kernel.c_str(),
              results.front().kernel_target.c_str(), results.front().threads,
              results.front().threads == 1 ? "" : "s");
  if (count > 1) {
    std::printf("  mean over %zu replicas +- block error +- replica-scatter error\n", count);
  }
  // With replicas: "value +- block error +- replica error"; alone: "value +- block error".
  auto line = [&](const char* label, const std::optional<Estimate>& e, const char* value_format) {
    const Estimate x = e.value_or(Estimate{});
    std::printf("  %-14s = ", label);
    std::printf(value_format, x.value);
    std::printf(" +- %.2e", x.err);
    if (count > 1)
      std::printf(" +- %.2e", x.replica_err.value_or(Summary::kNaN));
    std::printf("\n");
  };
  line("phi", combined.phi, "%.6f");
  line("pressure", combined.pressure, "%.6e");
  line("sigma_xy", combined.sigma_xy, "%.6e");
  line("eta", combined.eta, "%.6e");
  line("mu", combined.mu, "%.6f");
  std::printf("  J              = %.6e\n", combined.J.value_or(Summary::kNaN));
  std::printf("  energy_balance = %.4f\n", combined.energy_balance);
  std::printf("  tau_sigma_xy   = %.4g\n", combined.tau_sigma_xy);
  for (const auto& [name, v] : kVerdicts)
    std::printf("  %-14s = %s\n", name, (combined.*v).text().c_str());
  if (spec.auto_eq || spec.auto_av) {
    for (std::size_t r = 0; r < results.size(); ++r) {
      const auto& t = results[r].summary;
      std::printf("  %-14s = %s%.6g after t_eq = %.6g (%s)\n", "t_av",
                  count > 1 ? ("replica " + std::to_string(r) + ": ").c_str() : "",
                  t.t_av.value_or(Summary::kNaN), t.t_eq.value_or(Summary::kNaN),
                  t.run_length.value_or("").c_str());
    }
  }
  std::printf("  force passes   = %.6g force-pass equivalents%s\n", equivalents,
              count > 1 ? " (all replicas)" : "");
  std::printf("  cpu time       = %.2f s%s\n", cpu,
              cpu_from_wall ? " (partly wall time: continued from an older checkpoint)" : "");
  std::printf("  wall time      = %.2f s\n", wall);
  return combined.failed();
}

}  // namespace detail

}  // namespace jamflow
