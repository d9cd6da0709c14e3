#pragma once
// The one reader of 2D laser logs: time-stamped scans with the robot's odometry, whatever the
// source.
//
//   tether::lidar::LidarLog log = tether::lidar::ReadLidarLog("intel.clf.gz");  // or "intel.bag"
//   for (const tether::lidar::LaserScan& s : log.scans) {
//     std::vector<Eigen::Vector2d> points = tether::lidar::ScanToPoints(s);
//     ... s.stamp, s.odometry ...
//   }
//
// Sources: CARMEN logs (FLASER, ROBOTLASER1, RAWLASER1 and ODOM lines; plain text or gzip, see
// carmen_reader.h) and ROS 1 bags (sensor_msgs/LaserScan and nav_msgs/Odometry, see
// rosbag_reader.h). docs/lidar.md describes both.
#include <functional>
#include <string>
#include <vector>

#include "tether/core/enum_names.h"
#include "tether/frontends/lidar/sensor/imu_yaw.h"
#include "tether/frontends/lidar/sensor/laser_scan.h"
#include "tether/frontends/lidar/sensor/odometry_track.h"

namespace tether {
namespace lidar {

/// Where each scan's odometry comes from.
enum class OdometrySource {
  kAuto,          ///< the scan's own line where it carries a pose (CARMEN), else interpolated
  kScanLine,      ///< the scan's line only (a CARMEN scan line always has one; a bag has none: error)
  kInterpolated,  ///< interpolated from the odometry messages (ODOM lines, the odometry topic)
  kNone,          ///< none: every scan's odometry dropped (identity, OdometryOrigin::kNone), to run scan-only
};
inline constexpr EnumName<OdometrySource> kOdometrySourceNames[] = {{OdometrySource::kAuto, "auto"},
                                                                    {OdometrySource::kScanLine, "scan-line"},
                                                                    {OdometrySource::kInterpolated, "interpolated"},
                                                                    {OdometrySource::kNone, "none"}};
constexpr const auto& EnumNames(OdometrySource) { return kOdometrySourceNames; }

enum class LogFormat { kAuto, kCarmen, kRosBag };
inline constexpr EnumName<LogFormat> kLogFormatNames[] = {
    {LogFormat::kAuto, "auto"}, {LogFormat::kCarmen, "carmen"}, {LogFormat::kRosBag, "rosbag"}};
constexpr const auto& EnumNames(LogFormat) { return kLogFormatNames; }

struct LidarReadOptions {
  /// kAuto: a ROS bag by its first bytes ("#ROSBAG V2.0"), else a CARMEN log.
  LogFormat format = LogFormat::kAuto;
  OdometrySource odometry = OdometrySource::kAuto;
  /// Range limits put on every scan (0: the source's own). A bag's LaserScan carries its
  /// limits; CARMEN FLASER lines carry none, so `flaser_max_range` is used there.
  RangeLimits limits;
  /// The range at and beyond which a FLASER beam is no return (SICK scanners in CARMEN logs
  /// report about 81.9 m for none; the logs' bags say 80 m).
  double flaser_max_range = 80.0;
  /// The field of view of FLASER scans (radians; beams from -fov/2 to +fov/2, the first and last
  /// beam on the edges, as CARMEN writes them: 180 beams over pi give a step of pi / 179).
  double flaser_fov = 3.14159265358979323846;
  /// Bags: the topics.
  std::string scan_topic = "/scan";
  std::string odom_topic = "/odom";
  /// Bags: a sensor_msgs/Imu topic whose yaw rate (angular_velocity.z) gives each scan's
  /// imu_yaw (imu_yaw.h); empty: none read. A topic not in the bag is an error; so is one given
  /// for a CARMEN log (it has no IMU messages).
  std::string imu_topic;
  /// The gyro's bias: the mean rate over the IMU's first this many seconds where the robot
  /// stood still then (0: none taken off).
  double imu_bias_seconds = 1;

  /// False (and why) for negative or non-finite limits, a minimum not below the maximum, a
  /// non-positive FLASER range or field of view, an empty scan or odometry topic, a negative or
  /// non-finite imu_bias_seconds.
  bool IsValid(std::string* why) const;
};

struct LidarLog {
  std::string path;
  LogFormat format = LogFormat::kAuto;  ///< the format it was read as
  std::vector<LaserScan> scans;         ///< in the order of the source (not sorted by time)
  OdometryTrack odometry;               ///< every odometry message / ODOM line
  ImuTrack imu;                         ///< the IMU's messages (LidarReadOptions::imu_topic)
  /// Scans whose odometry was clamped to the first or last odometry message.
  std::size_t clamped_odometry = 0;
};

/// Reads a log (format by `options.format`). Throws IoError where the file cannot be opened,
/// ParseError ("file:line: what") on malformed content, InvalidArgument on unusable options
/// or where bag support was not built (see RosBagSupported()).
LidarLog ReadLidarLog(const std::string& path, const LidarReadOptions& options = {});

/// Where a scan of the log came from, for messages: "log.clf:1234" (a CARMEN line) or
/// "run.bag: message 56" (a bag).
std::string ScanLocation(const LidarLog& log, const LaserScan& scan);

/// Calls add(scan) for the first `max_scans` scans of the log (0: all), in order; `progress`,
/// where given, after every `progress_every`-th with the count so far. An Error from `add` is
/// raised again as a ParseError naming the scan's file:line (or bag message) and its index:
/// how the front-ends' Run() feed a whole log.
void ForEachScan(const LidarLog& log, long max_scans, const std::function<void(const LaserScan&)>& add,
                 long progress_every = 0, const std::function<void(long)>& progress = nullptr);

/// The robot's odometry pose of every scan, in scan order.
std::vector<StampedPose2> OdometryTrajectory(const LidarLog& log);

/// The log's format from its first bytes: kRosBag for "#ROSBAG V2.0", else kCarmen. Throws
/// IoError where the file cannot be opened.
LogFormat DetectLogFormat(const std::string& path);

/// Sets each scan's odometry from its line or the track, as `source` says; counts the clamped.
/// Used by the readers; throws ParseError naming `path` where a scan has no odometry to take
/// (kScanLine for a scan without a pose on its line, kInterpolated without odometry messages).
/// kAuto never throws: a scan without a pose of its own in a log without odometry gets kNone.
void AttachOdometry(const std::string& path, OdometrySource source, LidarLog* log);

/// Throws InvalidArgument "lidar reader: <IsValid's why>" (each reader calls it first).
void CheckReadOptions(const LidarReadOptions& options);

/// Each reader's last step: puts `options.limits` on every scan, attaches the odometry
/// (AttachOdometry with log->path) and the IMU's headings (AttachImuYaw).
void FinishLog(const LidarReadOptions& options, LidarLog* log);

}  // namespace lidar
}  // namespace tether
