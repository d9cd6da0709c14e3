#include "tether/frontends/lidar/sensor/laser_scan.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "tether/core/enum_names.h"
#include "tether/core/registry.h"

namespace tether {
namespace lidar {

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

std::string PoseProblem(double x, double y, double theta) {
  if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(theta)) return "a pose is not finite";
  if (std::abs(x) > scan_bounds::kMaxCoordinate || std::abs(y) > scan_bounds::kMaxCoordinate) {
    return "a pose lies " + FormatDouble(std::max(std::abs(x), std::abs(y))) + " m from the origin, beyond " +
           FormatDouble(scan_bounds::kMaxCoordinate) + " m (is the log in metres?)";
  }
  if (std::abs(theta) > scan_bounds::kMaxHeading) {
    return "a heading of " + FormatDouble(theta) + " rad is beyond +-" + FormatDouble(scan_bounds::kMaxHeading) +
           " rad (is the log in radians?)";
  }
  return "";
}

std::string StampProblem(double stamp) {
  if (!std::isfinite(stamp)) return "the stamp is not finite";
  if (std::abs(stamp) > scan_bounds::kMaxStamp) {
    return "the stamp " + FormatDouble(stamp) + " is beyond " + FormatDouble(scan_bounds::kMaxStamp) +
           " s (stamps are seconds)";
  }
  return "";
}

std::string ScanProblem(const LaserScan& s) {
  const std::size_t n = s.ranges.size();
  if (n < 2) return "a scan needs at least 2 ranges, this one has " + std::to_string(n);
  if (!std::isfinite(s.angle_min) || std::abs(s.angle_min) > 2 * M_PI) {
    return "the start angle " + FormatDouble(s.angle_min) + " rad is not within +-2 pi";
  }
  const double step = std::abs(s.angle_increment);
  if (!std::isfinite(s.angle_increment) || step < scan_bounds::kMinAngleIncrement) {
    return "the angle step " + FormatDouble(s.angle_increment) + " rad is not finite or below " +
           FormatDouble(scan_bounds::kMinAngleIncrement) + " rad in size";
  }
  const double span = step * static_cast<double>(n - 1);
  if (span > 2 * M_PI * (1 + 1e-6)) {
    return std::to_string(n) + " beams " + FormatDouble(s.angle_increment) + " rad apart span " + FormatDouble(span) +
           " rad, more than a full turn";
  }
  if (!std::isfinite(s.range_min) || s.range_min < 0) {
    return "the minimum range " + FormatDouble(s.range_min) + " m is not finite or negative";
  }
  if (!std::isfinite(s.range_max) || !(s.range_max > s.range_min) || s.range_max > scan_bounds::kMaxRange) {
    return "the maximum range " + FormatDouble(s.range_max) + " m must be above the minimum (" +
           FormatDouble(s.range_min) + " m) and at most " + FormatDouble(scan_bounds::kMaxRange) + " m";
  }
  for (double stamp : {s.stamp, s.logger_stamp}) {
    const std::string why = StampProblem(stamp);
    if (!why.empty()) return why;
  }
  for (const SE2<double>* p : {&s.odometry, &s.laser_in_robot}) {
    const std::string why = PoseProblem(p->x(), p->y(), p->theta());
    if (!why.empty()) return (p == &s.odometry ? "odometry: " : "the laser's pose on the robot: ") + why;
  }
  if (s.has_imu_yaw && !(std::abs(s.imu_yaw) <= scan_bounds::kMaxHeading)) {
    return "the IMU's heading " + FormatDouble(s.imu_yaw) + " rad is not finite or beyond " +
           FormatDouble(scan_bounds::kMaxHeading) + " rad";
  }
  return "";
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
