#pragma once
// An IMU's yaw rate as the turn between scans: a robot without odometry (a scanner alone, or a
// log read with --odometry none) whose bag has sensor_msgs/Imu messages gets each scan's
// heading by the rate about z (angular_velocity.z) integrated up to its stamp; local SLAM takes
// the difference between two scans as the turn of its scan-only prediction (local_slam_2d.h).
// A fast turn in a room whose walls say little about rotation (a round room, a featureless
// one) is where scan matching alone loses the heading and the gyro does not.
//
// The gyro's bias (its reading at rest) is taken off: the mean over the IMU's first
// `bias_seconds` where the robot stood still then (the readings' spread within
// kStillSpread and their mean within kStillRate); otherwise none is taken off, and the
// reason is kept for the report.
#include <string>
#include <vector>

namespace tether {
namespace lidar {

struct LidarLog;

/// One IMU message: its stamp (s) and its rate about z (rad/s, counter-clockwise).
struct ImuSample {
  double stamp = 0;
  double yaw_rate = 0;
};

struct ImuTrack {
  std::vector<ImuSample> samples;  ///< in time order once attached
  double bias = 0;                 ///< rad/s, taken off every rate
  bool bias_estimated = false;     ///< false: no bias taken off (see bias_why)
  std::string bias_why;            ///< how the bias was found, or why none was
  long scans_with_yaw = 0;         ///< scans within the samples' span
  bool empty() const { return samples.empty(); }
};

/// The rates' standard deviation and mean magnitude (rad/s) at most which the robot counts as
/// standing still over the first bias_seconds.
constexpr double kStillSpread = 0.05;
constexpr double kStillRate = 0.1;

/// Sorts the samples by stamp (stably), sets the bias (over the first `bias_seconds`; 0: none)
/// and each scan's imu_yaw and has_imu_yaw: the rate minus the bias, integrated by the
/// trapezoid rule from the first sample, interpolated linearly at the scan's stamp. Scans before
/// the first sample or after the last get none. Nothing happens for a log without samples.
void AttachImuYaw(double bias_seconds, LidarLog* log);

}  // namespace lidar
}  // namespace tether
