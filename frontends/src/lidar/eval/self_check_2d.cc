#include "tether/frontends/lidar/eval/self_check_2d.h"

#include <algorithm>
#include <cmath>
#include <memory>

#include "tether/core/error.h"
#include "tether/core/registry.h"
#include "tether/factors/probability_grid.h"
#include "tether/frontends/lidar/mapping/probability_grid_inserter.h"

namespace tether {
namespace lidar {

bool SelfCheckOptions::IsValid(std::string* why) const {
  const auto fail = [why](const std::string& what) {
    if (why != nullptr) *why = what;
    return false;
  };
  if (sample_every < 0) return fail("sample_every must not be negative (0: no check)");
  if (!(std::isfinite(resolution) && resolution > 0)) return fail("resolution must be finite and positive");
  if (!(std::isfinite(max_range) && max_range >= 0)) return fail("max_range must be finite and not negative");
  if (part_scans < 1) return fail("part_scans must be at least 1");
  if (min_separation_scans < 0) return fail("min_separation_scans must not be negative");
  if (min_points < 1) return fail("min_points must be at least 1");
  if (!(fit_fraction >= 0 && fit_fraction <= 1)) return fail("fit_fraction must lie in [0, 1]");
  if (min_stretch < 1) return fail("min_stretch must be at least 1");
  return true;
}

double SelfCheckResult::FitShare() const {
  return judged.empty() ? 1.0 : static_cast<double>(fitting) / static_cast<double>(judged.size());
}

namespace {

struct Part {
  long first = 0, last = 0;  // scans [first, last]
  std::unique_ptr<ProbabilityGrid> grid;
};

// Whether a cell of `grid` within one cell of c is occupied (probability above 0.5).
bool NearOccupied(const ProbabilityGrid& grid, const ProbabilityGrid::Cell& c) {
  for (int dy = -1; dy <= 1; ++dy) {
    for (int dx = -1; dx <= 1; ++dx) {
      const ProbabilityGrid::Cell n(c.x() + dx, c.y() + dy);
      if (grid.IsKnown(n) && grid.Probability(n) > 0.5) return true;
    }
  }
  return false;
}

}  // namespace

SelfCheckResult CheckSelfConsistency(const std::vector<SE2d>& laser_poses,
                                     const std::vector<const std::vector<Eigen::Vector2d>*>& points,
                                     const SelfCheckOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("SelfCheckOptions: " + why);
  if (laser_poses.size() != points.size()) {
    throw InvalidArgument("CheckSelfConsistency: " + std::to_string(laser_poses.size()) + " poses but " +
                          std::to_string(points.size()) + " scans of points");
  }
  SelfCheckResult result;
  const long n = static_cast<long>(laser_poses.size());
  if (options.sample_every == 0 || n == 0) return result;
  const auto in_range = [&](const Eigen::Vector2d& p) {
    return options.max_range <= 0 || p.squaredNorm() <= options.max_range * options.max_range;
  };

  // The reference grids, one per part of consecutive scans.
  std::vector<Part> parts;
  // One hit makes a cell occupied (0.9) and it takes some 55 beams through it to make it free
  // again: a wall seen along a corridor is not worn away by the beams grazing it.
  GridInsertOptions insert;
  insert.hit_probability = 0.9;
  insert.miss_probability = 0.49;
  const ProbabilityGridInserter inserter(insert, ProbabilityGrid::kDefaultMinProbability,
                                         ProbabilityGrid::kDefaultMaxProbability);
  std::vector<Eigen::Vector2d> hits;
  for (long first = 0; first < n; first += options.part_scans) {
    Part part;
    part.first = first;
    part.last = std::min(n, first + options.part_scans) - 1;
    part.grid = std::make_unique<ProbabilityGrid>(options.resolution);
    for (long i = part.first; i <= part.last; ++i) {
      hits.clear();
      for (const Eigen::Vector2d& p : *points[static_cast<std::size_t>(i)]) {
        if (in_range(p)) hits.push_back(laser_poses[static_cast<std::size_t>(i)] * p);
      }
      if (!hits.empty()) {
        inserter.Insert(part.grid.get(), laser_poses[static_cast<std::size_t>(i)].translation(), hits);
      }
    }
    parts.push_back(std::move(part));
  }

  // The samples against the parts far enough from them.
  std::vector<const ProbabilityGrid*> references;
  for (long i = 0; i < n; i += options.sample_every) {
    ++result.sampled;
    references.clear();
    for (const Part& part : parts) {
      if (part.last + options.min_separation_scans <= i || part.first - options.min_separation_scans >= i) {
        references.push_back(part.grid.get());
      }
    }
    if (references.empty()) continue;
    ScanFit fit;
    fit.scan = i;
    for (const Eigen::Vector2d& p : *points[static_cast<std::size_t>(i)]) {
      if (!in_range(p)) continue;
      const Eigen::Vector2d q = laser_poses[static_cast<std::size_t>(i)] * p;
      bool judged = false, fits = false;
      for (const ProbabilityGrid* grid : references) {
        const ProbabilityGrid::Cell c = grid->CellOf(q);
        if (!grid->IsKnown(c)) continue;
        judged = true;
        if (NearOccupied(*grid, c)) {
          fits = true;
          break;
        }
      }
      fit.judged += judged ? 1 : 0;
      fit.fitting += fits ? 1 : 0;
    }
    if (fit.judged < options.min_points) continue;
    fit.fits = static_cast<double>(fit.fitting) >= options.fit_fraction * static_cast<double>(fit.judged);
    result.fitting += fit.fits ? 1 : 0;
    result.judged.push_back(fit);
  }

  // Runs of consecutive judged misfits.
  std::size_t k = 0;
  while (k < result.judged.size()) {
    if (result.judged[k].fits) {
      ++k;
      continue;
    }
    std::size_t end = k;
    while (end < result.judged.size() && !result.judged[end].fits) ++end;
    if (static_cast<int>(end - k) >= options.min_stretch) {
      result.stretches.push_back(
          MisfitStretch{result.judged[k].scan, result.judged[end - 1].scan, static_cast<int>(end - k)});
    }
    k = end;
  }
  return result;
}

}  // namespace lidar
}  // namespace tether
