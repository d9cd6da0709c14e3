#pragma once
// What every particle filter of tether does with its weights (Monte Carlo localisation,
// FastSLAM): low-variance resampling, the effective sample size, and weights kept as logarithms
// turned into normalised ones without underflow.
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

}  // namespace tether
