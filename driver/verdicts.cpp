// The verdicts' numerics (driver/verdicts.hpp).
#include "driver/verdicts.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace jamflow {

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
}  // namespace

// ---- StepCorrelation ------------------------------------------------------------------------

void StepCorrelation::add(const std::vector<double>& v) {
  for (double x : v) {
    if (!std::isfinite(x)) {
      finite_ = false;
      return;
    }
  }
  if (!prev_.empty() && prev_.size() == v.size()) {
    double cross = 0.0, norm = 0.0;
    std::size_t reversed = 0;
    const std::size_t groups = group_ > 0 ? v.size() / group_ : 0;
    for (std::size_t g = 0; g < groups; ++g) {
      double d = 0.0;
      for (std::size_t c = 0; c < group_; ++c) {
        const std::size_t k = g * group_ + c;
        d += v[k] * prev_[k];
        norm += 0.5 * (v[k] * v[k] + prev_[k] * prev_[k]);
      }
      cross += d;
      if (d < 0.0)
        ++reversed;
    }
    cross_ += cross;
    norm_ += norm;
    reversed_ += groups > 0 ? double(reversed) / double(groups) : 0.0;
    ++pairs_;
  }
  prev_ = v;
}

void StepPairs::add(const std::vector<double>& before, const std::vector<double>& now) {
  if (before.size() != now.size())
    return;
  double c = 0.0, n = 0.0;
  for (std::size_t i = 0; i < now.size(); ++i) {
    c += before[i] * now[i];
    n += 0.5 * (before[i] * before[i] + now[i] * now[i]);
  }
  cross += c;
  norm += n;
  ++pairs;
}

double StepCorrelation::correlation() const {
  return norm_ > 0.0 ? cross_ / norm_ : 1.0;
}

double StepCorrelation::alternating_share() const {
  return 0.5 * (1.0 - correlation());
}

double StepCorrelation::reversed_fraction() const {
  return pairs_ > 0 ? reversed_ / double(pairs_) : 0.0;
}

// ---- Energy balance -------------------------------------------------------------------------

EnergyBalance energy_balance(const std::vector<Sample>& samples, double t_eq, double gdot,
                             std::optional<double> imposed_pressure, std::size_t blocks) {
  EnergyBalance eb;
  eb.ratio = eb.error = eb.residual = eb.drift = eb.raw_ratio = kNaN;
  // The window: samples after the last one at or before t_eq, which is the starting point.
  std::size_t start = 0;
  for (std::size_t k = 0; k < samples.size(); ++k) {
    if (samples[k].time <= t_eq * (1.0 + 1e-12) + 1e-12)
      start = k;
  }
  const std::size_t count = samples.size() > start ? samples.size() - start - 1 : 0;
  if (blocks < 2 || count < blocks)
    return eb;
  const double p = imposed_pressure.value_or(0.0);
  auto work = [&](const Sample& s) { return s.sigma_xy * gdot * s.volume; };
  auto loss = [&](const Sample& s) { return s.dissipation + s.piston_dissipation; };
  auto enthalpy = [&](const Sample& s) { return s.energy + p * s.volume; };
  // Blocks of equal length over the newest samples, as block_average does.
  const std::size_t len = count / blocks;
  const std::size_t first = start + (count - len * blocks);  // sample preceding block 0
  std::vector<double> ratios(blocks);
  double w_all = 0.0, l_all = 0.0;
  for (std::size_t b = 0; b < blocks; ++b) {
    const std::size_t a = first + b * len;  // start point of the block
    double w = 0.0, l = 0.0;
    for (std::size_t k = a + 1; k <= a + len; ++k) {
      w += work(samples[k]);
      l += loss(samples[k]);
    }
    w /= double(len);
    l /= double(len);
    w_all += w;
    l_all += l;
    const double span = samples[a + len].time - samples[a].time;
    const double drift =
        span > 0.0 ? (enthalpy(samples[a + len]) - enthalpy(samples[a])) / span : 0.0;
    ratios[b] = w / (l + drift);
  }
  w_all /= double(blocks);
  l_all /= double(blocks);
  const Sample& s0 = samples[first];
  const Sample& s1 = samples.back();
  const double span = s1.time - s0.time;
  eb.drift = span > 0.0 ? (enthalpy(s1) - enthalpy(s0)) / span : 0.0;
  const double denom = l_all + eb.drift;
  eb.raw_ratio = l_all > 0.0 ? w_all / l_all : kNaN;
  if (!(denom > 0.0) || !std::isfinite(w_all))
    return eb;
  eb.ratio = w_all / denom;
  double m = 0.0, v = 0.0;
  for (double r : ratios)
    m += r;
  m /= double(blocks);
  for (double r : ratios)
    v += (r - m) * (r - m);
  eb.error = std::sqrt(v / double(blocks - 1) / double(blocks));
  eb.residual = std::abs(eb.ratio - 1.0);
  eb.valid = std::isfinite(eb.ratio) && std::isfinite(eb.error);
  return eb;
}

double trend_t(const std::vector<double>& means) {
  const std::size_t n = means.size();
  if (n < 3)
    return kNaN;
  double mx = 0.0, my = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    mx += double(k);
    my += means[k];
  }
  mx /= double(n);
  my /= double(n);
  double sxx = 0.0, sxy = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    sxx += (double(k) - mx) * (double(k) - mx);
    sxy += (double(k) - mx) * (means[k] - my);
  }
  const double slope = sxy / sxx;
  double rss = 0.0, tss = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    const double r = means[k] - my - slope * (double(k) - mx);
    rss += r * r;
    tss += (means[k] - my) * (means[k] - my);
  }
  // Constant to round-off: no trend.
  if (!(tss > 1e-28 * my * my * double(n)) && tss == tss)
    return 0.0;
  // Block means shorter than the correlation time are correlated, which makes a wandering
  // series look like a trend: the residuals' lag-1 autocorrelation r (clamped to [0, 0.9])
  // inflates the slope's variance by (1 + r) / (1 - r), the AR(1) correction.
  double c0 = 0.0, c1 = 0.0;
  std::vector<double> res(n);
  for (std::size_t k = 0; k < n; ++k)
    res[k] = means[k] - my - slope * (double(k) - mx);
  for (std::size_t k = 0; k < n; ++k) {
    c0 += res[k] * res[k];
    if (k + 1 < n)
      c1 += res[k] * res[k + 1];
  }
  const double r = c0 > 0.0 ? std::clamp(c1 / c0, 0.0, 0.9) : 0.0;
  const double se = std::sqrt(rss / double(n - 2) / sxx * (1.0 + r) / (1.0 - r));
  if (!(se > 0.0))
    return slope == 0.0 ? 0.0 : std::copysign(std::numeric_limits<double>::infinity(), slope);
  return slope / se;
}

}  // namespace jamflow
