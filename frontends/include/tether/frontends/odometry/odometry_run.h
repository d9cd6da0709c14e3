#pragma once
// A whole odometry track through the odometry front-end: the library's loop behind
// `tether odometry` and Python's `odometry.run_track`.
//
// A wheeled robot's odometry comes as a track of stamped poses (CARMEN ODOM lines, a bag's
// nav_msgs/Odometry). Each step between two poses goes through OdometryFrontEnd::AddMotion as
// the motion measured (composed exactly) with the covariance of the arc's control that makes
// it (ControlBetween, diff_drive.h): a pose every `controls_per_pose` steps, a BetweenSE2 with
// the propagated covariance between consecutive poses, a prior on the first. The result is the
// pose graph a smoother or `tether optimize` takes; its poses are the track's.
//
//   OdometryRunResult r = RunOdometry(stamps, poses, OdometryFrontEndOptions{});
//   WriteG2o(file, r.values, r.graph, DefaultRegistry());
#include <string>
#include <vector>

#include "tether/core/factor_graph.h"
#include "tether/core/se2.h"
#include "tether/core/values.h"
#include "tether/frontends/odometry/odometry_front_end.h"

namespace tether {
namespace odometry {

/// What a run did.
struct OdometryReport {
  int messages = 0;     ///< poses in the track
  int steps = 0;        ///< controls given to the front-end
  int merged = 0;       ///< poses whose stamp did not advance, merged into the next step
  int sideways = 0;     ///< steps with a sideways part over 1 cm (dropped by ControlBetween)
  int poses = 0;        ///< poses in the graph (the start included)
  double distance = 0;  ///< metres driven (the arcs' lengths)
  double turned = 0;    ///< radians turned (sum of |dtheta|)
  double duration = 0;  ///< seconds from the first stamp to the last
  /// One paragraph for people: the counts, the distance, the time.
  std::string Summary() const;
};

struct OdometryRunResult {
  FactorGraph graph;             ///< the prior, then a BetweenSE2 per pose
  Values values;                 ///< the dead-reckoned poses (the initial guess)
  std::vector<double> stamps;    ///< the stamp of each pose in `values`, in key order
  std::vector<SE2d> trajectory;  ///< the same poses, in order
  OdometryReport report;
};

/// Runs the track (`stamps[i]` the time of `poses[i]`, not decreasing) through the front-end.
/// The first pose is the start (options.start is replaced by it); the steps after the last full
/// `controls_per_pose` make one more pose, so the graph ends at the track's last pose. Throws InvalidArgument for
/// invalid options, sizes that differ, fewer than two poses, a stamp that goes back or a pose
/// or stamp that is not finite, naming the index.
OdometryRunResult RunOdometry(const std::vector<double>& stamps, const std::vector<SE2d>& poses,
                              OdometryFrontEndOptions options);

}  // namespace odometry
}  // namespace tether
