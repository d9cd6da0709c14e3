#pragma once
// What every particle filter of tether does with its weights (Monte Carlo localisation,
// FastSLAM): low-variance resampling, the effective sample size, and weights kept as logarithms
// turned into normalised ones without underflow.
#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

namespace tether {

/// Low-variance (systematic) resampling: the indices of `count` particles drawn from
/// `weights` (normalised) with one uniform number `u` in [0, 1): index of (u + m) / count.
std::vector<int> LowVarianceResample(const std::vector<double>& weights, int count, double u);

/// (sum w)^2 / sum w^2: N for equal weights, 1 where one particle holds all; 0 for no weight.
double EffectiveSampleSize(const std::vector<double>& weights);

/// exp(log_weights - max), normalised to sum 1 (equal weights where every one is -infinity or
/// the list holds a NaN).
std::vector<double> NormalizedFromLogs(const std::vector<double>& log_weights);

/// Selective resampling of particles that carry a `log_weight`: where the effective sample size
/// of their weights falls below `fraction` times their count (and there are two or more),
/// low-variance resampling with one number from uniform() (called only then), every log weight
/// 0 after; otherwise the log weights shifted so that the largest is 0 (no drift towards
/// underflow). Returns the effective sample size where it resampled, -1 otherwise. A particle
/// drawn twice is copied: what it shares (maps, paths) it shares with its copies.
template <class Particle, class Uniform>
double SelectiveResample(std::vector<Particle>* particles, double fraction, Uniform&& uniform) {
  std::vector<double> log_w;
  log_w.reserve(particles->size());
  for (const Particle& p : *particles) log_w.push_back(p.log_weight);
  const std::vector<double> w = NormalizedFromLogs(log_w);
  const double neff = EffectiveSampleSize(w);
  if (particles->size() > 1 && neff < fraction * static_cast<double>(particles->size())) {
    std::vector<Particle> next;
    next.reserve(particles->size());
    for (const int i : LowVarianceResample(w, static_cast<int>(particles->size()), uniform())) {
      next.push_back((*particles)[static_cast<std::size_t>(i)]);
      next.back().log_weight = 0;
    }
    *particles = std::move(next);
    return neff;
  }
  double top = -std::numeric_limits<double>::infinity();
  for (const double l : log_w) top = std::max(top, l);
  if (std::isfinite(top)) {
    for (Particle& p : *particles) p.log_weight -= top;
  }
  return -1;
}

}  // namespace tether
