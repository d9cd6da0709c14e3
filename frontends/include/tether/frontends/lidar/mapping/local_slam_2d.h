#pragma once
// Local SLAM: scans in, each matched against the submap built from the scans before it, then
// inserted (Hess et al. 2016, section IV without the loop closure of section V).
//
// For every scan: the pose predicted from the previous matched pose and the odometry's motion
// since the previous scan; the real-time correlative matcher's search around the prediction;
// the nonlinear refinement from its result with the regularisers towards the prediction; the
// scan inserted into the active submaps at the refined pose. Scans without odometry are
// predicted by constant velocity from the two scans before (LocalSlamOptions). The first scan
// is put at its odometry pose (or the origin), unmatched. A motion filter inserts only scans taken after the
// robot moved or turned enough (every scan is matched and has a pose). Poses are the robot's in the local map frame
// (the laser's offset on the robot, LaserScan::laser_in_robot, applied to the points).
#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <unordered_set>
#include <vector>

#include "tether/core/se2.h"
#include "tether/frontends/lidar/mapping/kidnap_detector.h"
#include "tether/frontends/lidar/mapping/submap_2d.h"
#include "tether/frontends/lidar/scan_matching/real_time_correlative_scan_matcher_2d.h"
#include "tether/frontends/lidar/scan_matching/scan_refiner_2d.h"
#include "tether/frontends/lidar/scan_matching/scan_to_scan_2d.h"
#include "tether/frontends/lidar/sensor/laser_scan.h"
#include "tether/frontends/lidar/sensor/odometry_track.h"

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
  /// Scans without odometry (OdometryOrigin::kNone: a scanner alone, or a log read with the
  /// odometry dropped) are predicted from the scan before: a scan-to-scan match
  /// (scan_to_scan_2d.h) from two guesses, the motion between the last two scans (constant
  /// motion per scan) and none, the first kept unless the second pairs 10% more points (along
  /// a corridor both pair alike: the robot is taken to keep moving); its motion then stands in
  /// for odometry's. Per scan, not per second: logs' stamps are when a scan was logged, and
  /// bunch (Intel: 0.01, 0.14, 0.54, 0 and 0 s between five scans at 5 Hz); a velocity
  /// scaled by them predicted 1.4 rad where the robot turned 0.05. Where that match
  /// fails (or scan_to_scan is off), the prediction is constant velocity alone, weaker than
  /// odometry's, so such a scan whose first search is not trusted or whose best candidate lies
  /// on the window's edge
  /// is searched again with the wider `weak_prediction` window, with a weaker preference for
  /// the prediction's translation (weak_prediction_translation_weight instead of
  /// correlative.translation_delta_cost_weight: the prediction is the thing in doubt), and
  /// refined with the regularisers pulling towards that search's best. A scan-only scan keeps its match even below
  /// min_match_probability: constant velocity only repeats the match before, and a scan that
  /// took it would stop a robot that starts from rest (the velocity stays zero) while the
  /// scans move on.
  double weak_prediction_linear_window = 0.3;       ///< m, half side
  double weak_prediction_angular_window = 0.524;    ///< rad, half range (30 degrees)
  double weak_prediction_translation_weight = 0.1;  ///< 1/m
  bool scan_to_scan = true;
  ScanToScanOptions scan_to_scan_options;
  /// The correlative search's preference for a scan-to-scan prediction's translation (1/m; at
  /// least correlative.translation_delta_cost_weight): a submap favours the poses its own
  /// scans were taken from, and without odometry nothing else holds a match in a corridor to
  /// the robot's motion. Scan-only, no loop closure, the first scans of each log (benchmarks/
  /// RESULTS.md, "LiDAR X"): 5 against 2: aces (800 scans) 0.0777 -> 0.0478 m, Intel (3000)
  /// 0.389 -> 0.149 m, fr079 (1500) 0.0336 -> 0.0353 m; 10 gives the same as 5.
  double scan_to_scan_translation_weight = 5;
  /// Scan-only scans whose scan and the one before carry an IMU heading (LaserScan::imu_yaw):
  /// the turn between them is the prediction's rotation (constant motion keeps only its
  /// translation), the scan-to-scan match starts from it (both guesses) and is pulled towards
  /// it with this weight (1/rad, in place of scan_to_scan_options.guess_rotation_weight where
  /// larger: 20 against a pair's 1/m, so a few hundred pairs along walls still correct a
  /// gyro's drift, while a room without corners keeps the gyro's turn). Scans with odometry
  /// do not use it.
  double imu_rotation_weight = 20;
  /// Kidnap detection (kidnap_detector.h): every matched scan's cost is filtered; where a kidnap
  /// is declared (and kidnap.detect is on) the scan is neither inserted nor kept
  /// (LocalScanResult::kidnapped): local SLAM cannot go on from where it was, and its owner
  /// starts a new one (LidarSlam2D: a new trajectory).
  KidnapOptions kidnap;
  /// A run that never ends (localisation in a saved map): keep only the newest this many
  /// submaps and the last poses (trajectory() then holds the last few), so that memory stays
  /// bounded. 0: keep everything (mapping).
  int keep_submaps = 0;
  bool IsValid(std::string* why) const;
};

/// One scan's result, with the seconds its steps took.
struct LocalScanResult {
  double stamp = 0;
  SE2d predicted;        ///< the pose before matching
  SE2d pose;             ///< the matched pose (the prediction where not trusted and not scan-only)
  bool matched = false;  ///< false for the first scan and for a scan without points
  /// The matched pose's mean probability (0 where not matched), and whether it reached
  /// min_match_probability (false: `pose` is the prediction).
  double match_probability = 0;
  bool trusted = false;
  /// The odometry stood still (LocalSlamOptions::still_*): not matched, `pose` is the prediction.
  bool still = false;
  /// The scan had no odometry: the prediction is constant velocity from the scans before.
  bool scan_only = false;
  /// The prediction came from a scan-to-scan match (scan-only scans).
  bool scan_to_scan = false;
  /// The prediction's rotation came from the IMU (scan-only scans with an IMU heading).
  bool imu_turn = false;
  /// Searched a second time with the weak-prediction window (scan-only scans).
  bool widened = false;
  bool inserted = false;          ///< inserted into the submaps (the motion filter let it through)
  InsertedSubmaps inserted_into;  ///< the submaps it went into (empty where not inserted)
  int matching_points = 0;        ///< matching.size() where matched, else 0
  /// The scan's valid points in the robot's frame through the matching voxel filter (what the
  /// matchers used; a pose graph's loop-closure search takes the same points).
  std::vector<Eigen::Vector2d> matching;
  double correlative_score = 0;
  long correlative_candidates = 0;  ///< poses the correlative search scored
  /// Kidnap detection (matched scans only): the cost (1 - the mean probability the matched
  /// points read, unknown cells 0.5), the detector's step, the share of the points on
  /// occupied cells (KidnapOptions::hit_probability), and the overlap (below).
  double match_cost = 0;
  KidnapStep kidnap;
  double hit_fraction = 0;
  /// The share of the points within about 0.1 m of a point of the scan before (both at their
  /// poses); -1 where there was none.
  double overlap = -1;
  /// The detector declared a kidnap and KidnapOptions::detect is on: the scan was not inserted
  /// and not kept in trajectory(); nothing more can be added (a new LocalSlam2D takes over).
  bool kidnapped = false;
  double scan_to_scan_seconds = 0, correlative_seconds = 0, refine_seconds = 0, insert_seconds = 0;
};

class LocalSlam2D {
 public:
  /// Throws InvalidArgument for invalid options.
  explicit LocalSlam2D(const LocalSlamOptions& options);

  /// Matches and inserts one scan; scans must come in time order (not checked: a log's order).
  /// Throws InvalidArgument after a scan that was kidnapped.
  LocalScanResult AddScan(const LaserScan& scan);

  /// Ends this local SLAM's run (a kidnap): its active submaps are finished and returned
  /// (ActiveSubmaps2D::FinishActive); no scan can be added afterwards.
  InsertedSubmaps FinishTrajectory();

  const ActiveSubmaps2D& submaps() const { return submaps_; }
  /// One pose per scan added, with the scan's stamp (with keep_submaps, the last few only).
  const std::vector<StampedPose2>& trajectory() const { return trajectory_; }

 private:
  LocalSlamOptions options_;
  ActiveSubmaps2D submaps_;
  std::vector<StampedPose2> trajectory_;
  /// The constant-motion prediction of a scan without odometry: the last scan's pose moved
  /// as it moved from the scan before.
  SE2d ConstantVelocity() const;
  /// A scan-only scan's first search is weak: below min_match_probability, or its best on
  /// the window's outermost ring of translations or rotations.
  bool WeakMatch(const CorrelativeMatch& m, const SE2d& predicted, const ProbabilityGrid& grid) const;
  /// A declared kidnap's scan searched in `grid` near the last pose before the break
  /// (KidnapOptions::relocate_*): true, with the refined pose, where it fits there as well as
  /// the scans before (`before`: their filtered cost).
  bool Relocate(const std::shared_ptr<const ProbabilityGrid>& grid, const std::vector<Eigen::Vector2d>& matching,
                double before, SE2d* pose) const;

  std::vector<Eigen::Vector2d> last_points_;     ///< the last scan with points, its robot frame
  std::unordered_set<std::int64_t> last_cells_;  ///< its matching points' 0.1 m cells, the map frame
  SE2d last_odometry_;
  bool last_has_odometry_ = false;
  double last_imu_yaw_ = 0;
  bool last_has_imu_yaw_ = false;
  bool inserted_any_ = false;
  StampedPose2 last_inserted_;
  KidnapDetector kidnap_;
  bool kidnapped_ = false;
};

}  // namespace lidar
}  // namespace tether
