#include "tether/frontends/lidar/laser_scan.h"

#include <cmath>

#include "tether/core/enum_names.h"

namespace tether {
namespace lidar {

namespace {

constexpr EnumName<OdometryOrigin> kOriginNames[] = {{OdometryOrigin::kNone, "none"},
                                                     {OdometryOrigin::kScanLine, "scan-line"},
                                                     {OdometryOrigin::kInterpolated, "interpolated"},
                                                     {OdometryOrigin::kClamped, "clamped"}};

}  // namespace

const char* ToString(OdometryOrigin o) { return NameOf(kOriginNames, o); }

bool LaserScan::Valid(std::size_t i) const {
  if (i >= ranges.size()) return false;
  const double r = ranges[i];
  return std::isfinite(r) && r > 0 && r >= range_min && r < range_max;
}

std::size_t LaserScan::ValidCount() const {
  std::size_t n = 0;
  for (std::size_t i = 0; i < ranges.size(); ++i) n += Valid(i) ? 1 : 0;
  return n;
}

std::vector<Eigen::Vector2d> ScanToPoints(const LaserScan& scan, const RangeLimits& limits) {
  const double lo = limits.min_range > 0 ? std::max(limits.min_range, scan.range_min) : scan.range_min;
  const double hi = limits.max_range > 0 ? std::min(limits.max_range, scan.range_max) : scan.range_max;
  std::vector<Eigen::Vector2d> points;
  points.reserve(scan.ranges.size());
  for (std::size_t i = 0; i < scan.ranges.size(); ++i) {
    const double r = scan.ranges[i];
    if (!std::isfinite(r) || r <= 0 || r < lo || r >= hi) continue;
    const double a = scan.Angle(i);
    points.emplace_back(r * std::cos(a), r * std::sin(a));
  }
  return points;
}

}  // namespace lidar
}  // namespace tether
