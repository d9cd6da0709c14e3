#pragma once
// 2D LiDAR SLAM as one object: scans in (with odometry where the log has it), trajectory, pose
// graph, occupancy map and a report out. It owns the loop that `tether lidar` and
// `tether.LidarSlam2D` (Python) drive:
//
//   tether::lidar::LidarSlam2D slam(options);        // LidarSlamOptions: documented defaults
//   for (const tether::lidar::LaserScan& s : log.scans) slam.AddScan(s);
//   slam.Finish();                                    // the final solve, the map, the checks
//   slam.Trajectory(); slam.map(); slam.report().Summary(); slam.Outputs();
//
// Each scan goes through local SLAM (local_slam_2d.h: matched into the active submaps) and then
// into the pose graph (pose_graph_2d.h: loop closures by branch and bound, the incremental
// smoother). Finish() solves the graph, inserts every scan at its final pose into one map, and
// checks the result two ways: each loop closure against the final solution (LoopClosureCheck:
// agreement, not accuracy) and a sample of scans against the parts of the map made at other
// times (self_check_2d.h: a stretch of the trajectory placed where it does not belong fits
// nothing).
#include <Eigen/Core>
#include <deque>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "tether/core/factor_graph.h"
#include "tether/core/values.h"
#include "tether/factors/probability_grid.h"
#include "tether/frontends/lidar/eval/self_check_2d.h"
#include "tether/frontends/lidar/io/lidar_log.h"
#include "tether/frontends/lidar/io/lidar_state.h"
#include "tether/frontends/lidar/mapping/local_slam_2d.h"
#include "tether/frontends/lidar/mapping/pose_graph_2d.h"
#include "tether/frontends/lidar/sensor/body_mask.h"
#include "tether/frontends/lidar/sensor/laser_scan.h"

namespace tether {
namespace lidar {

struct LidarSlamOptions {
  LocalSlamOptions local;       ///< local SLAM; local.limits also bound the final map's points
  PoseGraphOptions pose_graph;  ///< loop closures and the smoother (threads: the machine's cores)
  SelfCheckOptions self_check;
  /// The robot's own body: beams shorter than mask.min_range or in mask.sectors are no return
  /// in every scan, before matching and before any map (body_mask.h). Empty by default.
  BodyMask mask;
  /// A loop closure counts as kept by the solution where the final poses violate it by less
  /// than this (m, degrees).
  double kept_translation = 0.2;
  double kept_rotation_deg = 1;
  bool IsValid(std::string* why) const;
};

/// One loop closure against the final solution.
struct LoopClosureCheck {
  LoopClosure closure;
  SE2d solved;                       ///< the scan in the submap's frame by the final poses
  double translation_violation = 0;  ///< m
  double rotation_violation_deg = 0;
  bool kept = false;
};

/// A trajectory (a kidnap starts a new one): where it starts and when it joined the map.
struct TrajectoryReport {
  long first_scan = 0;
  double first_stamp = 0;
  long joined_scan = -1;  ///< the scan whose closures joined it to the map (-1: never; the first: 0)
  double joined_stamp = 0;
  bool session = false;  ///< started by the log after a saved state (LidarSlam2D::Continue), not a kidnap
};

/// What a run did and how long it took (seconds).
struct LidarSlamReport {
  long scans = 0;
  int submaps = 0;
  long loop_closures = 0;
  long closures_kept = 0;  ///< kept by the final solution (LidarSlamOptions::kept_*)
  PoseGraphStats graph;
  long scan_only = 0;     ///< scans without odometry
  long scan_to_scan = 0;  ///< of those, predicted by scan-to-scan matching (the others: constant velocity)
  long widened = 0;       ///< scan-only scans searched again with the weak-prediction window
  long imu_turns = 0;     ///< scan-only scans whose prediction turned by the IMU
  long masked_beams = 0;  ///< valid beams the body mask made no return (LidarSlamOptions::mask)
  /// Matched scans below the match probability: they took the prediction (odometry's or
  /// scan-to-scan's; a scan with only constant velocity keeps its match).
  long untrusted = 0;
  long untrusted_scan_only = 0;  ///< of those, scans without odometry
  double logged_seconds = 0;     ///< the log's span (last stamp - first)
  double total_seconds = 0, matching_seconds = 0, insert_seconds = 0, graph_seconds = 0, map_seconds = 0,
         check_seconds = 0;
  SelfCheckResult self_check;
  /// One per trajectory: the first, and one per kidnap declared.
  std::vector<TrajectoryReport> trajectories;
  /// The kidnap signals alone (KidnapStep): the first scans of the runs where the cost rule
  /// fired, and the scans that broke with the scan before.
  std::vector<long> cost_rises;
  std::vector<long> breaks;
  /// Declared kidnaps withdrawn: the scan fitted the current submap near the last pose before
  /// the break (KidnapOptions::relocate_window), and the trajectory went on from there.
  std::vector<long> relocations;
  double first_stamp = 0;       ///< the first scan's stamp (times in the summary count from it)
  double max_kidnap_ratio = 0;  ///< the largest rise of the filtered cost (KidnapStep::ratio)
  long max_kidnap_ratio_scan = -1;
  double kidnap_threshold = 0;  ///< KidnapOptions::threshold
  double max_overlap = 0;       ///< KidnapOptions::max_overlap
  /// The lines `tether lidar` prints.
  std::string Summary(int threads) const;
  /// Of those, the kidnaps' (`kidnap detected at scan N (t = T s)`, N from 1, T from the first
  /// scan) and the independent signal's.
  std::string KidnapSummary() const;
};

/// A file a run writes, by name: the bytes Outputs() gives.
struct LidarOutput {
  std::string name;  ///< file name within the output folder
  std::string what;  ///< for messages
  std::string bytes;
};

class LidarSlam2D {
 public:
  /// Throws InvalidArgument naming the option for invalid options.
  explicit LidarSlam2D(const LidarSlamOptions& options = {});
  ~LidarSlam2D();
  LidarSlam2D(const LidarSlam2D&) = delete;
  LidarSlam2D& operator=(const LidarSlam2D&) = delete;

  /// Multi-session mapping: before the first scan, a saved state (State() of an earlier run, or
  /// ReadLidarState) becomes the map this run goes on from (PoseGraph2D::Restore): its scans are
  /// scans 0.., trajectory 0; the scans added next form a new trajectory that joins it by the
  /// global search (as after a kidnap), and the outputs, the map and State() hold both. Throws
  /// InvalidArgument after a scan was added or for a state with a Problem().
  void Continue(const LidarState& state);
  /// Adds the next scan (time order). Where local SLAM declares a kidnap at it, the trajectory
  /// ends there and the scan starts a new one (LidarSlamReport::trajectories). Throws InvalidArgument for a scan
  /// ScanProblem refuses (nothing changes), after Finish(), and after an earlier scan failed part-way (a point far
  /// outside any map): the run cannot go on then.
  void AddScan(const LaserScan& scan);
  /// Adds the first `max_scans` scans of a log (0: all) and calls Finish(); `progress`, where
  /// given, is called after every `progress_every`-th scan with the scans added so far. An
  /// error adding a scan is raised again as a ParseError naming the scan's file:line (or bag
  /// message).
  void Run(const LidarLog& log, long max_scans = 0, long progress_every = 0,
           const std::function<void(long)>& progress = nullptr);
  /// Waits for the searches, solves the graph, builds the map and runs the checks. Once.
  void Finish();
  bool finished() const { return finished_; }

  /// Scans added. The last KidnapOptions::filter_size - 1 of them wait for the kidnap detector
  /// before they reach the pose graph (and Trajectory()); Finish() hands them over.
  long scan_count() const { return added_; }
  /// The scans' poses (robot frame; the first scan's odometry frame, or the origin), each with
  /// its scan's stamp: the pose graph's current estimate (final after Finish()).
  std::vector<StampedPose2> Trajectory() const;
  /// The trajectory as a g2o graph: scan i is vertex i, chained by their relative poses (unit
  /// information), so that it reads back as one connected graph.
  void TrajectoryGraph(FactorGraph* graph, Values* values) const;
  const PoseGraph2D& pose_graph() const { return *graph_; }
  /// The occupancy map of every scan at its final pose (after Finish()).
  const ProbabilityGrid& map() const;
  const std::vector<LoopClosureCheck>& closure_checks() const { return checks_; }
  /// Every scan's kidnap detection signals, in order.
  const std::vector<KidnapRecord>& kidnap_records() const { return kidnap_records_; }
  const LidarSlamReport& report() const { return report_; }
  const LidarSlamOptions& options() const { return options_; }

  /// The files of a finished run (trajectory.tum, trajectory.g2o, pose_graph.g2o, map.pgm,
  /// map.yaml, map.png, loop_closures.txt, self_check.png, trajectory.csv: the poses with
  /// their trajectory, kidnap.csv and kidnap.svg: the detection's signals), in OutputNames()'
  /// order.
  std::vector<LidarOutput> Outputs() const;
  /// Their names and descriptions (bytes empty), for checking a folder before a run.
  static std::vector<LidarOutput> OutputNames();
  /// What a finished run built, to localise in or to go on from (lidar_state.h): every scan
  /// with its points and poses, the submaps, the loop closures and the map.
  LidarState State() const;
  /// The state file's name and description (`tether lidar --save-state`), and with its bytes.
  static LidarOutput StateOutputName() { return {"state.tether", "saved state", ""}; }
  LidarOutput StateOutput() const;

 private:
  struct ScanRecord {
    double stamp = 0;
    SE2d laser_in_robot;
    std::vector<Eigen::Vector2d> points;  ///< valid points, the laser's frame
  };

  /// A scan local SLAM has matched, waiting for the pose graph.
  struct Staged {
    LaserScan scan;  ///< masked
    LocalScanResult result;
    KidnapRecord record;
  };
  /// Notes the trajectories the pose graph joined by now (the scan being added: `stamp`).
  void NoteJoins(double stamp);
  /// A kidnap declared at *st: the trajectory ends where it began; the staged scans from there
  /// and *st go through a new local SLAM.
  void Restart(Staged* st);
  /// Hands the oldest staged scan to the pose graph.
  void Commit();

  LidarSlamOptions options_;
  std::unique_ptr<LocalSlam2D> local_;
  std::unique_ptr<PoseGraph2D> graph_;
  std::vector<ScanRecord> scans_;
  std::shared_ptr<ProbabilityGrid> map_;
  std::vector<LoopClosureCheck> checks_;
  std::vector<KidnapRecord> kidnap_records_;
  std::deque<Staged> staged_;
  long added_ = 0;          ///< scans added (staged or in the graph), with a continued state's
  bool continued_ = false;  ///< Continue() gave the first scans; the next one starts a trajectory
  LidarSlamReport report_;
  bool finished_ = false;
  std::string failed_;  ///< why an earlier AddScan failed part-way, if one did
};

}  // namespace lidar
}  // namespace tether
