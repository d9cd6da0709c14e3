#pragma once
// The pose graph built from the same odometry and observations the filters read (the
// thesis's section 4.2): a prior on the known start, one pose-pose factor per control (its
// information the inverse of the control noise propagated through the motion model, odometry/
// diff_drive.h) and one range-bearing factor (factors/range_bearing.h) per observation taken
// for a landmark. A filter's run seeds it: its trajectory gives each new pose's initial value
// and its landmark estimates each new landmark's; the graph is fed to the incremental smoother
// step by step as the robot moves, then solved to the batch optimum (Finish).
//
// Keys: pose i is Symbol('x', i), landmark j (the filter's index) Symbol('l', j).
#include <Eigen/Core>
#include <vector>

#include "tether/core/factor_graph.h"
#include "tether/core/values.h"
#include "tether/frontends/ekf/landmark_filter.h"
#include "tether/frontends/ekf/landmark_simulator.h"
#include "tether/solvers/incremental_smoother.h"

namespace tether {
namespace ekf {

inline Key PoseKey(int i) { return Symbol('x', static_cast<std::uint64_t>(i)); }
inline Key LandmarkKey(int j) { return Symbol('l', static_cast<std::uint64_t>(j)); }

/// What a run over a world leaves: one pose per step (steps + 1, the start first), per step and
/// observation the landmark index it was taken for (-1: dropped), per landmark index the true id
/// it was created from (-1: none) and its estimate (the filter's at the end of the step that
/// created it, or what the track was built from).
struct Track {
  std::vector<SE2d> poses;
  std::vector<std::vector<int>> association;
  std::vector<int> creator_id;
  std::vector<Eigen::Vector2d> first_seen;    ///< initial values for the graph
  std::vector<Eigen::Vector2d> landmarks;     ///< final estimates
  std::vector<Eigen::Matrix2d> landmark_cov;  ///< final covariances, where the track has them
  std::vector<Eigen::Matrix3d> pose_cov;      ///< per step, where the track has them
  int wrong_associations = 0;
  int dropped_observations = 0;
};

/// Runs the filter over the world (predict with each control, update with the step's
/// observations) and records its track.
Track RunFilter(LandmarkFilter* filter, const LandmarkWorld& world);
/// The truth, with the known association (landmarks indexed in the order they are first seen).
Track TruthTrack(const LandmarkWorld& world);
/// Dead reckoning, with the known association; each landmark at the mean of its observations
/// placed from the dead-reckoned poses.
Track DeadReckoningTrack(const LandmarkWorld& world);

struct LandmarkGraphOptions {
  odometry::OdometryNoise odometry;  ///< the control noise the pose-pose factors come from
  Eigen::Matrix2d measurement_cov = FilterOptions().measurement_cov;
  double prior_sigma = 1e-3;  ///< the prior on the start (m, m, rad)
  SmootherOptions smoother;
  /// SmoothLandmarkRun: after every step also record the smoother's estimate of the newest
  /// pose and its marginal covariance (what the graph knows of the robot at that moment, to
  /// compare with a filter's). Costs one marginal per step; off by default.
  bool record_online = false;
};

/// The whole graph (batch): the factors, in the order the smoother receives them.
FactorGraph BuildLandmarkGraph(const LandmarkWorld& world, const std::vector<std::vector<int>>& association,
                               const LandmarkGraphOptions& options = {});
/// The seed's values for every pose and every landmark some observation is taken for.
Values SeedValues(const Track& seed);

struct SmoothedTrack {
  Track track;                ///< the optimum: poses and landmarks (association and ids of the seed)
  double chi2 = 0;            ///< at the optimum
  double online_seconds = 0;  ///< the step-by-step updates
  double finish_seconds = 0;  ///< Finish()
  int updates = 0;
  SolverSummary finish;
  /// With record_online, per pose i (the start first): the smoother's estimate of pose i right
  /// after the update that added it, and its marginal covariance there, in the SE2 tangent of
  /// that estimate (the error of the truth is online_poses[i].Local(truth[i])); the start's is
  /// its prior's. Empty otherwise.
  std::vector<SE2d> online_poses;
  std::vector<Eigen::Matrix3d> online_pose_cov;
};

/// Feeds the graph to the incremental smoother step by step (step k adds pose k + 1 with the
/// seed's value, its odometry factor, the step's observation factors and the landmarks first
/// seen there), then calls Finish(). Throws what the smoother throws.
/// With options.record_online, also the online estimate of each new pose (SmoothedTrack).
SmoothedTrack SmoothLandmarkRun(const LandmarkWorld& world, const Track& seed,
                                const LandmarkGraphOptions& options = {});

/// Position RMSE of a trajectory against the truth (same frame: the start is known).
double TrajectoryRmse(const std::vector<SE2d>& poses, const std::vector<SE2d>& truth);
/// RMSE of the landmarks against the true ones they were created from (landmarks without a true
/// id left out); NaN where there is none.
double LandmarkRmse(const Track& track, const std::vector<Eigen::Vector2d>& truth);

}  // namespace ekf
}  // namespace tether
