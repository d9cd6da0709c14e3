#pragma once
// Where the laser sits on the robot, from the log itself: a robot that turns in place turns
// about its own centre, and a laser mounted at (x, y) on it then moves by (R(theta) - I) (x, y)
// in the frame it started in, on top of whatever the odometry says the centre moved. Each turn
// in place (the odometry turns by at least min_turn while moving less than max_translation)
// is matched scan to scan (scan_to_scan_2d.h) in the laser's frame, and the offset is the
// least-squares solution of the linear equations the turns give:
//   laser motion translation = odometry translation + (R(theta) - I) offset.
// A check of a log's or a bag's mounting (LaserScan::laser_in_robot) against its data.
#include <string>

#include "tether/frontends/lidar/io/lidar_log.h"

namespace tether {
namespace lidar {

struct LaserOffsetOptions {
  double min_turn = 0.35;         ///< rad
  double max_translation = 0.03;  ///< m, by the odometry over the turn
  int max_scans_per_turn = 40;    ///< a turn spans at most this many scans
  double max_rms = 0.03;          ///< m: scan-to-scan matches worse than this are left out
  int min_pairs = 100;            ///< points paired, at least
  double max_range = 20;          ///< m: farther points are left out of the matches
  int max_turns = 200;            ///< the first this many turns are used
  bool IsValid(std::string* why) const;
};

struct LaserOffsetEstimate {
  int turns = 0;        ///< turns in place used (0: no estimate)
  double x = 0, y = 0;  ///< the laser's position on the robot (m)
  /// Root mean square of the turns' translation residuals at the estimate and at the log's
  /// own laser_in_robot (m).
  double rms = 0, rms_at_log = 0;
};

/// Throws InvalidArgument for invalid options. Scans without odometry are skipped.
LaserOffsetEstimate EstimateLaserOffset(const LidarLog& log, const LaserOffsetOptions& options = {});

}  // namespace lidar
}  // namespace tether
