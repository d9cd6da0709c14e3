#pragma once
// The odometry front-end: controls in (v, w; or wheel speeds and encoder ticks converted by
// diff_drive.h), a pose graph out. Every `controls_per_pose` controls make a new pose: its
// initial value is the previous one composed with the accumulated motion, and a pose-pose
// factor (BetweenSE2) links the two with the accumulated relative pose as measurement and the
// inverse of its propagated covariance (plus the floor) as information. The pieces made since
// the last TakeNew go to the incremental smoother in one Update.
//
//   OdometryFrontEnd odo;                       // pose x0 at the origin
//   for (...) {
//     if (odo.Add(FromWheelSpeeds(vl, vr, 0.5), 0.1)) {
//       FactorGraph f;  Values v;
//       odo.TakeNew(&f, &v);
//       smoother.Update(std::move(f), std::move(v));
//     }
//   }
#include <vector>

#include "tether/core/factor_graph.h"
#include "tether/core/values.h"
#include "tether/frontends/odometry/diff_drive.h"

namespace tether {
namespace odometry {

struct OdometryFrontEndOptions {
  OdometryNoise noise;
  /// Controls accumulated into one pose-pose factor. Default 1 (a pose per control).
  int controls_per_pose = 1;
  /// Pose i is Symbol(letter, i). Default 'x'.
  char letter = 'x';
  /// The first pose's value; a prior holds it with prior_sigma (m, m, rad) unless that is 0.
  SE2d start;
  double prior_sigma = 1e-3;
};

class OdometryFrontEnd {
 public:
  /// Throws InvalidArgument for controls_per_pose < 1 or a negative or non-finite prior_sigma.
  explicit OdometryFrontEnd(const OdometryFrontEndOptions& options = {});
  /// Adds a control over dt seconds; true where it completed a new pose.
  bool Add(const Control& u, double dt);
  /// Adds a measured motion over dt seconds (MotionIntegrator::AddMotion); true where it
  /// completed a new pose.
  bool AddMotion(const SE2d& delta, double dt);
  /// Makes a pose of the steps added since the last one, fewer than controls_per_pose (the end
  /// of a track); true where there were any.
  bool Flush();
  /// Moves the factors and values made since the last call into `factors` and `values` (the
  /// first call also carries the start and its prior).
  void TakeNew(FactorGraph* factors, Values* values);
  /// Dead-reckoned value of every pose made so far (the start first).
  const std::vector<SE2d>& trajectory() const { return trajectory_; }
  Key PoseKey(int i) const;

 private:
  bool MaybeMakePose();  // a pose and its factor once controls_per_pose steps are in
  void MakePose();       // a pose and its factor of the steps since the last
  OdometryFrontEndOptions options_;
  MotionIntegrator integrator_;
  std::vector<SE2d> trajectory_;
  FactorGraph pending_factors_;
  Values pending_values_;
};

}  // namespace odometry
}  // namespace tether
