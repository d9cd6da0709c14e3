#pragma once
// The LiDAR front-end's pose graph (Hess et al. 2016, section V): a node per scan and per
// submap, fed to tether's incremental smoother while the scans stream in.
//
// - Local constraints: each scan to every submap it was inserted into, the relative pose local
//   SLAM gave it (submap local pose^-1 * scan local pose), BetweenSE2 with local_*_sigma.
// - Loop closures: the constraint builder (constraint_builder_2d.h) searches scans against
//   finished submaps and says which matches to add; each is added as a BetweenSE2 with a Huber
//   loss (loop_*_sigma, huber_delta) marked as a loop closure.
// - The smoother gets the new nodes and factors every update_every_n_scans scans; in between,
//   ScanPose gives a new scan's estimate as the last one's composed with local SLAM's motion.
// - The builder's searches run on `threads` background threads. Their results are taken at
//   fixed scan counts (every apply_every_n_scans scans, waiting for every search started before
//   that scan, and in that scan's smoother update) and at Finish(): the result does not depend
//   on the number of threads or their timing.
// - Trajectories (a kidnap: LidarSlam2D starts a new one): StartTrajectory() begins a new
//   trajectory whose first scan has no link to the scans before, and whose local poses and
//   submap indices start afresh (local SLAM is new). Its nodes and factors are held out of the
//   smoother, placed where its first scan continues from the last scan before it, until its
//   first loop closure to the joined map (the constraint builder's global search): then the
//   whole trajectory is moved rigidly to where that closure puts it and handed to the
//   smoother with the closures. A trajectory never joined is placed beside the map at
//   Finish() (to the right of it, 5 m apart), held there by a prior on its first scan.
// Keys: scan i is Symbol('s', i), submap j Symbol('m', j); a prior holds the first scan.
#include <Eigen/Core>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "tether/core/key.h"
#include "tether/core/se2.h"
#include "tether/frontends/lidar/io/lidar_state.h"
#include "tether/frontends/lidar/mapping/constraint_builder_2d.h"
#include "tether/frontends/lidar/mapping/submap_2d.h"
#include "tether/solvers/incremental_smoother.h"

namespace tether {
namespace lidar {

inline Key ScanKey(int i) { return Symbol('s', static_cast<std::uint64_t>(i)); }
inline Key SubmapKey(int j) { return Symbol('m', static_cast<std::uint64_t>(j)); }

/// The smoother settings of the pose graph. Its estimate between loop closures only places the
/// search windows, and Finish() solves to the batch optimum all the same, so it re-linearises
/// less than the smoother's defaults (a step beyond 0.05, no sigma rule, no extra rounds for
/// many small steps) and stops back substitution below 1e-6: the optimisation takes half the
/// time (Intel 19.9 s against 40 s) with the same maps within the run-to-run spread; iSAM2's
/// 0.1 and 1e-3 cut it to 11.8 s but moved fr079's closures enough to give 0.72 m against
/// 0.28 m (benchmarks/RESULTS.md, "LiDAR V").
inline SmootherOptions PoseGraphSmootherOptions() {
  SmootherOptions o;
  o.relinearize_threshold = 0.05;
  o.relinearize_sigmas = std::numeric_limits<double>::infinity();
  o.iterate_share = 1;
  o.wildfire_threshold = 1e-6;
  return o;
}

/// The graph's options, and the loop-closure search's (ConstraintBuilderOptions: search,
/// min_score, rival_*, the search distance and window growth, search_voxel_size,
/// search_every_n_scans, refine, confirm_*, threads).
struct PoseGraphOptions : ConstraintBuilderOptions {
  /// The local constraints' sigmas: looser than the loop closures', as measured on Intel
  /// (benchmarks/RESULTS.md, "LiDAR IV": 0.05 m / 0.02 rad gave 90.7% precision and 0.050 m,
  /// 0.1 m / 0.04 rad 94.0% and 0.043 m, 0.02 m / 0.01 rad 70.9% and 0.088 m).
  double local_translation_sigma = 0.1;  ///< m
  double local_rotation_sigma = 0.04;    ///< rad
  /// Consecutive scans are also tied to each other by local SLAM's relative pose between
  /// them, with these sigmas (both 0: no such constraint). Local SLAM's relative pose between
  /// neighbouring scans is far better than 0.1 m: tied, the loop closures cannot pull single
  /// scans out of line. 0.01 m / 0.002 rad against none, quadratic ties, every 10th scan searched
  /// (benchmarks/RESULTS.md, "LiDAR VII"): Intel 0.0355 -> 0.0282 m and 0.337 -> 0.289 deg,
  /// aces 0.0738 -> 0.0711 m and 0.490 -> 0.414 deg, fr079 0.0915 -> 0.0889 m and 0.869 ->
  /// 0.823 deg; the stiffer solution keeps fewer loop closures within 20 cm and 1 deg (89.4%,
  /// 50.0%, 84.5% against 91.8%, 63.0%, 86.9%).
  double consecutive_translation_sigma = 0.01;  ///< m
  double consecutive_rotation_sigma = 0.002;    ///< rad
  bool loop_closure = true;                     ///< ask the constraint builder for loop closures
  double loop_translation_sigma = 0.05;         ///< m
  double loop_rotation_sigma = 0.02;            ///< rad
  double huber_delta = 1;                       ///< on the whitened error's norm
  /// A Huber loss (this delta on the whitened error) on the local and consecutive ties too
  /// (0: none, quadratic): where local SLAM slipped, the closures that say so can pull the
  /// ties across the slip apart instead of losing against them. Every 10th scan searched
  /// (benchmarks/RESULTS.md, "LiDAR VII"), 0.25 against quadratic ties: Intel 0.0282 ->
  /// 0.0187 m, aces 0.0711 -> 0.0510 m, fr079 0.0889 -> 0.0341 m, precision 89.4 -> 95.5%,
  /// 50.0 -> 87.8%, 84.5 -> 98.9%. 0.1 tears Intel and aces (relation errors up to 5 m); without
  /// the consecutive ties 0.25 tears aces.
  double local_huber_delta = 0.25;
  /// The builder's closures are taken every apply_every_n_scans scans (and at Finish).
  int apply_every_n_scans = 30;
  /// The scans' nodes and ties reach the smoother together, every update_every_n_scans scans
  /// (at the scans whose index it divides, before their searches start), and with the loop
  /// closures applied at that scan; in between, a new scan's estimate is the last one's
  /// composed with local SLAM's motion. Every update re-solves the part of the graph the change
  /// touches, and that part holds the submaps' large separators. 10 against 1 (every 10th scan
  /// searched, benchmarks/RESULTS.md "LiDAR VIII"): Intel's optimisation 39.6 -> 20.5 s, the
  /// relation errors within the run-to-run spread (Intel 0.0187 -> 0.0185 m, aces 0.0510 ->
  /// 0.0506 m, fr079 0.0341 m both).
  int update_every_n_scans = 10;
  SmootherOptions smoother = PoseGraphSmootherOptions();
  /// The graph's rules and the builder's (ConstraintBuilderOptions::IsValid).
  bool IsValid(std::string* why) const;
};

/// The builder's counts and times (ConstraintBuilderStats), and the smoother's.
struct PoseGraphStats : ConstraintBuilderStats {
  double optimize_seconds = 0;  ///< the smoother's updates and Finish
  long updates = 0;             ///< smoother updates (before Finish)
  double finish_seconds = 0;    ///< Finish's solve
};

class PoseGraph2D {
 public:
  /// Throws InvalidArgument for invalid options.
  explicit PoseGraph2D(const PoseGraphOptions& options = {});
  PoseGraph2D(const PoseGraph2D&) = delete;
  PoseGraph2D& operator=(const PoseGraph2D&) = delete;

  /// The next scan (index = scans so far): its pose from local SLAM, its points (the robot's
  /// frame) and the submaps it was inserted into (index in the order of creation, and the
  /// submap, as ActiveSubmaps2D::InsertScan gives them). Submaps must come with increasing
  /// indices; a finished one stays finished. A scan in no submap (the motion filter left it
  /// out, or no points) is tied to the submaps the last scan with any went into, by the local
  /// poses (before any submap: to the previous scan). Throws InvalidArgument for a null submap
  /// or one that skips an index. Within a trajectory after the first, submap indices count
  /// from 0 again (the new local SLAM's) and local poses are in its frame.
  void AddScan(const SE2d& local_pose, std::vector<Eigen::Vector2d> points, const InsertedSubmaps& inserted_into);
  /// The scans added from now on form a new trajectory (see above). `finished`: the ending
  /// trajectory's submaps its local SLAM finished (LocalSlam2D::FinishTrajectory, indices as
  /// it numbers them), searched as any finished submap; one the graph never got is left out. No
  /// new trajectory where the current one has no scan yet. Throws InvalidArgument for a submap
  /// that is null or not finished.
  void StartTrajectory(const InsertedSubmaps& finished = {});
  /// Before any scan: a saved map (a session before this one, lidar_state.h) as trajectory 0,
  /// joined, at its saved poses: its scans and submaps (finished, not searched again), the
  /// constraints the run that saved it had (each scan to its submaps and to the scan before it
  /// in its own trajectory by the local poses, the loop closures; a prior on its first scan).
  /// The scans added next form a new trajectory, not joined, that the global search joins to it
  /// (multi-session mapping). Throws InvalidArgument after a scan was added or for a state with
  /// a Problem().
  void Restore(const LidarState& state);
  /// Waits for every search, applies the results and solves the graph to convergence.
  void Finish();

  int scan_count() const { return static_cast<int>(local_poses_.size()); }
  int trajectory_count() const { return static_cast<int>(trajectories_.size()); }
  /// Trajectory t's first scan and first submap (indices over all trajectories).
  int TrajectoryFirstScan(int t) const { return trajectories_.at(static_cast<std::size_t>(t)).first_scan; }
  int TrajectoryFirstSubmap(int t) const { return trajectories_.at(static_cast<std::size_t>(t)).first_submap; }
  /// The scans added when trajectory t was joined to the map (-1: not joined; 0 for the first).
  int TrajectoryJoinedAt(int t) const { return trajectories_.at(static_cast<std::size_t>(t)).joined_at; }
  /// The trajectory scan i belongs to.
  int ScanTrajectory(int i) const;
  int submap_count() const { return static_cast<int>(submaps_.size()); }
  /// Scan i's pose from local SLAM (its trajectory's local frame) and the submaps it is tied to.
  const SE2d& LocalPose(int i) const { return local_poses_.at(static_cast<std::size_t>(i)); }
  const std::vector<int>& ScanSubmaps(int i) const { return builder_.scan_submaps(i); }
  /// Submap j, and the trajectory it belongs to.
  const std::shared_ptr<const Submap2D>& submap(int j) const { return submaps_.at(static_cast<std::size_t>(j)); }
  int SubmapTrajectory(int j) const { return builder_.submap_trajectory(j); }
  /// The current estimates (global frame: the first scan's local pose).
  SE2d ScanPose(int i) const;
  SE2d SubmapPose(int j) const;
  const std::vector<LoopClosure>& loop_closures() const { return closures_; }
  /// The graph and its estimate with plain ids, as g2o tools expect them: scan i is i, submap
  /// j is scan_count() + j (the loop closures keep their Huber loss and mark).
  void Export(FactorGraph* graph, Values* values) const;
  const PoseGraphStats& stats() const { return stats_; }
  const IncrementalSmoother& smoother() const { return smoother_; }
  const ConstraintBuilder2D& constraint_builder() const { return builder_; }

 private:
  struct Trajectory {
    int first_scan = 0;
    int first_submap = 0;
    int joined_at = -1;
    FactorGraph held_graph;  ///< not joined yet: its factors and values, placed
    Values held_values;
  };
  /// A node's estimate: the smoother's, its initial value while it waits for an update, or
  /// its placement while its trajectory is held out.
  SE2d Pose(Key k) const;
  /// Moves trajectory t's held nodes by `correction` (applied on the left) and hands them and
  /// its factors to the next update.
  void Join(int t, const SE2d& correction);
  /// Places the trajectories never joined beside the map, each held by a prior.
  void PlaceUnjoined();
  /// Hands the waiting nodes and factors to the smoother.
  void Flush();
  /// Takes the builder's new loop closures into the waiting factors; true where there were any.
  bool TakeClosures();
  SE2d GlobalFromLocal() const;

  PoseGraphOptions options_;
  IncrementalSmoother smoother_;
  FactorGraph pending_graph_;  // waiting for the next update
  Values pending_values_;
  std::vector<SE2d> local_poses_;  ///< per scan: local SLAM's pose
  std::vector<std::shared_ptr<const Submap2D>> submaps_;
  std::vector<LoopClosure> closures_;
  std::vector<int> active_;  ///< the submaps the last scan given any went into
  std::vector<Trajectory> trajectories_{Trajectory{0, 0, 0, {}, {}}};
  PoseGraphStats stats_;
  ConstraintBuilder2D builder_;  // reads the estimates above (ScanPose, SubmapPose)
};

}  // namespace lidar
}  // namespace tether
