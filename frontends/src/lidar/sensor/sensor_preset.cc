#include "tether/frontends/lidar/sensor/sensor_preset.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "tether/core/error.h"
#include "tether/core/registry.h"

namespace tether {
namespace lidar {

std::string SensorDescription(SensorClass sensor) {
  switch (sensor) {
    case SensorClass::kAuto:
      return "chosen from the log's scans by their maximum range";
    case SensorClass::kLds:
      return "a low-cost 360-degree scanner (LDS-01, RPLIDAR A1): 360 beams, 5 Hz, 6-12 m, 1-3 cm noise";
    case SensorClass::kSick:
      return "a SICK LMS-class scanner: 180 or 361 beams over 180 degrees, 80 m, about 1 cm noise";
    case SensorClass::kHokuyo:
      return "a Hokuyo UTM-30LX-class scanner: 1081 beams over 270 degrees, 30 m, 40 Hz, 1-3 cm noise";
  }
  return "unknown";
}

LidarSlamOptions ForSensor(SensorClass sensor) {
  LidarSlamOptions o;
  switch (sensor) {
    case SensorClass::kAuto:
      throw InvalidArgument(
          "ForSensor: auto is a class chosen from a log's scans (ChooseSensor); give lds, sick or "
          "hokuyo");
    case SensorClass::kSick:
      return o;
    case SensorClass::kHokuyo:
      // Returns nearer than 0.1 m are the scanner's own window or the robot.
      o.mask.min_range = 0.1;
      return o;
    case SensorClass::kLds:
      // Returns nearer than 0.15 m are the scanner's dead zone or the robot's body.
      o.mask.min_range = 0.15;
      return o;
  }
  throw InvalidArgument("ForSensor: not a sensor class");
}

ScanStatistics ComputeScanStatistics(const std::vector<LaserScan>& scans, long n) {
  if (scans.empty()) throw InvalidArgument("ComputeScanStatistics: no scans");
  const std::size_t count = n > 0 ? std::min(scans.size(), static_cast<std::size_t>(n)) : scans.size();
  ScanStatistics s;
  s.scans = static_cast<long>(count);
  s.beams_min = scans[0].ranges.size();
  for (std::size_t i = 0; i < count; ++i) {
    const LaserScan& scan = scans[i];
    s.beams_min = std::min(s.beams_min, scan.ranges.size());
    s.beams_max = std::max(s.beams_max, scan.ranges.size());
    s.max_range = std::max(s.max_range, scan.range_max);
    for (std::size_t b = 0; b < scan.ranges.size(); ++b) {
      if (scan.Valid(b)) s.longest_return = std::max(s.longest_return, static_cast<double>(scan.ranges[b]));
    }
    s.with_odometry += scan.odometry_origin != OdometryOrigin::kNone;
    s.with_imu += scan.has_imu_yaw;
  }
  const LaserScan& first = scans[0];
  s.field_of_view = std::abs(first.angle_increment) * static_cast<double>(first.ranges.size() - 1);
  s.span = scans[count - 1].stamp - first.stamp;
  s.rate = s.span > 0 ? static_cast<double>(count - 1) / s.span : 0;
  return s;
}

SensorChoice ChooseSensor(const ScanStatistics& s) {
  SensorChoice c;
  std::ostringstream why;
  why << "maximum range " << FormatFixed(s.max_range, 1) << " m, ";
  if (s.max_range <= kLdsMaxRange) {
    c.sensor = SensorClass::kLds;
    why << "at most " << FormatDouble(kLdsMaxRange) << " m: a low-cost scanner's";
  } else if (s.max_range <= kHokuyoMaxRange) {
    c.sensor = SensorClass::kHokuyo;
    why << "over " << FormatDouble(kLdsMaxRange) << " m and at most " << FormatDouble(kHokuyoMaxRange)
        << " m: a Hokuyo-class scanner's";
  } else {
    c.sensor = SensorClass::kSick;
    why << "over " << FormatDouble(kHokuyoMaxRange) << " m: a SICK-class scanner's";
  }
  c.why = why.str();
  return c;
}

}  // namespace lidar
}  // namespace tether
