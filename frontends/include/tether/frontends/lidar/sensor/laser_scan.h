#pragma once
// One 2D laser scan as every reader gives it (CARMEN logs, ROS 1 bags): the ranges with their
// angles and limits, the time, the robot's odometry pose at that time and where the laser sits
// on the robot.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "tether/core/enum_names.h"
#include "tether/core/se2.h"

namespace tether {
namespace lidar {

/// Where a scan's odometry came from.
enum class OdometryOrigin {
  kNone,          ///< no odometry at all (a log without ODOM lines, a bag without odometry)
  kScanLine,      ///< carried by the scan's own line (CARMEN FLASER, ROBOTLASER1)
  kInterpolated,  ///< interpolated in time between the two odometry messages around the scan
  kClamped,       ///< the scan lies before the first or after the last odometry message: that one
};
inline constexpr EnumName<OdometryOrigin> kOdometryOriginNames[] = {{OdometryOrigin::kNone, "none"},
                                                                    {OdometryOrigin::kScanLine, "scan-line"},
                                                                    {OdometryOrigin::kInterpolated, "interpolated"},
                                                                    {OdometryOrigin::kClamped, "clamped"}};
constexpr const auto& EnumNames(OdometryOrigin) { return kOdometryOriginNames; }
using ::tether::FromString;
using ::tether::ToString;
using ::tether::operator<<;

struct LaserScan {
  double stamp = 0;  ///< seconds (CARMEN ipc_timestamp, ROS header.stamp)
  /// CARMEN's logger_timestamp (seconds since the logger started; a bag: `stamp`).
  double logger_stamp = 0;
  /// Beam i points at angle_min + i * angle_increment (radians, in the laser's frame, x forward).
  double angle_min = 0;
  double angle_increment = 0;
  /// Beams shorter than range_min or not shorter than range_max are invalid (no return), and
  /// so is a range of 0 whatever range_min says (low-cost scanners write 0 for no return).
  double range_min = 0;
  double range_max = 0;
  std::vector<float> ranges;
  /// The robot's odometry pose at `stamp` (odometry frame), see `odometry_origin`.
  SE2<double> odometry;
  OdometryOrigin odometry_origin = OdometryOrigin::kNone;
  /// The laser's pose in the robot's frame (CARMEN: from the laser and robot poses on the line;
  /// a bag: /tf_static's robot -> laser transform where there is one; identity otherwise).
  SE2<double> laser_in_robot;
  /// Line number in the CARMEN log (1-based), or message index in the bag; for messages.
  long source_index = 0;
  /// The robot's heading by an IMU's yaw rate integrated up to `stamp` (radians, from the IMU's
  /// first message, the gyro's bias taken off; imu_yaw.h), where the log has one over the scan's
  /// time (`has_imu_yaw`). Only differences between scans are used: the turn between them.
  double imu_yaw = 0;
  bool has_imu_yaw = false;

  /// The angle of beam i.
  double Angle(std::size_t i) const { return angle_min + static_cast<double>(i) * angle_increment; }
  /// True where beam i has a finite, positive range in [range_min, range_max).
  bool Valid(std::size_t i) const;
  /// Number of valid beams.
  std::size_t ValidCount() const;
};

/// What a scan or pose read from a log (or given through the API) must keep to. Beyond these
/// a log is damaged or in other units, not a sensor; the readers refuse it naming file:line.
namespace scan_bounds {
/// [m] the longest maximum range accepted (2D scanners reach 30-250 m).
constexpr double kMaxRange = 1000;
/// [m] the largest pose coordinate (UTM northings fit).
constexpr double kMaxCoordinate = 1e7;
/// [rad] the largest heading as written (unwrapped headings of long runs fit).
constexpr double kMaxHeading = 1e6;
/// [s] the largest stamp (Unix time until the year 5000; nanoseconds do not fit).
constexpr double kMaxStamp = 1e11;
/// [rad] the finest angle step (a million beams on a circle would be 6e-6).
constexpr double kMinAngleIncrement = 1e-6;
}  // namespace scan_bounds

/// Why `scan` cannot be used, or "" where it can: at least 2 ranges; a finite start angle
/// within +-2 pi; an angle step finite, at least kMinAngleIncrement in size and spanning at
/// most a full turn over the beams; 0 <= range_min < range_max <= kMaxRange; finite stamps
/// within kMaxStamp; odometry and laser pose finite, within kMaxCoordinate. The individual
/// ranges are not checked (NaN, inf, negative or out of limits: no return).
std::string ScanProblem(const LaserScan& scan);
/// Why a pose written as (x, y, theta) cannot be used, or "": finite, |x|, |y| within
/// kMaxCoordinate, |theta| within kMaxHeading.
std::string PoseProblem(double x, double y, double theta);
/// Why a stamp cannot be used, or "": finite and within kMaxStamp.
std::string StampProblem(double stamp);

/// Optional tighter range limits applied on top of a scan's own (0: keep the scan's).
struct RangeLimits {
  double min_range = 0;
  double max_range = 0;
};

/// The valid beams as points in the laser's frame (range limits of the scan, tightened by
/// `limits`), in beam order.
std::vector<Eigen::Vector2d> ScanToPoints(const LaserScan& scan, const RangeLimits& limits = {});

}  // namespace lidar
}  // namespace tether
