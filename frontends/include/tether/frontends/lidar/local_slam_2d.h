#pragma once
// Local SLAM: scans in, each matched against the submap built from the scans before it, then
// inserted (Hess et al. 2016, section IV without the loop closure of section V).
//
// For every scan: the pose predicted from the previous matched pose and the odometry's motion
// since the previous scan; the real-time correlative matcher's search around the prediction;
// the nonlinear refinement from its result with the regularisers towards the prediction; the
// scan inserted into the active submaps at the refined pose. The first scan is put at its
// odometry pose (or the origin), unmatched. A motion filter inserts only scans taken after the
// robot moved or turned enough (every scan is matched and has a pose). Poses are the robot's in the local map frame
// (the laser's offset on the robot, LaserScan::laser_in_robot, applied to the points).
#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "tether/core/se2.h"
#include "tether/frontends/lidar/laser_scan.h"
#include "tether/frontends/lidar/odometry_track.h"
#include "tether/frontends/lidar/real_time_correlative_scan_matcher_2d.h"
#include "tether/frontends/lidar/scan_refiner_2d.h"
#include "tether/frontends/lidar/submap_2d.h"

namespace tether {
namespace lidar {

struct LocalSlamOptions {
  SubmapOptions submaps;
  /// Off: the refinement starts at the prediction itself.
  bool use_correlative_matcher = true;
  CorrelativeMatcherOptions correlative;
  ScanRefinerOptions refiner;
  /// Edge of the voxel filter applied to the points used for matching (m; 0: none). The grid
  /// gets every valid point.
  double matching_voxel_size = 0.05;
  RangeLimits limits;
  /// Motion filter: a scan is inserted into the submaps only where the robot moved at least
  /// this far (m) or turned this much (rad) since the last inserted scan, or this much time
  /// passed (s); every scan is matched. 0, 0, 0: insert every scan.
  double insert_min_distance = 0.2;
  double insert_min_angle = 0.0174532925199432958;  // 1 degree
  double insert_max_seconds = 5;
  /// A match is trusted only where the scan's points, at the matched pose, read at least this
  /// mean probability in the submap (cells; unknown ones read correlative.unknown_probability).
  /// Below it the submap does not know where the points fall (a robot leaving a room for a
  /// corridor it has not seen: free and unknown cells around 0.5) and the matchers follow noise
  /// (fr079: turns of 10-17 degrees a scan against the odometry's 0.4); the scan then takes the
  /// prediction. 0: always trust the match. benchmarks/RESULTS.md, "LiDAR V".
  double min_match_probability = 0.52;
  /// A scan whose odometry moved less than still_distance (m) and turned less than still_angle
  /// (rad) since the scan before is not matched: it takes the prediction, the pose before. A
  /// robot standing in a corridor otherwise slides along it, every match a few centimetres from
  /// the last (aces: 2-10 cm a scan over 8 s of standing still). Off by default (0, 0: always
  /// match): at 1 mm and 1 mrad the slide on aces is gone, but the relations error with loop
  /// closures grows on Intel and aces (benchmarks/RESULTS.md, "LiDAR V").
  double still_distance = 0;
  double still_angle = 0;
  bool IsValid(std::string* why) const;
};

/// One scan's result, with the seconds its steps took.
struct LocalScanResult {
  double stamp = 0;
  SE2d predicted;        ///< the pose before matching
  SE2d pose;             ///< the matched pose (the prediction where not trusted)
  bool matched = false;  ///< false for the first scan and for a scan without points
  /// The matched pose's mean probability (0 where not matched), and whether it reached
  /// min_match_probability (false: `pose` is the prediction).
  double match_probability = 0;
  bool trusted = false;
  /// The odometry stood still (LocalSlamOptions::still_*): not matched, `pose` is the prediction.
  bool still = false;
  bool inserted = false;          ///< inserted into the submaps (the motion filter let it through)
  InsertedSubmaps inserted_into;  ///< the submaps it went into (empty where not inserted)
  int matching_points = 0;        ///< matching.size() where matched, else 0
  /// The scan's valid points in the robot's frame through the matching voxel filter (what the
  /// matchers used; a pose graph's loop-closure search takes the same points).
  std::vector<Eigen::Vector2d> matching;
  double correlative_score = 0;
  long correlative_candidates = 0;  ///< poses the correlative search scored
  double correlative_seconds = 0, refine_seconds = 0, insert_seconds = 0;
};

class LocalSlam2D {
 public:
  /// Throws InvalidArgument for invalid options.
  explicit LocalSlam2D(const LocalSlamOptions& options);

  /// Matches and inserts one scan; scans must come in time order (not checked: a log's order).
  LocalScanResult AddScan(const LaserScan& scan);

  const ActiveSubmaps2D& submaps() const { return submaps_; }
  /// One pose per scan added, with the scan's stamp.
  const std::vector<StampedPose2>& trajectory() const { return trajectory_; }

 private:
  LocalSlamOptions options_;
  ActiveSubmaps2D submaps_;
  std::vector<StampedPose2> trajectory_;
  SE2d last_odometry_;
  bool last_has_odometry_ = false;
  bool inserted_any_ = false;
  StampedPose2 last_inserted_;
};

}  // namespace lidar
}  // namespace tether
