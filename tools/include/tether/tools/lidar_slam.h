#pragma once
// `tether lidar LOG -o DIR`: 2D LiDAR SLAM over a laser log (CARMEN or ROS 1 bag): local SLAM
// (scan matching into submaps, frontends/lidar/local_slam_2d.h), the pose graph with
// branch-and-bound loop closures fed to the incremental smoother while the scans stream in
// (pose_graph_2d.h), then the outputs in DIR:
//   trajectory.tum   one robot pose per scan (stamp x y z qx qy qz qw)
//   trajectory.g2o   the same poses (id = scan index), chained by their relative poses
//   pose_graph.g2o   the graph (scans 0..N-1, submaps N..), re-optimisable by tether optimize
//   map.pgm, map.yaml, map.png   the occupancy map (every scan inserted at its final pose)
//   loop_closures.txt   each loop closure: scan, submap, score, measured and solved relative
//                       pose, the violation (m, degrees), kept (below 20 cm and 1 degree)
#include <iosfwd>
#include <string>

#include "tether/frontends/lidar/local_slam_2d.h"
#include "tether/frontends/lidar/pose_graph_2d.h"

namespace tether {

struct LidarCommand {
  std::string log;
  std::string output_dir;
  bool loop_closure = true;
  int threads = 1;     ///< background loop-closure search threads (0: inline)
  long max_scans = 0;  ///< 0: every scan
  int scans_per_submap = 90;
  double resolution = 0.05;
  int search_every = 10;                                              ///< loop-closure search for every N-th scan
  int update_every = lidar::PoseGraphOptions{}.update_every_n_scans;  ///< scans per smoother update
  double min_score = 0.55;                                            ///< branch and bound's score threshold
  /// The pose graph's constraints (PoseGraphOptions): sigmas of the local constraints and of
  /// the loop closures (translation m, rotation rad), and the loop closures' Huber delta.
  double local_translation_sigma = 0.1, local_rotation_sigma = 0.04;
  double consecutive_translation_sigma = 0.01, consecutive_rotation_sigma = 0.002;
  double local_huber_delta = 0.25;
  double loop_translation_sigma = 0.05, loop_rotation_sigma = 0.02;
  double huber_delta = 1;
  double rival_ratio = 0.9;  ///< PoseGraphOptions::rival_ratio (0: keep ambiguous matches)
  /// PoseGraphOptions::confirm_* (0 m: off)
  double confirm_translation = lidar::PoseGraphOptions{}.confirm_translation;
  double confirm_rotation = lidar::PoseGraphOptions{}.confirm_rotation;
  double max_search_distance = 8;  ///< PoseGraphOptions::max_search_distance (m)
  /// Branch and bound's window (PoseGraphOptions::search): half its side (m) and half its
  /// rotations (degrees).
  double search_voxel_size = lidar::PoseGraphOptions{}.search_voxel_size;  ///< m
  double search_window = lidar::PoseGraphOptions{}.search.linear_search_window;
  double search_window_growth = lidar::PoseGraphOptions{}.search_window_growth;  ///< m per m of graph distance
  double max_search_window = lidar::PoseGraphOptions{}.max_search_window;        ///< m
  double search_angle_deg = lidar::PoseGraphOptions{}.search.angular_search_window * 180 / 3.14159265358979323846;
  double max_range = 0;  ///< 0: the log's
  /// Local matching (LocalSlamOptions' defaults): the scan-match factor's regulariser weights
  /// towards the odometry's prediction (ScanMatchWeights translation, rotation), the correlative
  /// search's preference for it (CorrelativeMatcherOptions *_delta_cost_weight) and its half
  /// window of rotations (degrees), and min_match_probability.
  double match_translation_weight = lidar::LocalSlamOptions{}.refiner.weights.translation;
  double match_rotation_weight = lidar::LocalSlamOptions{}.refiner.weights.rotation;
  double correlative_translation_weight = lidar::LocalSlamOptions{}.correlative.translation_delta_cost_weight;
  double correlative_rotation_weight = lidar::LocalSlamOptions{}.correlative.rotation_delta_cost_weight;
  double correlative_angle_deg =
      lidar::LocalSlamOptions{}.correlative.angular_search_window * 180 / 3.14159265358979323846;
  double min_match_probability = lidar::LocalSlamOptions{}.min_match_probability;
  double still_distance = lidar::LocalSlamOptions{}.still_distance;  ///< m
  double still_angle = lidar::LocalSlamOptions{}.still_angle;        ///< rad
  std::string scan_topic = "/scan";
  std::string odom_topic = "/odom";
  long progress_every = 2000;  ///< scans between progress lines (0: none)
  bool quiet = false;
};

/// Exit codes as commands.h: 0 done, 1 bad input, 2 bad usage, 4 an output not written.
int RunLidar(const LidarCommand& cmd, std::ostream& out, std::ostream& err);

}  // namespace tether
