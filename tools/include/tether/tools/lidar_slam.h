#pragma once
// `tether lidar LOG -o DIR`: 2D LiDAR SLAM over a laser log (CARMEN or ROS 1 bag) by
// tether::lidar::LidarSlam2D (frontends/lidar/lidar_slam_2d.h), whose files go to DIR:
//   trajectory.tum   one robot pose per scan (stamp x y z qx qy qz qw)
//   trajectory.g2o   the same poses (id = scan index), chained by their relative poses
//   pose_graph.g2o   the graph (scans 0..N-1, submaps N..), re-optimisable by tether optimize
//   map.pgm, map.yaml, map.png   the occupancy map (every scan inserted at its final pose)
//   loop_closures.txt   each loop closure: scan, submap, score, measured and solved relative
//                       pose, the violation (m, degrees), kept (below 20 cm and 1 degree)
//   self_check.png   the map with the self-check's sampled scans, green where they fit the
//                    map made at other times, red where not
//   trajectory.csv, kidnap.csv, kidnap.svg   the poses with their trajectory; the kidnap signals
//   state.tether     with --save-state: the saved state (lidar_state.h) `tether localize` reads
// The command parses its flags straight into the options (LidarSlamOptions, LidarReadOptions),
// runs, and prints the report.
#include <iosfwd>
#include <string>
#include <vector>

#include "tether/frontends/lidar/io/lidar_log.h"
#include "tether/frontends/lidar/lidar_slam_2d.h"

namespace tether {

struct LidarCommand {
  std::string log;
  std::string output_dir;
  lidar::LidarSlamOptions options;
  lidar::LidarReadOptions read;
  long max_scans = 0;  ///< 0: every scan
  /// Where the odometry comes from: auto, scan-line, interpolated or none (scan-only);
  /// lidar::OdometrySource's names.
  std::string odometry = "auto";
  /// Angles the command line takes in degrees (set into `options` by RunLidar).
  double search_angle_deg = lidar::PoseGraphOptions{}.search.angular_search_window * 180 / 3.14159265358979323846;
  double correlative_angle_deg =
      lidar::LocalSlamOptions{}.correlative.angular_search_window * 180 / 3.14159265358979323846;
  /// The laser's pose on the robot (x m, y m, theta rad) for every scan, replacing the log's;
  /// empty: the log's.
  std::vector<double> laser_offset;
  /// A true trajectory (TUM text, as `tether simulate lidar --truth` writes it): the absolute
  /// trajectory error of the result against it is printed (poses matched by stamp).
  std::string ground_truth;
  /// The class of scanner whose settings (lidar::ForSensor) fill every option the command line
  /// did not give: auto (chosen from the log's scans, lidar::ChooseSensor), lds, sick or hokuyo.
  std::string sensor = "auto";
  /// The flags given on the command line ("--min-range", ...): a preset leaves their values.
  std::vector<std::string> given;
  /// The body mask's sectors, "a:b[,c:d]" in degrees (lidar::ParseAngleSectors); empty: none.
  std::string mask_angles;
  long progress_every = 2000;  ///< scans between progress lines (0: none)
  bool save_state = false;     ///< also write state.tether (LidarSlam2D::StateOutput)
  /// A saved state (state.tether of an earlier run) to go on from: the log becomes a second
  /// session of that map (LidarSlam2D::Continue); empty: a new map.
  std::string continue_state;
  bool quiet = false;
};

/// Exit codes as commands.h: 0 done, 1 bad input, 2 bad usage, 4 an output not written.
int RunLidar(LidarCommand cmd, std::ostream& out, std::ostream& err);

}  // namespace tether
