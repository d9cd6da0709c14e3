#pragma once
// Grid-based Rao-Blackwellised particle filter SLAM (Grisetti, Stachniss and Burgard 2007, the
// method of GMapping): each particle carries a trajectory and its own occupancy grid, the
// pose drawn from an improved proposal that includes the current scan. Odometry moves the
// particles; a log without it is moved by scan-to-scan matching.
//
//   tether::lidar::RbpfSlam2D slam(options);     // RbpfSlamOptions: documented defaults
//   for (const tether::lidar::LaserScan& s : log.scans) slam.AddScan(s);
//   slam.Trajectory(); slam.map(); slam.report();
//
// A scan is processed where the odometry moved linear_update or turned angular_update since
// the last processed one (the first scan always); every scan gets a pose (the last processed
// one's, moved by the odometry since). For each processed scan, each particle:
// 1. samples its motion from the odometry's (the sampled odometry model of
//    localization/motion_model.h);
// 2. matches the scan against its own map from there (the real-time correlative search, then
//    the nonlinear refinement: the matchers of scan_matching/, on a window of the particle's
//    map copied into a dense grid);
// 3. evaluates the scan's likelihood at the 27 poses one step around the match (or around the
//    sampled motion where the map there is too little known), times the motion model's
//    density there; their weighted mean and covariance are the proposal, their sum eta the
//    particle's weight factor (the improved proposal's weight);
// 4. draws its pose from that Gaussian and inserts the scan into its map there.
// The scan's likelihood at a pose: likelihood_points * the mean over its points of
// log P(cell), P the cell's occupancy probability (unknown: 0.5) — the points counted as
// likelihood_points independent beams, whatever the scanner's count, as GMapping's gain does.
// Resampling is selective: low-variance where the effective sample size falls below
// resample_fraction * particles.
//
// Maps are TiledProbabilityGrid: a resampled particle shares its parent's tiles until it
// inserts a scan, which copies the tiles that scan touches; trajectories are linked lists of
// nodes shared the same way. Memory grows with what the particles' maps do not share, not with
// particles x map.
//
// Deterministic for a seed, whatever the thread count: each particle draws from its own stream.
#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "tether/core/se2.h"
#include "tether/factors/probability_grid.h"
#include "tether/frontends/lidar/io/lidar_log.h"
#include "tether/frontends/lidar/lidar_slam_2d.h"
#include "tether/frontends/lidar/mapping/probability_grid_inserter.h"
#include "tether/frontends/lidar/mapping/tiled_probability_grid.h"
#include "tether/frontends/lidar/scan_matching/real_time_correlative_scan_matcher_2d.h"
#include "tether/frontends/lidar/scan_matching/scan_refiner_2d.h"
#include "tether/frontends/lidar/scan_matching/scan_to_scan_2d.h"
#include "tether/frontends/lidar/sensor/laser_scan.h"
#include "tether/frontends/lidar/sensor/odometry_track.h"
#include "tether/frontends/localization/motion_model.h"

namespace tether {
namespace lidar {

struct RbpfSlamOptions {
  int particles = 30;
  double resolution = 0.05;  ///< m, the particles' grids
  /// Range limits put on every scan (0: the scan's own), and the longest return used for
  /// matching and the maps (m; GMapping's maxUrange).
  RangeLimits limits;
  double max_range = 30;
  double matching_voxel_size = 0.05;  ///< m: the points matched and weighed (0: all)
  /// A scan is processed after this much motion by the odometry since the last processed one
  /// (GMapping's linearUpdate, angularUpdate). 0.1 m / 0.05 rad against 0.5 m / 0.25 rad on aces's
  /// first 3000 scans: relation error 0.047 m / 0.67 deg against 0.069 m / 2.07 deg, at three
  /// times the time (benchmarks/RESULTS.md, "Grid RBPF").
  double linear_update = 0.1;    ///< m
  double angular_update = 0.05;  ///< rad
  /// The odometry's noise (variances: rot1 alpha1 rot1^2 + alpha2 trans^2, ...; motion_model.h):
  /// 0.02 gives 0.14 rad per m of travel and 0.14 m per m. 0.1 (0.32 rad per m) spread the
  /// samples past the matcher's window (aces's first 2000 scans: 0.0411 m against 0.0388 m).
  localization::OdometryMotionModel motion{0.02, 0.02, 0.02, 0.02};
  CorrelativeMatcherOptions correlative = DefaultCorrelative();
  ScanRefinerOptions refiner;
  /// A particle's map must know this share of the cells its scan's points fall in (at the
  /// sampled motion) to be matched against; else the proposal is taken around the motion.
  /// Unknown cells are neutral in the match, so a little overlap is enough: a lap of a room
  /// whose 180-degree scans look at what was behind them (tests/python/test_lidar.py), 6
  /// particles: 3.0 m off at the end with 0.1, 5.4 m with 0.3; 30 particles: 0.022 and 0.050 m.
  double min_known_fraction = 0.1;
  /// The proposal's 27 poses: the match +- these steps (m, rad). Half a cell and 0.005 rad
  /// against a cell and 0.01 rad: 0.043 m / 0.62 deg against 0.047 m / 0.67 deg (aces, above).
  double proposal_step = 0.025;
  double proposal_angle = 0.005;
  /// The points counted as this many independent beams in the likelihood (above). 10 against
  /// 30 (benchmarks/RESULTS.md, "Grid RBPF"): aces 0.062 m against 0.300 m (with 30 the weights
  /// are so peaked that the set resamples at a third of the scans, and no particle is left to
  /// close its 175 m loop), Intel 0.055 m against 0.046 m.
  double likelihood_points = 10;
  double resample_fraction = 0.5;
  GridInsertOptions insert;
  /// A log without odometry: the motion between scans by scan-to-scan matching.
  ScanToScanOptions scan_to_scan;
  /// With odometry: the motion between two processed scans is also matched scan to scan, from
  /// the odometry's motion and from standing still; where both matches reach the same motion
  /// (within 2 cm and 0.01 rad: the scans saw it) and it differs from the odometry's by more
  /// than these (m, rad), it is the motion. (One match, or the better of the two, overruled
  /// aces's odometry 489 times along its corridors and broke the map: 2.10 m.) The particles move by the odometry's
  /// samples within the matcher's window, and an odometry that is wrong for a stretch (fr079's
  /// door: forwards where the robot backs out, 4-5 m in all) takes them all out of it. 0: off.
  double odometry_check_translation = 0.05;
  double odometry_check_rotation = 0.05;
  std::uint64_t seed = 1;
  int threads = 0;  ///< 0: every core
  bool IsValid(std::string* why) const;

  static CorrelativeMatcherOptions DefaultCorrelative() {
    CorrelativeMatcherOptions c;
    c.linear_search_window = 0.2;
    c.angular_search_window = 0.1;
    return c;
  }
};

struct RbpfSlamReport {
  long scans = 0;
  long processed = 0;  ///< scans the particles processed (the motion rule)
  long matched = 0;    ///< particle-scans matched against the particle's map
  long resamplings = 0;
  long scan_to_scan = 0;           ///< scans without odometry moved by scan-to-scan matching
  long odometry_overruled = 0;     ///< processed scans whose odometry the scan-to-scan match overruled
  double min_effective = 0;        ///< the lowest effective sample size before a resampling
  std::size_t distinct_tiles = 0;  ///< tiles held by the particles' maps, each counted once
  std::size_t tile_bytes = 0;      ///< their memory
  double seconds = 0;
  double logged_seconds = 0;
  std::string Summary() const;
};

class RbpfSlam2D {
 public:
  /// Throws InvalidArgument naming the option for invalid options.
  explicit RbpfSlam2D(const RbpfSlamOptions& options = {});

  /// The next scan (time order). A log without odometry (every scan OdometryOrigin::kNone) is
  /// moved by scan-to-scan matching (scan_to_scan_2d.h: MatchMovingOrStill) instead. Throws
  /// InvalidArgument for a scan ScanProblem refuses, or one with odometry after scans without
  /// (or the other way); nothing changes then.
  void AddScan(const LaserScan& scan);

  /// Adds the first `max_scans` scans of a log (0: all). An error adding a scan is raised again
  /// as a ParseError naming the scan's file:line (or bag message).
  void Run(const LidarLog& log, long max_scans = 0);

  /// The files a run writes (trajectory.tum, map.pgm, map.yaml, map.png: the heaviest
  /// particle's, as `tether lidar` writes them), names only, and with their bytes.
  static std::vector<LidarOutput> OutputNames();
  std::vector<LidarOutput> Outputs() const;

  int particle_count() const { return static_cast<int>(particles_.size()); }
  std::vector<double> weights() const;
  int best_particle() const;
  /// Particle i's current pose (the last processed scan's).
  SE2d particle_pose(int i) const { return particles_.at(static_cast<std::size_t>(i)).pose; }
  /// Every scan's pose along particle i's trajectory (-1: the heaviest), with its stamp. Throws
  /// InvalidArgument for a particle that is not there (as Map does).
  std::vector<StampedPose2> Trajectory(int particle = -1) const;
  /// Particle i's map (-1: the heaviest) as a dense grid.
  ProbabilityGrid Map(int particle = -1) const;
  const TiledProbabilityGrid& particle_map(int i) const { return particles_.at(static_cast<std::size_t>(i)).map; }
  const RbpfSlamReport& report() const;
  const RbpfSlamOptions& options() const { return options_; }

 private:
  struct Node {  // a processed scan on one particle's trajectory
    SE2d pose;
    long scan = 0;
    std::shared_ptr<const Node> parent;
  };
  struct Particle {
    SE2d pose;
    double log_weight = 0;
    TiledProbabilityGrid map;
    std::shared_ptr<const Node> path;
  };
  void Process(long scan, const SE2d& odometry, const LaserScan& s);
  void Step(Particle* p, const localization::OdometryMotion& motion, const SE2d& laser,
            const std::vector<Eigen::Vector2d>& points, const std::vector<Eigen::Vector2d>& matching, long scan,
            std::uint64_t stream, bool* matched) const;
  void MaybeResample();
  /// -1 (or any negative): the heaviest; otherwise checked (InvalidArgument naming it).
  int ParticleIndex(int particle) const;

  RbpfSlamOptions options_;
  ProbabilityGridInserter inserter_;
  std::vector<Particle> particles_;
  std::vector<double> stamps_;          // per scan
  std::vector<long> processed_before_;  // per scan: the last processed scan at or before it
  std::vector<SE2d> since_processed_;   // per scan: the odometry's motion since that scan
  SE2d last_odometry_;                  // the last processed scan's
  bool scan_only_ = false;              // the log has no odometry
  SE2d scan_odometry_, last_motion_;    // scan-only: the chained matches, the last one
  std::vector<Eigen::Vector2d> previous_points_;
  std::vector<Eigen::Vector2d> processed_points_;  // the last processed scan's (robot frame)
  bool started_ = false;
  std::uint64_t steps_ = 0;
  mutable RbpfSlamReport report_;
};

}  // namespace lidar
}  // namespace tether
