#include "tether/frontends/lidar/io/restamp.h"

#include <algorithm>
#include <cmath>

#include "tether/core/error.h"

namespace tether {
namespace lidar {

namespace {

bool SameRanges(const LaserScan& a, const LaserScan& b) {
  if (a.ranges.size() != b.ranges.size()) return false;
  for (std::size_t i = 0; i < a.ranges.size(); ++i) {
    if (!(std::abs(a.ranges[i] - b.ranges[i]) <= 1e-4f)) return false;
  }
  return true;
}

}  // namespace

RestampResult RestampByReference(const LidarLog& log, const LidarLog& reference, double tolerance) {
  if (!(tolerance >= 0) || !std::isfinite(tolerance)) {
    throw InvalidArgument("restamp: the tolerance must be finite and not negative");
  }
  std::vector<const LaserScan*> ref;
  ref.reserve(reference.scans.size());
  for (const LaserScan& s : reference.scans) ref.push_back(&s);
  std::stable_sort(ref.begin(), ref.end(),
                   [](const LaserScan* a, const LaserScan* b) { return a->logger_stamp < b->logger_stamp; });
  RestampResult r;
  for (const LaserScan& s : log.scans) {
    const double t = s.logger_stamp;
    auto it = std::lower_bound(ref.begin(), ref.end(), t - tolerance,
                               [](const LaserScan* a, double v) { return a->logger_stamp < v; });
    const LaserScan* nearest = nullptr;
    const LaserScan* same = nullptr;
    for (; it != ref.end() && (*it)->logger_stamp <= t + tolerance; ++it) {
      const double d = std::abs((*it)->logger_stamp - t);
      if (nearest == nullptr || d < std::abs(nearest->logger_stamp - t)) nearest = *it;
      if (SameRanges(s, **it) && (same == nullptr || d < std::abs(same->logger_stamp - t))) same = *it;
    }
    const LaserScan* chosen = same != nullptr ? same : nearest;
    if (chosen == nullptr) {
      ++r.dropped;
      continue;
    }
    ++(same != nullptr ? r.by_ranges : r.by_time);
    r.max_time_difference = std::max(r.max_time_difference, std::abs(chosen->logger_stamp - t));
    r.poses.push_back({chosen->stamp, s.odometry});
  }
  return r;
}

}  // namespace lidar
}  // namespace tether
