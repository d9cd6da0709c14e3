#pragma once
// `tether lidar-eval TRAJECTORY RELATIONS`: the relations metric of Kümmerle et al. (see
// tether/frontends/lidar/eval/relations_metric.h) of a trajectory: TUM text, or a laser log (CARMEN,
// plain or gzip, or a ROS 1 bag) whose scans' odometry poses are the trajectory.
#include <iosfwd>
#include <string>

namespace tether {

struct LidarEvalCommand {
  bool quiet = false;  ///< only the scores (no lines on what was read)
  std::string trajectory;
  std::string relations;
  /// auto: a ROS bag by its first bytes, a CARMEN log by its name (.clf, .log, .gz), else TUM.
  std::string format = "auto";
  /// Logs: where each scan's pose comes from (auto, scan-line, interpolated, none).
  std::string odometry = "auto";
  std::string scan_topic = "/scan";
  std::string odom_topic = "/odom";
  /// A relation's stamp matches the nearest pose within this (seconds).
  double tolerance = 1e-3;
  /// The raw log the trajectory (a log) was derived from: each scan takes the stamp of the raw
  /// scan with its ranges near its logger time (restamp.h), as the corrected logs need.
  std::string time_reference;
  double time_reference_tolerance = 0.011;
  /// "x,y,theta": every pose T becomes T * offset before scoring (e.g. laser poses scored on
  /// relations of the robot's poses); empty for none.
  std::string pose_offset;
  /// Also write the trajectory scored (after restamping and the offset) as TUM text.
  std::string trajectory_output;
};

/// Exit codes as commands.h: 0 scored, 1 bad input (file:line), 2 bad usage, 4 an output that
/// cannot be written.
int RunLidarEval(const LidarEvalCommand& cmd, std::ostream& out, std::ostream& err);

}  // namespace tether
