// Statistical and systematic errors of the analyses' fits (error_model.hpp).
#include "analysis/error_model.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include "analysis/errors.hpp"
#include "analysis/format.hpp"

namespace jamflow::analysis {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

}  // namespace

double ParameterErrors::systematic() const {
  double s2 = 0.0;
  bool any = false;
  for (double s : {window, form}) {
    if (std::isfinite(s)) {
      s2 += s * s;
      any = true;
    }
  }
  return any ? std::sqrt(s2) : kNaN;
}

const ParameterErrors& ErrorModel::operator[](const std::string& name) const {
  for (const auto& p : parameters) {
    if (p.name == name)
      return p;
  }
  throw std::out_of_range("ErrorModel: no parameter " + name);
}

std::string degeneracy(const FitResult& fit, const std::vector<ParameterBound>& bounds) {
  std::string why;
  auto add = [&why](const std::string& s) { why += (why.empty() ? "" : "; ") + s; };
  for (std::size_t k = 0; k < fit.size(); ++k) {
    const Measured m = fit.at(k);
    for (const auto& b : bounds) {
      if (b.name != fit.names[k])
        continue;
      if (b.lower && m.value < *b.lower)
        add(b.name + " = " + fmt(m.value, "%.4g") +
            " is below its physical range (>= " + fmt(*b.lower, "%.4g") + ")");
      if (b.upper && m.value > *b.upper)
        add(b.name + " = " + fmt(m.value, "%.4g") +
            " is above its physical range (<= " + fmt(*b.upper, "%.4g") + ")");
    }
    if (!(m.error < std::fabs(m.value)))
      add(fit.names[k] + " = " + fmt(m.value, "%.4g") + " +- " + fmt(m.error, "%.4g") +
          " is not determined (error >= |value|)");
  }
  return why;
}

FitData drop_extreme_x(const FitData& data, bool highest) {
  if (data.size() == 0)
    return data;
  const double edge = highest ? *std::max_element(data.x.begin(), data.x.end())
                              : *std::min_element(data.x.begin(), data.x.end());
  std::vector<std::size_t> keep;
  for (std::size_t i = 0; i < data.size(); ++i) {
    if (!(std::fabs(data.x[i] - edge) <= 1e-9 * std::fabs(edge)))
      keep.push_back(i);
  }
  FitData out;
  for (std::size_t i : keep) {
    out.x.push_back(data.x[i]);
    out.y.push_back(data.y[i]);
    if (!data.sigma.empty())
      out.sigma.push_back(data.sigma[i]);
  }
  if (!data.covariance.empty()) {
    const std::size_t n = data.size();
    for (std::size_t i : keep) {
      for (std::size_t j : keep)
        out.covariance.push_back(data.covariance[i * n + j]);
    }
  }
  return out;
}

std::vector<double> window_shifts(const FitData& data, const FitResult& base,
                                  const std::function<FitResult(const FitData&)>& refit,
                                  const std::string& x_name, std::vector<std::string>& notes) {
  std::vector<double> shift(base.size(), kNaN);
  for (bool highest : {true, false}) {
    const FitData d = drop_extreme_x(data, highest);
    const std::string which =
        std::string("without the ") + (highest ? "largest " : "smallest ") + x_name;
    try {
      const FitResult f = refit(d);
      for (std::size_t k = 0; k < base.size(); ++k) {
        const double s = std::fabs(f.params.at(k) - base.params[k]);
        shift[k] = std::isfinite(shift[k]) ? std::max(shift[k], s) : s;
      }
    } catch (const AnalysisError& e) {
      notes.push_back("window refit " + which + " (" + std::to_string(d.size()) +
                      " points) not done: " + e.what());
    }
  }
  return shift;
}

FitResult fit_power_law_fixed_exponent(const FitData& data, const PowerLawForm& form, double b,
                                       const FitOptions& options) {
  // Linear in (a, c): the start is the weighted linear solution, which LM then confirms.
  const std::size_t n = data.size();
  double s11 = 0, s12 = 0, s22 = 0, t1 = 0, t2 = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double w = data.sigma.empty() ? 1.0 : 1.0 / (data.sigma[i] * data.sigma[i]);
    const double g = form.sign * std::pow(data.x[i], form.exponent_sign * b);
    s11 += w;
    s12 += w * g;
    s22 += w * g * g;
    t1 += w * data.y[i];
    t2 += w * g * data.y[i];
  }
  const double det = s11 * s22 - s12 * s12;
  double a0 = t1 / std::max(s11, 1e-300), c0 = 0.0;
  if (std::isfinite(det) && std::fabs(det) > 0.0) {
    a0 = (s22 * t1 - s12 * t2) / det;
    c0 = (s11 * t2 - s12 * t1) / det;
  }
  if (data.covariance.empty()) {
    // Uncorrelated data: the weighted linear least-squares solution is the fit (an iterative
    // solver started there has nothing to improve and may report no progress as failure).
    if (n < 3)
      throw InsufficientDataError(
          options.label + ": needs at least 3 points for 2 parameters, got " + std::to_string(n));
    if (!(std::isfinite(det) && det > 1e-300 * std::max(1.0, s11 * s22)))
      throw FitError(options.label + ": the amplitude is not determined (singular normal matrix)");
    FitResult r;
    r.names = {form.a_name, form.c_name};
    r.params = {a0, c0};
    for (std::size_t i = 0; i < n; ++i) {
      const double g = form.sign * std::pow(data.x[i], form.exponent_sign * b);
      r.chi2 += std::pow((data.y[i] - a0 - c0 * g) / data.sigma[i], 2);
    }
    r.dof = static_cast<int>(n) - 2;
    double scale = 1.0;
    if (options.scale_errors_by_chi2 && r.dof > 0 && r.chi2 / r.dof > 1.0) {
      scale = r.chi2 / r.dof;
      r.errors_scaled = true;
    }
    r.covariance = {scale * s22 / det, -scale * s12 / det, -scale * s12 / det, scale * s11 / det};
    return r;
  }
  ModelFunction model = [form, b](double x, std::span<const double> p, std::span<double> grad) {
    const double xp = std::pow(x, form.exponent_sign * b);
    if (!grad.empty()) {
      grad[0] = 1.0;
      grad[1] = form.sign * xp;
    }
    return p[0] + form.sign * p[1] * xp;
  };
  return fit_least_squares(data, model, {a0, c0}, {form.a_name, form.c_name}, options);
}

ErrorModel statistical_error_model(const FitResult& fit,
                                   const std::vector<ParameterBound>& bounds) {
  ErrorModel m;
  m.reduced_chi2 = fit.reduced_chi2();
  m.dof = fit.dof;
  m.errors_scaled = fit.errors_scaled;
  for (std::size_t k = 0; k < fit.size(); ++k) {
    ParameterErrors p;
    p.name = fit.names[k];
    p.value = fit.params[k];
    p.statistical = fit.at(k).error;
    p.window = kNaN;
    p.form = kNaN;
    m.parameters.push_back(p);
  }
  m.degenerate_reason = degeneracy(fit, bounds);
  m.degenerate = !m.degenerate_reason.empty();
  return m;
}

ErrorModel power_law_error_model(const FitData& data, const PowerLawForm& form,
                                 const FitResult& base, const FitOptions& options,
                                 std::optional<double> reference_b,
                                 const std::vector<ParameterBound>& bounds,
                                 const std::string& x_name) {
  ErrorModel m = statistical_error_model(base, bounds);
  FitOptions fo = options;
  const std::vector<double> window = window_shifts(
      data, base,
      [&](const FitData& d) {
        fo.label = options.label + ", window refit";
        return fit_power_law_offset(d, form, fo);
      },
      x_name, m.notes);
  for (std::size_t k = 0; k < m.parameters.size(); ++k)
    m.parameters[k].window = window[k];
  if (reference_b) {
    try {
      fo.label = options.label + ", " + form.b_name + " fixed at " + fmt(*reference_b, "%.4g");
      const FitResult fixed = fit_power_law_fixed_exponent(data, form, *reference_b, fo);
      for (std::size_t k = 0; k < m.parameters.size(); ++k) {
        const std::string& name = m.parameters[k].name;
        if (name == form.a_name)
          m.parameters[k].form = std::fabs(fixed.params[0] - base.params[k]);
        else if (name == form.c_name)
          m.parameters[k].form = std::fabs(fixed.params[1] - base.params[k]);
      }
    } catch (const AnalysisError& e) {
      m.notes.push_back("form refit with " + form.b_name + " fixed not done: " + e.what());
    }
  } else {
    m.notes.push_back("no reference " + form.b_name + ": no form systematic");
  }
  return m;
}

Scatter scatter_of(const std::vector<double>& x, const std::vector<double>& e) {
  Scatter out;
  double sw = 0.0, swx = 0.0;
  int n = 0;
  for (std::size_t k = 0; k < x.size() && k < e.size(); ++k) {
    if (!std::isfinite(x[k]) || !(e[k] > 0.0) || !std::isfinite(e[k]))
      continue;
    sw += 1.0 / (e[k] * e[k]);
    swx += x[k] / (e[k] * e[k]);
    ++n;
  }
  if (n < 2) {
    out.mean = n == 1 ? swx / sw : std::numeric_limits<double>::quiet_NaN();
    out.reduced_chi2 = std::numeric_limits<double>::quiet_NaN();
    return out;
  }
  out.mean = swx / sw;
  double chi2 = 0.0;
  for (std::size_t k = 0; k < x.size() && k < e.size(); ++k) {
    if (!std::isfinite(x[k]) || !(e[k] > 0.0) || !std::isfinite(e[k]))
      continue;
    chi2 += (x[k] - out.mean) * (x[k] - out.mean) / (e[k] * e[k]);
  }
  out.dof = n - 1;
  out.reduced_chi2 = chi2 / out.dof;
  out.error_scale = std::sqrt(std::max(1.0, out.reduced_chi2));
  return out;
}

}  // namespace jamflow::analysis
