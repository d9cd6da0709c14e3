#include "tether/frontends/lidar/real_time_correlative_scan_matcher_2d.h"

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
  std::vector<ProbabilityGrid::Cell> cells(points.size());
  for (int a = -angular_steps; a <= angular_steps; ++a) {
    const double dtheta = a * step;
    const SE2d rotated(guess.x(), guess.y(), guess.theta() + dtheta);
    for (std::size_t k = 0; k < points.size(); ++k) cells[k] = grid.CellOf(rotated * points[k]);
    for (int iy = -linear_steps; iy <= linear_steps; ++iy) {
      for (int ix = -linear_steps; ix <= linear_steps; ++ix) {
        const ProbabilityGrid::Cell offset(ix, iy);
        double sum = 0;
        for (const ProbabilityGrid::Cell& c : cells) sum += grid.Probability(c + offset, options.unknown_probability);
        const double mean = sum * inv_n;
        const double penalty = options.translation_delta_cost_weight * r * std::hypot(ix, iy) +
                               options.rotation_delta_cost_weight * std::abs(dtheta);
        const double score = mean * std::exp(-penalty * penalty);
        ++best.candidates;
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
