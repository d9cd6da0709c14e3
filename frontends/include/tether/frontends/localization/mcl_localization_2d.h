#pragma once
// Monte Carlo localisation of a whole log as one object, the front-end `tether mcl` and
// Python's `tether.localization.MclLocalization2D` drive: scans (with their odometry) in; the
// pose stream, a report and the files out.
//
//   auto map = std::make_shared<const OccupancyMap2D>(OccupancyMap2D::Read("map.yaml"));
//   MclLocalization2D run(map, options);   // MclRunOptions: the filter's options and the start
//   run.Run(log);                           // or AddScan(scan) one at a time
//   run.Trajectory(); run.report().Summary(); run.Outputs();
//
// The start is global (particles over the whole free space) unless an initial pose is given.
// The picture (mcl.png) is the map with the estimated path and the particle clouds of a few
// chosen scans; mcl_steps.csv holds, per scan, the estimate, its spread and what the filter
// did.
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "tether/frontends/lidar/io/lidar_log.h"
#include "tether/frontends/lidar/lidar_slam_2d.h"
#include "tether/frontends/localization/monte_carlo_localizer_2d.h"

namespace tether {
namespace localization {

struct MclRunOptions {
  MclOptions filter;
  /// Where the robot starts; without one, the start is global.
  bool has_initial_pose = false;
  SE2d initial_pose;
  /// The spread around the initial pose (standard deviations: m, m, rad).
  Eigen::Vector3d initial_sigma = Eigen::Vector3d(0.1, 0.1, 0.05);
  /// Scans from this time on (seconds after the log's first stamp); the earlier ones are skipped.
  double start_time = 0;
  /// The picture's particle clouds: at these scans (counted from 1 in the log), or where empty
  /// at `snapshots` scans spread over the run (the first update among them).
  std::vector<long> snapshot_scans;
  int snapshots = 4;
  /// False (and why) for invalid filter options, a non-finite initial pose or a sigma not
  /// positive, a negative or non-finite start time, a negative snapshot count or scan.
  bool IsValid(std::string* why) const;
};

struct MclRunReport {
  long scans = 0;    ///< scans given to the filter
  long skipped = 0;  ///< scans before start_time
  long updates = 0;  ///< scans the filter was updated with
  long injected = 0, redrawn = 0;
  double particle_beams = 0;  ///< particle x beam scores evaluated
  double logged_seconds = 0;  ///< the log's span from the first scan used to the last
  double total_seconds = 0;   ///< wall time of the filter's work
  double update_seconds = 0;  ///< of which weighting, resampling and estimating
  int final_particles = 0;
  /// The lines `tether mcl` prints.
  std::string Summary() const;
};

/// One row of mcl_steps.csv.
struct MclStepRecord {
  long scan = 0;  ///< counted from 1 in the log
  double stamp = 0;
  MclStep step;
};

/// A localisation's pose stream against a reference (the mapping run's trajectory, or the
/// truth), pose by pose where the stamps agree within `tolerance` seconds. The estimate and the
/// reference share the map's frame: no alignment. Both in the log's order: each pose meets the
/// next reference pose (after the last one matched) whose stamp agrees, so scans that share a
/// stamp meet their own.
struct LocalizationError {
  long matched = 0;               ///< poses with a reference
  double mean_error = 0;          ///< m, over every matched pose
  double max_error = 0;           ///< m
  double mean_heading_error = 0;  ///< rad
  /// The first matched pose from which on every error stays within `converged_*` (-1: never),
  /// its stamp, and the mean errors from there on.
  long converged_index = -1;
  double converged_stamp = 0;
  double mean_error_converged = 0;
  double mean_heading_error_converged = 0;
  /// A converged run that left the bound again is not converged: `converged_index` is the first
  /// pose of the last stretch within it, which runs to the end.
};
LocalizationError CompareWithReference(const std::vector<lidar::StampedPose2>& estimate,
                                       const std::vector<lidar::StampedPose2>& reference, double converged_metres = 0.5,
                                       double converged_radians = 10 * 3.14159265358979323846 / 180,
                                       double tolerance = 1e-3);

class MclLocalization2D {
 public:
  /// Throws InvalidArgument for invalid options (MclRunOptions::IsValid) or a map the filter
  /// refuses.
  MclLocalization2D(std::shared_ptr<const OccupancyMap2D> map, const MclRunOptions& options);

  /// The next scan (the log's `scan_number`-th, counted from 1, for the records). Throws
  /// InvalidArgument for a scan without odometry (localisation needs the robot's motion) or one
  /// lidar::ScanProblem refuses.
  const MclStep& AddScan(const lidar::LaserScan& scan, long scan_number);
  /// Every scan of the log from start_time on (at most `max_scans`, 0: all); an error on a scan
  /// is raised again as a ParseError naming its file:line (or bag message). `progress`, where
  /// given, is called every `progress_every` scans.
  void Run(const lidar::LidarLog& log, long max_scans = 0, long progress_every = 0,
           const std::function<void(long)>& progress = nullptr);

  /// The estimate at every scan given, with its stamp.
  std::vector<lidar::StampedPose2> Trajectory() const;
  const std::vector<MclStepRecord>& steps() const { return steps_; }
  const MonteCarloLocalizer2D& filter() const { return filter_; }
  MonteCarloLocalizer2D& filter() { return filter_; }
  const MclRunReport& report() const { return report_; }

  /// trajectory.tum, mcl_steps.csv and mcl.png, in OutputNames()' order.
  std::vector<lidar::LidarOutput> Outputs() const;
  static std::vector<lidar::LidarOutput> OutputNames();

 private:
  struct Snapshot {
    long scan = 0;
    std::vector<Particle> particles;
    SE2d estimate;
  };

  std::shared_ptr<const OccupancyMap2D> map_;
  MclRunOptions options_;
  MonteCarloLocalizer2D filter_;
  std::vector<MclStepRecord> steps_;
  std::vector<Snapshot> snapshots_;
  MclRunReport report_;
  bool started_ = false;
};

}  // namespace localization
}  // namespace tether
