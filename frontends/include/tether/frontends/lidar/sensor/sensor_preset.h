#pragma once
// Settings per class of scanner, and the class a log's own scans say it is.
//
//   tether::lidar::LidarSlamOptions o = tether::lidar::ForSensor(tether::lidar::SensorClass::kLds);
//   // or from the log: the class its beams, field of view, range and rate point to
//   const tether::lidar::ScanStatistics stats = tether::lidar::ComputeScanStatistics(log.scans);
//   const tether::lidar::SensorChoice choice = tether::lidar::ChooseSensor(stats);
//   o = tether::lidar::ForSensor(choice.sensor);   // choice.why says why
//
// Three classes (docs/lidar.md, "Scanners"; benchmarks/RESULTS.md, "LiDAR XII"):
// - sick: a SICK LMS-class scanner, 180 or 361 beams over 180 degrees, 80 m, 10-75 Hz, about
//   1 cm noise. The settings are LidarSlamOptions' defaults, tuned on the benchmark's logs
//   (Intel, aces, fr079), which are such scanners.
// - hokuyo: a Hokuyo UTM-30LX-class scanner, 1081 beams over 270 degrees, 30 m, 40 Hz, 1-3 cm.
// - lds: a low-cost 360-degree scanner (LDS-01, RPLIDAR A1-class), 360 beams, 5 Hz, 6-12 m, 1-3
//   cm, on small robots whose body is often within its reach.
// The choice goes by the longest range the scans declare (range_max): the range decides how
// much of a building a scan sees, which is what the settings differ by. At most
// kLdsMaxRange: lds; at most kHokuyoMaxRange: hokuyo; beyond: sick.
#include <cstddef>
#include <string>
#include <vector>

#include "tether/core/enum_names.h"
#include "tether/frontends/lidar/lidar_slam_2d.h"
#include "tether/frontends/lidar/sensor/laser_scan.h"

namespace tether {
namespace lidar {

enum class SensorClass {
  kAuto,    ///< chosen from the log's scans (ChooseSensor)
  kLds,     ///< low-cost 360-degree scanner
  kSick,    ///< SICK LMS-class (the defaults)
  kHokuyo,  ///< Hokuyo UTM-30LX-class
};
inline constexpr EnumName<SensorClass> kSensorClassNames[] = {{SensorClass::kAuto, "auto"},
                                                              {SensorClass::kLds, "lds"},
                                                              {SensorClass::kSick, "sick"},
                                                              {SensorClass::kHokuyo, "hokuyo"}};
constexpr const auto& EnumNames(SensorClass) { return kSensorClassNames; }

/// The longest declared range (m) of each class: scans up to kLdsMaxRange are lds, up to
/// kHokuyoMaxRange hokuyo, longer ones sick.
constexpr double kLdsMaxRange = 16;
constexpr double kHokuyoMaxRange = 40;

/// The kind of scanner a class stands for (one line, for help and reports).
std::string SensorDescription(SensorClass sensor);

/// The settings of a class: LidarSlamOptions' defaults with the class's own values (kSick: the
/// defaults exactly). Throws InvalidArgument for kAuto (a class chosen from a log: ChooseSensor).
LidarSlamOptions ForSensor(SensorClass sensor);

/// What a log's scans say about the scanner.
struct ScanStatistics {
  long scans = 0;
  std::size_t beams_min = 0, beams_max = 0;
  double field_of_view = 0;   ///< rad: the first scan's (beams - 1) x |step|
  double max_range = 0;       ///< m: the largest range_max of the scans
  double longest_return = 0;  ///< m: the longest valid range of any scan
  double span = 0;            ///< s: last stamp - first
  double rate = 0;            ///< scans per second over the span (0: no span)
  long with_odometry = 0;     ///< scans with odometry (odometry_origin not kNone)
  long with_imu = 0;          ///< scans with an IMU heading
};

/// The statistics of the first `n` scans (0 or beyond the scans: all). Throws InvalidArgument
/// where there are none.
ScanStatistics ComputeScanStatistics(const std::vector<LaserScan>& scans, long n = 0);

struct SensorChoice {
  SensorClass sensor = SensorClass::kSick;
  std::string why;  ///< "maximum range 6.0 m, at most 16 m: a low-cost scanner's"
};

/// The class the statistics point to (see above).
SensorChoice ChooseSensor(const ScanStatistics& statistics);

}  // namespace lidar
}  // namespace tether
