#pragma once
// The sampled odometry motion model (Thrun, Burgard and Fox, "Probabilistic Robotics", 5.4):
// the odometry's motion between two steps, in the odometry's own frame, is split into a turn
// towards the direction of travel (rot1), a straight move (trans) and a second turn (rot2);
// each gets Gaussian noise of variance
//
//   rot1:  alpha1 rot1^2 + alpha2 trans^2
//   trans: alpha3 trans^2 + alpha4 (rot1^2 + rot2^2)
//   rot2:  alpha1 rot2^2 + alpha2 trans^2
//
// and the noisy motion is applied to a particle's pose. A robot that backs up (the odometry's
// move points behind it) turns by rot1 - pi and moves -trans, so a small reverse does not
// become two half turns; a move shorter than 1 mm has no direction and rot1 = 0.
#include <Eigen/Core>
#include <string>

#include "tether/core/se2.h"

namespace tether {

class RandomStream;

namespace localization {

/// The three parts of an odometry motion.
struct OdometryMotion {
  double rot1 = 0, trans = 0, rot2 = 0;
};

/// The motion from odometry pose `from` to `to`, split as above.
OdometryMotion DecomposeOdometry(const SE2d& from, const SE2d& to);

struct OdometryMotionModel {
  double alpha1 = 0.2;  ///< rotation noise from rotation
  double alpha2 = 0.2;  ///< rotation noise from translation
  double alpha3 = 0.2;  ///< translation noise from translation
  double alpha4 = 0.2;  ///< translation noise from rotation

  /// False (and why) for a negative or non-finite alpha.
  bool IsValid(std::string* why) const;
  /// The standard deviations of rot1, trans and rot2's noise for a motion.
  Eigen::Vector3d Sigmas(const OdometryMotion& m) const;
  /// `pose` moved by `m` with noise drawn from `random`.
  SE2d Sample(const SE2d& pose, const OdometryMotion& m, RandomStream* random) const;
};

}  // namespace localization
}  // namespace tether
