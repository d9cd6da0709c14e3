#pragma once
// A robot driving with constant commands among point landmarks, observed by range and bearing:
// the set-up of the filter experiment (`tether ekf-demo`). Defaults: 200 steps of dt = 1 s at
// v = 1 m/s, w = pi/10 rad/s (a circle of radius v/w = 3.18 m, driven ten times), 20 landmarks
// drawn uniformly in a 20 m square centred on the circle, observed within 10 m, control noise
// std (0.1 m/s, pi/18 rad/s), measurement noise std (2 m, pi/18 rad).
//
// The truth moves with the commands; the odometry the filters read is the command plus control
// noise; each observation is the true range and bearing plus measurement noise (a range below
// 0.1 m is kept at 0.1 m). One seed gives one world, bit for bit (std::mt19937_64 and a
// hand-written Box-Muller, so the numbers do not depend on the standard library).
#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "tether/frontends/ekf/range_bearing_model.h"
#include "tether/frontends/odometry/diff_drive.h"

namespace tether {
namespace ekf {

struct LandmarkWorldOptions {
  int steps = 200;
  double dt = 1;
  odometry::Control command{1.0, 0.3141592653589793};
  int landmarks = 20;
  double map_size = 20;   ///< side of the square the landmarks are drawn in [m]
  double max_range = 10;  ///< landmarks farther than this are not observed [m]
  Eigen::Vector2d control_sigma{0.1, 0.17453292519943295};
  Eigen::Vector2d measurement_sigma{2.0, 0.17453292519943295};
  std::uint64_t seed = 1;
  bool IsValid(std::string* why) const;
};

struct LandmarkWorld {
  double dt = 1;
  std::vector<SE2d> truth;                  ///< steps + 1 poses, truth[0] the start
  std::vector<Eigen::Vector2d> landmarks;   ///< true positions; an observation's id indexes them
  std::vector<odometry::Control> odometry;  ///< steps controls as measured (command + noise)
  /// observations[k]: what is seen at truth[k + 1], after the k-th control.
  std::vector<std::vector<Observation>> observations;
};

/// Throws InvalidArgument (with IsValid's reason) for invalid options.
LandmarkWorld SimulateLandmarkWorld(const LandmarkWorldOptions& options);

/// Dead reckoning: the start composed with the measured controls (steps + 1 poses).
std::vector<SE2d> DeadReckoning(const LandmarkWorld& world);

}  // namespace ekf
}  // namespace tether
