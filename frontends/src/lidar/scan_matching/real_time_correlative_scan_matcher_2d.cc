#include "tether/frontends/lidar/scan_matching/real_time_correlative_scan_matcher_2d.h"

#include <algorithm>
#include <cmath>

#include "tether/core/error.h"
#include "tether/core/registry.h"

namespace tether {
namespace lidar {

bool CorrelativeMatcherOptions::IsValid(std::string* why) const {
  const auto check = [&](const char* name, double v) {
    if (std::isfinite(v) && v >= 0) return true;
    if (why != nullptr) *why = std::string(name) + " is " + FormatDouble(v) + "; it must be finite and not negative";
    return false;
  };
  return check("linear_search_window", linear_search_window) && check("angular_search_window", angular_search_window) &&
         check("angular_step", angular_step) && check("translation_delta_cost_weight", translation_delta_cost_weight) &&
         check("rotation_delta_cost_weight", rotation_delta_cost_weight) &&
         check("unknown_probability", unknown_probability) &&
         (unknown_probability <= 1 || !(why != nullptr && (*why = "unknown_probability must lie in [0, 1]", true)));
}

CorrelativeMatch MatchCorrelative(const ProbabilityGrid& grid, const SE2d& guess,
                                  const std::vector<Eigen::Vector2d>& points,
                                  const CorrelativeMatcherOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("CorrelativeMatcherOptions: " + why);
  if (points.empty()) throw InvalidArgument("MatchCorrelative: the scan has no points");
  if (!(std::isfinite(guess.x()) && std::isfinite(guess.y()) && std::isfinite(guess.theta()))) {
    throw InvalidArgument("MatchCorrelative: the guess is not finite");
  }
  double max_range = 0;
  for (const Eigen::Vector2d& p : points) {
    if (!p.allFinite()) throw InvalidArgument("MatchCorrelative: a point of the scan is not finite");
    max_range = std::max(max_range, p.norm());
  }
  const double r = grid.resolution();
  double step = options.angular_step;
  if (step == 0) {
    const double d = std::max(max_range, r);
    step = std::acos(std::max(-1.0, 1.0 - r * r / (2 * d * d)));
  }
  const int angular_steps = static_cast<int>(std::ceil(options.angular_search_window / step - 1e-9));
  const int linear_steps = static_cast<int>(std::ceil(options.linear_search_window / r - 1e-9));

  CorrelativeMatch best;
  best.score = -1;
  best.angular_step = step;
  const double inv_n = 1.0 / static_cast<double>(points.size());
  const double unknown = options.unknown_probability;
  const auto probability = [&](std::uint16_t v) {
    return v == ProbabilityGrid::kUnknownValue ? unknown : grid.ValueToProbability(v);
  };
  // Per rotation, the sums of all (2 L + 1)^2 translations at once: each point reads its
  // neighbourhood's rows, and every sum still adds the points in order.
  const int side = 2 * linear_steps + 1;
  const ProbabilityGrid::Cell reach(linear_steps, linear_steps);
  std::vector<double> sums(static_cast<std::size_t>(side * side));
  std::vector<ProbabilityGrid::Cell> cells;
  for (int a = -angular_steps; a <= angular_steps; ++a) {
    const double dtheta = a * step;
    const SE2d rotated(guess.x(), guess.y(), guess.theta() + dtheta);
    grid.CellsOf(rotated, points, &cells);
    std::fill(sums.begin(), sums.end(), 0.0);
    for (const ProbabilityGrid::Cell& c : cells) {
      const int base = grid.BoxIndex(c - reach, c + reach);
      double* sum = sums.data();
      if (base >= 0) {
        for (int iy = 0; iy < side; ++iy, sum += side) {
          const int row = base + iy * grid.stride();
          for (int ix = 0; ix < side; ++ix) sum[ix] += probability(grid.ValueAt(row + ix));
        }
      } else {
        for (int iy = 0; iy < side; ++iy, sum += side) {
          for (int ix = 0; ix < side; ++ix)
            sum[ix] += probability(grid.Value(c - reach + ProbabilityGrid::Cell(ix, iy)));
        }
      }
    }
    for (int iy = -linear_steps; iy <= linear_steps; ++iy) {
      for (int ix = -linear_steps; ix <= linear_steps; ++ix) {
        ++best.candidates;
        const double mean = sums[static_cast<std::size_t>((iy + linear_steps) * side + ix + linear_steps)] * inv_n;
        // The weight below is at most 1: a mean not above the best cannot win.
        if (!(mean > best.score)) continue;
        const double penalty = options.translation_delta_cost_weight * r * std::hypot(ix, iy) +
                               options.rotation_delta_cost_weight * std::abs(dtheta);
        const double score = mean * std::exp(-penalty * penalty);
        if (score > best.score) {
          best.score = score;
          best.mean_probability = mean;
          best.pose = SE2d(guess.x() + ix * r, guess.y() + iy * r, guess.theta() + dtheta);
        }
      }
    }
  }
  return best;
}

}  // namespace lidar
}  // namespace tether
