#pragma once
// The body of the CARMEN reader's fuzz target (read_carmen_fuzzer.cc), shared with the test
// that replays its findings in the normal build (tests/frontends/lidar_fuzz_regression_test.cc).
//
// The first byte of an input picks the read options; the rest is the log:
//   bits 0-1  odometry: 0 auto, 1 scan-line, 2 interpolated, 3 none
//   bit 2     range limits 0.1 m to 5 m
//   bit 3     the log gzip-compressed before it is read
//   bit 4     FLASER field of view pi / 2 and maximum range 4 m
// A log that reads must also be written (WriteCarmenLog, with odometry) and read back as the
// same scans: the same count, stamps, angles, maximum range, valid beams and their ranges, and
// the odometry and laser pose of every scan that had odometry (to rounding), or the writer must
// refuse it with a tether::Error; and degrading it (DegradeLog) must not fail. Anything but a
// tether::Error escaping, or a round trip that differs, is a finding (abort).
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "scratch_path.h"
#include "tether/core/error.h"
#include "tether/frontends/lidar/io/carmen_reader.h"
#include "tether/frontends/lidar/io/degrade_log.h"

namespace tether {
namespace fuzz {

/// A file of this process for the log (the reader takes a path).
inline const std::string& CarmenScratchPath() {
  static const std::string path = ScratchPath("carmen", "log");
  return path;
}

inline lidar::LidarReadOptions CarmenOptionsFromByte(std::uint8_t b) {
  lidar::LidarReadOptions o;
  o.format = lidar::LogFormat::kCarmen;
  const lidar::OdometrySource sources[] = {lidar::OdometrySource::kAuto, lidar::OdometrySource::kScanLine,
                                           lidar::OdometrySource::kInterpolated, lidar::OdometrySource::kNone};
  o.odometry = sources[b & 3];
  if ((b & 4) != 0) {
    o.limits.min_range = 0.1;
    o.limits.max_range = 5;
  }
  if ((b & 16) != 0) {
    o.flaser_fov = 3.14159265358979323846 / 2;
    o.flaser_max_range = 4;
  }
  return o;
}

[[noreturn]] inline void CarmenFinding(const std::string& what) {
  std::fprintf(stderr, "finding: %s\n", what.c_str());
  std::abort();
}

inline bool CarmenClose(double a, double b, double scale) { return std::abs(a - b) <= 1e-9 * (1 + scale); }

// Writes the log and reads it back; a difference is a finding.
inline void CheckCarmenRoundTrip(const lidar::LidarLog& log) {
  std::string written;
  try {
    std::ostringstream out;
    lidar::WriteCarmenLog(out, log, true);
    written = out.str();
  } catch (const Error&) {
    return;  // a clear refusal (a pose that overflows)
  }
  {
    std::ofstream f(CarmenScratchPath(), std::ios::binary | std::ios::trunc);
    f << written;
  }
  lidar::LidarLog back;
  try {
    back = lidar::ReadCarmenLog(CarmenScratchPath());
  } catch (const Error& e) {
    CarmenFinding(std::string("what tether wrote it cannot read: ") + e.what() + "\n" + written.substr(0, 2000));
  }
  const auto fail = [&](std::size_t k, const std::string& what) {
    CarmenFinding("scan " + std::to_string(k) + " reads back with " + what + ":\n" + written.substr(0, 2000));
  };
  if (back.scans.size() != log.scans.size()) fail(0, "another scan count");
  for (std::size_t k = 0; k < log.scans.size(); ++k) {
    const lidar::LaserScan &a = log.scans[k], &b = back.scans[k];
    if (a.stamp != b.stamp || a.logger_stamp != b.logger_stamp) fail(k, "another stamp");
    if (a.angle_min != b.angle_min || a.angle_increment != b.angle_increment || a.range_max != b.range_max) {
      fail(k, "other angles or maximum range");
    }
    if (a.ranges.size() != b.ranges.size()) fail(k, "another beam count");
    for (std::size_t i = 0; i < a.ranges.size(); ++i) {
      if (a.Valid(i) != b.Valid(i) || (a.Valid(i) && a.ranges[i] != b.ranges[i]))
        fail(k, "another beam " + std::to_string(i));
    }
    if (a.odometry_origin == lidar::OdometryOrigin::kNone) continue;
    const double scale = a.odometry.translation().norm() + a.laser_in_robot.translation().norm();
    if (!CarmenClose(a.odometry.x(), b.odometry.x(), scale) || !CarmenClose(a.odometry.y(), b.odometry.y(), scale) ||
        !CarmenClose(std::remainder(a.odometry.theta() - b.odometry.theta(), 2 * 3.14159265358979323846), 0, 0)) {
      fail(k, "another odometry");
    }
    const lidar::LaserScan& l = b;
    if (!CarmenClose(a.laser_in_robot.x(), l.laser_in_robot.x(), scale) ||
        !CarmenClose(a.laser_in_robot.y(), l.laser_in_robot.y(), scale)) {
      fail(k, "another laser pose");
    }
  }
}

/// Reads `data` as a CARMEN log (see the top of this file); returns 0 or aborts.
inline int ReadCarmenOnce(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const lidar::LidarReadOptions options = CarmenOptionsFromByte(data[0]);
  const std::string text(reinterpret_cast<const char*>(data) + 1, size - 1);
  const std::string& path = CarmenScratchPath();
  if ((data[0] & 8) != 0) {
    gzFile f = gzopen(path.c_str(), "wb");
    if (f == nullptr) CarmenFinding("cannot write " + path);
    if (!text.empty()) gzwrite(f, text.data(), static_cast<unsigned>(text.size()));
    gzclose(f);
  } else {
    std::ofstream f(path, std::ios::binary | std::ios::trunc);
    f << text;
  }
  lidar::LidarLog log;
  try {
    log = lidar::ReadCarmenLog(path, options);
  } catch (const Error&) {
    return 0;  // a clear refusal is the right answer to a bad log
  }
  for (const lidar::LaserScan& s : log.scans) {
    if (s.ranges.size() < 2 || !std::isfinite(s.stamp) || !(s.angle_increment > 0) || !(s.range_max > 0)) {
      CarmenFinding("a scan read with fewer than 2 beams, a stamp not finite or non-positive limits");
    }
  }
  CheckCarmenRoundTrip(log);
  try {
    lidar::DegradeOptions d;
    d.beams = 1 + (data[0] >> 5) * 3;  // 1 (refused), 4, 7, ... 22
    d.max_range = 3;
    d.noise_sigma = 0.05;
    d.drop_fraction = 0.3;
    d.keep_every = 1 + (data[0] & 1);
    d.drop_odometry = (data[0] & 2) != 0;
    const lidar::LidarLog degraded = lidar::DegradeLog(log, d);
    std::ostringstream out;
    lidar::WriteCarmenLog(out, degraded, !d.drop_odometry);
  } catch (const Error&) {
  }
  return 0;
}

}  // namespace fuzz
}  // namespace tether
