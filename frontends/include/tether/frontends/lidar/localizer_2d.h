#pragma once
// Localisation in a saved map (`tether localize LOG --state STATE`): the robot tracked against
// the frozen map of an earlier run (lidar_state.h), from an unknown start.
//
//   tether::lidar::Localizer2D loc(state, options);   // LocalizationOptions: documented defaults
//   for (const tether::lidar::LaserScan& s : log.scans) {
//     const tether::lidar::LocalizedScan r = loc.AddScan(s);   // r.localized, r.pose
//   }
//   loc.report().Summary();
//
// - Local SLAM (local_slam_2d.h) tracks the robot in a frame of its own, as in mapping, keeping
//   only its newest submaps (LocalizationOptions::keep_submaps): memory does not grow with the
//   log. The saved map is never changed.
// - Until the first fix: every global_every_n_scans-th scan is searched by branch and bound
//   over the whole saved map at every heading (global localisation; no initial pose needed).
//   A match that scores above global_min_score and has no rival elsewhere in the map (another
//   place or heading scoring within global_rival_ratio of it) is a candidate: it says where
//   local SLAM's frame lies in the map. Two candidates from scans at least confirm_min_travel
//   apart (or turned confirm_min_turn) that place the frame alike (confirm_*) are the fix: a
//   single scan can match a look-alike room; two views seldom agree on one. A robot standing
//   still has one view: confirm_still_candidates alike candidates from it are the fix.
// - Once fixed, two ways, each scan refined against the saved map (the scan-match factor) and
//   taken where it fits (LocalizationOptions::min_known_share, track_min_score, max_correction_*):
//   - tracking the map: the prediction is the last pose moved by the odometry (scans without
//     odometry, or where the odometry's prediction does not fit: by a scan-to-scan match); local
//     SLAM does not run. The saved map is better than
//     any submap local SLAM could build, and local SLAM's search costs most of the time (aces: 19
//     ms a scan, a ceiling of 10x real time).
//   - dead reckoning by local SLAM: where a scan does not fit (the map does not know where its
//     points fall: the robot beyond the mapped area; a door the map has closed; odometry that
//     slipped), a new local SLAM starts at the predicted pose and carries the poses, each still
//     refined against the map; after resume_after_scans scans in a row that fit, tracking the map
//     takes over again.
//   After lost_after_scans scans in a row that do not fit (scans beyond the mapped area do not
//   count), or a kidnap local SLAM declares, the fix is lost and global localisation starts
//   again.
// - --initial-pose (LocalizationOptions::initial_pose): the first scan is placed there and
//   tracking starts at once (no global search).
#include <Eigen/Core>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "tether/core/se2.h"
#include "tether/factors/probability_grid.h"
#include "tether/frontends/lidar/io/lidar_log.h"
#include "tether/frontends/lidar/io/lidar_state.h"
#include "tether/frontends/lidar/lidar_slam_2d.h"
#include "tether/frontends/lidar/mapping/local_slam_2d.h"
#include "tether/frontends/lidar/scan_matching/fast_correlative_scan_matcher_2d.h"
#include "tether/frontends/lidar/scan_matching/scan_refiner_2d.h"
#include "tether/frontends/lidar/sensor/body_mask.h"
#include "tether/frontends/lidar/sensor/laser_scan.h"

namespace tether {
namespace lidar {

struct LocalizationOptions {
  LocalSlamOptions local = DefaultLocalOptions();
  BodyMask mask;  ///< as LidarSlamOptions::mask
  /// Local SLAM's submaps kept (LocalSlamOptions::keep_submaps): the newest few.
  int keep_submaps = 3;
  /// Global localisation: every this many scans until the fix.
  int global_every_n_scans = 5;
  double global_min_score = 0.6;
  /// A match is ambiguous where another candidate at least global_rival_distance (m) away or
  /// global_rival_angle (rad) turned scores above global_rival_ratio times its score.
  double global_rival_ratio = 0.9;
  double global_rival_distance = 1;
  double global_rival_angle = 0.1;
  double global_angular_step = 0.00872664625997165;  ///< rad (0.5 degrees)
  double global_search_voxel_size = 0.2;             ///< m: the points branch and bound scores
  /// Branch and bound scores only the points at most this far from the robot (m; 0: all).
  double global_max_range = 0;
  FastMatcherOptions search;  ///< its depth (the windows are the map's)
  /// Two candidates confirm each other where they place local SLAM's frame within these (m,
  /// rad, compared at the later scan) and their scans lie confirm_min_travel (m) apart or
  /// turned confirm_min_turn (rad) by local SLAM, at most confirm_max_scans scans apart.
  double confirm_translation = 0.3;
  double confirm_rotation = 0.05;
  double confirm_min_travel = 1;
  double confirm_min_turn = 0.5;
  int confirm_max_scans = 300;
  /// A robot that stands still shows one view only: that many candidates (within
  /// confirm_max_scans) placing the frame alike are the fix as well (0: never; a fix then needs
  /// the robot to move).
  int confirm_still_candidates = 4;
  /// Tracking: the refined scan fits where at least min_known_share of its points fall on cells
  /// the map knows and those read at least track_min_score mean probability, and it moved less
  /// than max_correction_translation (m) and max_correction_rotation (rad) from the prediction.
  /// A scan with fewer of its points on known cells (the robot beyond the mapped area) is not
  /// refined: local SLAM carries the pose, and it does not count towards lost_after_scans.
  double min_known_share = 0.3;
  double track_min_score = 0.5;
  double max_correction_translation = 0.3;
  double max_correction_rotation = 0.1;
  ScanRefinerOptions refine;
  /// Scans in a row that do not fit before the fix is given up (global localisation again).
  int lost_after_scans = 50;
  /// Dead reckoning hands back to tracking the map after this many scans in a row that fit.
  int resume_after_scans = 3;
  /// Where known: the first scan's pose in the map; tracking starts there.
  bool has_initial_pose = false;
  SE2d initial_pose;
  bool IsValid(std::string* why) const;
  /// Local SLAM's settings for localisation: the mapping defaults, keeping few submaps.
  static LocalSlamOptions DefaultLocalOptions();
};

/// One scan's result.
struct LocalizedScan {
  long scan = 0;  ///< from 0, in the order added
  double stamp = 0;
  bool localized = false;  ///< the pose is known in the map (after the fix)
  SE2d pose;               ///< the robot in the map (where localized)
  bool tracked = false;    ///< refined against the map and fitted (else: the prediction)
  bool outside = false;    ///< too few points on cells the map knows: not refined
  double score = 0;        ///< the mean probability its points on known cells read at `pose`
  bool fix = false;        ///< the fix was made (or made again) at this scan
  bool global = false;     ///< searched globally
};

struct LocalizationReport {
  long scans = 0;
  long localized = 0;
  long tracked = 0;
  long outside = 0;               ///< localised scans beyond the mapped area (LocalizedScan::outside)
  long dead_reckoned = 0;         ///< localised scans local SLAM carried (the others: tracking the map)
  long first_fix_scan = -1;       ///< -1: never
  double first_fix_seconds = -1;  ///< of log, from the first scan
  long fixes = 0;                 ///< the first and any after a loss
  long losses = 0;
  long global_searches = 0;
  long candidates = 0;  ///< global matches found (above the score, no rival)
  long ambiguous = 0;   ///< global matches dropped for a rival
  double global_seconds = 0;
  double total_seconds = 0;             ///< every scan
  double localized_seconds = 0;         ///< of that, the scans once localised
  double logged_seconds = 0;            ///< the log's span
  double logged_localized_seconds = 0;  ///< the log's time while localised
  std::string Summary() const;
};

class Localizer2D {
 public:
  /// Throws InvalidArgument for invalid options or a state without a map.
  Localizer2D(const LidarState& state, const LocalizationOptions& options = {});
  ~Localizer2D();
  Localizer2D(const Localizer2D&) = delete;
  Localizer2D& operator=(const Localizer2D&) = delete;

  /// The next scan (time order). Throws InvalidArgument for a scan ScanProblem refuses.
  LocalizedScan AddScan(const LaserScan& scan);
  /// Adds scans start_scan .. start_scan + max_scans - 1 of a log (max_scans 0: to the end),
  /// `repeat` times over (each pass's stamps moved on by the log's span and a scan interval:
  /// an endless log), keeping each result (results()); `progress`, where given, is called after
  /// every `progress_every`-th scan. An error adding a scan is raised again as a ParseError
  /// naming the scan's file:line.
  void Run(const LidarLog& log, long start_scan = 0, long max_scans = 0, int repeat = 1, long progress_every = 0,
           const std::function<void(long)>& progress = nullptr);
  /// Every result Run kept, in order.
  const std::vector<LocalizedScan>& results() const { return results_; }
  /// The localised scans' poses with their stamps.
  std::vector<StampedPose2> Trajectory() const;
  /// The files of a run (poses.tum: the localised scans' poses; localization.csv: every scan's
  /// result; localization.png: the map with the localised positions, blue where they fitted
  /// the map, orange where local SLAM carried them, a red cross at each fix), in OutputNames()'
  /// order.
  std::vector<LidarOutput> Outputs() const;
  static std::vector<LidarOutput> OutputNames();
  const LocalizationReport& report() const { return report_; }
  const LocalizationOptions& options() const { return options_; }
  const ProbabilityGrid& map() const { return *map_; }

 private:
  struct Candidate {
    long scan = 0;
    SE2d local;      ///< local SLAM's pose of the scan
    SE2d placement;  ///< local SLAM's frame in the map
  };
  /// A global search of a scan (robot-frame points); adds a candidate, and fixes where two agree.
  bool GlobalSearch(long scan, const SE2d& local, const std::vector<Eigen::Vector2d>& points, LocalizedScan* out);
  enum class Mode { kGlobal, kTracking, kDeadReckoning };
  /// Refines `predicted` against the map; whether it fits (out: the pose, score, outside).
  bool Fits(const SE2d& predicted, const std::vector<Eigen::Vector2d>& points, LocalizedScan* out) const;
  /// Tracking the map: the scan's predicted pose from the last one, by the odometry where the
  /// scan and the one before have it (*by_odometry), else PredictByScans.
  SE2d Predict(const LaserScan& scan, const std::vector<Eigen::Vector2d>& points, bool* by_odometry) const;
  /// The last pose moved by a scan-to-scan match of the scan before and this one.
  SE2d PredictByScans(const std::vector<Eigen::Vector2d>& points) const;
  /// Global localisation or dead reckoning: the scan through local SLAM.
  void AddByLocalSlam(const LaserScan& scan, LocalizedScan* out);
  void Lose();
  /// localization.png's bytes.
  std::string Picture() const;
  /// The scan's valid points, the robot's frame, through the matching voxel filter.
  std::vector<Eigen::Vector2d> MatchingPoints(const LaserScan& scan) const;

  LocalizationOptions options_;
  std::shared_ptr<const ProbabilityGrid> map_;
  std::unique_ptr<FastCorrelativeScanMatcher2D> matcher_;
  SE2d map_center_;  ///< the map's known area's centre
  double map_half_side_ = 0;
  std::unique_ptr<LocalSlam2D> local_;  ///< null while tracking the map
  std::vector<Candidate> candidates_;
  Mode mode_ = Mode::kGlobal;
  SE2d placement_;  ///< local SLAM's frame in the map (dead reckoning)
  long misses_ = 0;
  long streak_ = 0;  ///< scans in a row that fit (dead reckoning)
  // The last scan, for the next prediction while tracking the map.
  SE2d last_pose_, before_last_pose_;
  bool has_last_ = false, has_before_last_ = false;
  SE2d last_odometry_;
  bool last_has_odometry_ = false;
  std::vector<Eigen::Vector2d> last_points_;
  long since_global_ = 0;
  double first_stamp_ = 0;
  double last_stamp_ = 0;
  bool last_localized_ = false;
  LocalizationReport report_;
  std::vector<LocalizedScan> results_;
};

}  // namespace lidar
}  // namespace tether
