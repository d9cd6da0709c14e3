#include "tether/frontends/lidar/io/lidar_log.h"

#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>

#include "tether/core/enum_names.h"
#include "tether/core/error.h"
#include "tether/core/registry.h"
#include "tether/frontends/lidar/io/carmen_reader.h"
#include "tether/frontends/lidar/io/rosbag_reader.h"

namespace tether {
namespace lidar {

bool LidarReadOptions::IsValid(std::string* why) const {
  const auto fail = [why](const char* what) {
    if (why != nullptr) *why = what;
    return false;
  };
  const auto bad = [](double v) { return !std::isfinite(v) || v < 0; };
  if (bad(limits.min_range) || bad(limits.max_range)) {
    return fail("range limits must be finite and not negative (0: the source's own)");
  }
  if (limits.max_range > 0 && limits.min_range >= limits.max_range) {
    return fail("the minimum range must be below the maximum range");
  }
  if (!(flaser_max_range > 0) || !(flaser_max_range <= scan_bounds::kMaxRange)) {
    return fail("flaser_max_range must be positive and at most 1000 m");
  }
  if (!(flaser_fov > 0) || !(flaser_fov <= 2 * M_PI)) return fail("flaser_fov must be in (0, 2 pi] radians");
  if (scan_topic.empty() || odom_topic.empty()) return fail("empty topic name");
  if (!(std::isfinite(imu_bias_seconds) && imu_bias_seconds >= 0)) {
    return fail("imu_bias_seconds must be finite and not negative (0: no bias taken off)");
  }
  return true;
}

void CheckReadOptions(const LidarReadOptions& o) {
  std::string why;
  if (!o.IsValid(&why)) throw InvalidArgument("lidar reader: " + why);
}

LogFormat DetectLogFormat(const std::string& path) {
  // A pipe (`<(zcat log.gz)`, /dev/stdin) cannot be read twice: peeking would eat its first
  // bytes. A bag needs seeking, so whatever comes through a pipe is read as a CARMEN log.
  struct stat st;
  if (::stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode) && !S_ISDIR(st.st_mode)) return LogFormat::kCarmen;
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError(path + ": cannot open the log (" + std::strerror(errno) + ")");
  char head[13] = {};
  in.read(head, 12);
  return std::string(head, static_cast<std::size_t>(in.gcount())) == "#ROSBAG V2.0" ? LogFormat::kRosBag
                                                                                    : LogFormat::kCarmen;
}

void AttachOdometry(const std::string& path, OdometrySource source, LidarLog* log) {
  log->clamped_odometry = 0;
  for (LaserScan& s : log->scans) {
    if (source == OdometrySource::kNone) {
      s.odometry = SE2<double>();
      s.odometry_origin = OdometryOrigin::kNone;
      continue;
    }
    const bool has_line = s.odometry_origin == OdometryOrigin::kScanLine;
    if (source == OdometrySource::kScanLine && !has_line) {
      throw ParseError(path + ": scan " + std::to_string(s.source_index) +
                       " carries no odometry of its own (odometry source scan-line); use interpolated");
    }
    if (source == OdometrySource::kScanLine || (source == OdometrySource::kAuto && has_line)) continue;
    if (source == OdometrySource::kInterpolated && log->odometry.empty()) {
      throw ParseError(path + ": no odometry messages to interpolate from (odometry source interpolated)");
    }
    s.odometry_origin = log->odometry.At(s.stamp, &s.odometry);
    if (s.odometry_origin == OdometryOrigin::kClamped) ++log->clamped_odometry;
  }
}

LidarLog ReadLidarLog(const std::string& path, const LidarReadOptions& options) {
  CheckReadOptions(options);
  LogFormat format = options.format;
  if (format == LogFormat::kAuto) format = DetectLogFormat(path);
  if (format == LogFormat::kCarmen && !options.imu_topic.empty()) {
    throw InvalidArgument(path + ": an IMU topic (" + options.imu_topic +
                          ") is for ROS bags; a CARMEN log has no IMU messages");
  }
  LidarLog log = format == LogFormat::kRosBag ? ReadRosBag(path, options) : ReadCarmenLog(path, options);
  return log;
}

void FinishLog(const LidarReadOptions& options, LidarLog* log) {
  bool any_valid = false;
  for (LaserScan& s : log->scans) {
    if (options.limits.min_range > 0) s.range_min = std::max(s.range_min, options.limits.min_range);
    if (options.limits.max_range > 0) s.range_max = std::min(s.range_max, options.limits.max_range);
    any_valid = any_valid || s.ValidCount() > 0;
  }
  if (!any_valid) {
    std::string limits;
    if (options.limits.min_range > 0 || options.limits.max_range > 0) {
      limits = " (with the range limits given: minimum " + FormatDouble(options.limits.min_range) + " m, maximum " +
               FormatDouble(options.limits.max_range) + " m; 0 = the log's own)";
    }
    throw ParseError(log->path + ": none of the " + std::to_string(log->scans.size()) +
                     " scans has a valid range: every beam is 0, not finite, or outside the scan's range limits" +
                     limits + "; nothing can be mapped");
  }
  AttachOdometry(log->path, options.odometry, log);
  AttachImuYaw(options.imu_bias_seconds, log);
  log->odometry.Sorted();  // sorted now, so that later const calls change nothing
}

std::string ScanLocation(const LidarLog& log, const LaserScan& scan) {
  if (log.format == LogFormat::kRosBag) return log.path + ": message " + std::to_string(scan.source_index);
  return log.path + ":" + std::to_string(scan.source_index);
}

void ForEachScan(const LidarLog& log, long max_scans, const std::function<void(const LaserScan&)>& add,
                 long progress_every, const std::function<void(long)>& progress) {
  const long n =
      max_scans > 0 ? std::min(static_cast<long>(log.scans.size()), max_scans) : static_cast<long>(log.scans.size());
  for (long i = 0; i < n; ++i) {
    const LaserScan& scan = log.scans[static_cast<std::size_t>(i)];
    try {
      add(scan);
    } catch (const Error& e) {
      throw ParseError(ScanLocation(log, scan) + ": scan " + std::to_string(i) + ": " + e.what());
    }
    if (progress && progress_every > 0 && (i + 1) % progress_every == 0) progress(i + 1);
  }
}

std::vector<StampedPose2> OdometryTrajectory(const LidarLog& log) {
  std::vector<StampedPose2> out;
  out.reserve(log.scans.size());
  for (const LaserScan& s : log.scans) out.push_back({s.stamp, s.odometry});
  return out;
}

}  // namespace lidar
}  // namespace tether
