#include "tether/frontends/localization/resampling.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>

namespace tether {

std::vector<int> LowVarianceResample(const std::vector<double>& weights, int count, double u) {
  std::vector<int> out(static_cast<std::size_t>(std::max(count, 0)));
  if (weights.empty()) return out;
  double cumulative = weights[0];
  int i = 0;
  const int last = static_cast<int>(weights.size()) - 1;
  for (int m = 0; m < count; ++m) {
    const double target = (u + m) / count;
    while (target > cumulative && i < last) cumulative += weights[static_cast<std::size_t>(++i)];
    out[static_cast<std::size_t>(m)] = i;
  }
  return out;
}

double EffectiveSampleSize(const std::vector<double>& weights) {
  double sum = 0, squares = 0;
  for (const double w : weights) {
    sum += w;
    squares += w * w;
  }
  return squares > 0 ? sum * sum / squares : 0.0;
}

std::vector<double> NormalizedFromLogs(const std::vector<double>& log_weights) {
  const std::size_t n = log_weights.size();
  std::vector<double> w(n, n > 0 ? 1.0 / static_cast<double>(n) : 0.0);
  double top = -std::numeric_limits<double>::infinity();
  for (const double l : log_weights) {
    if (std::isnan(l)) return w;
    top = std::max(top, l);
  }
  if (!std::isfinite(top)) return w;
  double sum = 0;
  for (std::size_t i = 0; i < n; ++i) sum += (w[i] = std::exp(log_weights[i] - top));
  for (double& x : w) x /= sum;
  return w;
}

}  // namespace tether
