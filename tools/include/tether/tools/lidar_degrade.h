#pragma once
// `tether lidar-degrade IN -o OUT.log`: a laser log (CARMEN or ROS 1 bag) degraded as a cheaper
// scanner or a poorer robot would record it, written as a CARMEN log (see
// tether/frontends/lidar/io/degrade_log.h and docs/lidar.md, "Degraded logs").
#include <cstddef>
#include <cstdint>
#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

namespace tether {

struct LidarDegradeCommand {
  std::string input;
  std::string output;
  /// A preset (lidar::DegradePreset: "lds") the options below change; empty for none.
  std::string preset;
  /// Each given option overrides the preset's (or DegradeOptions' default) value.
  std::optional<int> beams;
  std::optional<double> max_range;
  std::optional<double> noise;  ///< metres (DegradeOptions::noise_sigma)
  std::optional<double> drop;   ///< DegradeOptions::drop_fraction
  std::optional<double> error_share;
  std::optional<int> keep_every;
  std::optional<std::size_t> first_scan;
  std::optional<std::size_t> max_scans;
  std::optional<std::uint64_t> seed;
  bool no_odometry = false;
  /// Odometry drift: translation share, rotation share, rotation per metre (DegradeOptions'
  /// odometry_*_noise); empty: none.
  std::vector<double> odometry_drift;
  /// A kidnap: at, seconds (DegradeOptions::kidnap_at, kidnap_seconds); empty: none. The offset
  /// x, y, theta (empty: none) and the two switches as DegradeOptions has them.
  std::vector<double> kidnap;
  std::vector<double> kidnap_offset;
  bool kidnap_close_gap = false;
  bool kidnap_keep_odometry = false;
  /// Reading the input: where each scan's odometry comes from (auto, scan-line, interpolated,
  /// none), and a bag's topics.
  std::string odometry = "auto";
  std::string scan_topic = "/scan";
  std::string odom_topic = "/odom";
};

/// Exit codes as commands.h: 0 written, 1 bad input (file:line), 2 bad usage, 4 an output that
/// cannot be written (nothing is written).
int RunLidarDegrade(const LidarDegradeCommand& cmd, std::ostream& out, std::ostream& err);

}  // namespace tether
