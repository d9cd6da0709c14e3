#include "tether/frontends/localization/motion_model.h"

#include <cmath>

#include "tether/frontends/simulation/random_stream.h"

namespace tether {
namespace localization {

namespace {
constexpr double kPi = 3.14159265358979323846;
double Wrap(double a) { return std::remainder(a, 2 * kPi); }
}  // namespace

OdometryMotion DecomposeOdometry(const SE2d& from, const SE2d& to) {
  OdometryMotion m;
  const Eigen::Vector2d d = to.translation() - from.translation();
  m.trans = d.norm();
  const double turn = Wrap(to.theta() - from.theta());
  if (m.trans < 1e-3) {
    m.rot1 = 0;
  } else {
    m.rot1 = Wrap(std::atan2(d.y(), d.x()) - from.theta());
    if (std::abs(m.rot1) > kPi / 2) {  // backing up: turn the other way and move backwards
      m.rot1 = Wrap(m.rot1 - kPi);
      m.trans = -m.trans;
    }
  }
  m.rot2 = Wrap(turn - m.rot1);
  return m;
}

bool OdometryMotionModel::IsValid(std::string* why) const {
  for (const double a : {alpha1, alpha2, alpha3, alpha4}) {
    if (!(a >= 0) || !std::isfinite(a)) {
      if (why) *why = "the motion model's alphas must be 0 or more and finite";
      return false;
    }
  }
  return true;
}

Eigen::Vector3d OdometryMotionModel::Sigmas(const OdometryMotion& m) const {
  const double r1 = m.rot1 * m.rot1, t = m.trans * m.trans, r2 = m.rot2 * m.rot2;
  return Eigen::Vector3d(std::sqrt(alpha1 * r1 + alpha2 * t), std::sqrt(alpha3 * t + alpha4 * (r1 + r2)),
                         std::sqrt(alpha1 * r2 + alpha2 * t));
}

SE2d OdometryMotionModel::Sample(const SE2d& pose, const OdometryMotion& m, RandomStream* random) const {
  const Eigen::Vector3d s = Sigmas(m);
  const double rot1 = m.rot1 + s[0] * random->Normal();
  const double trans = m.trans + s[1] * random->Normal();
  const double rot2 = m.rot2 + s[2] * random->Normal();
  const double heading = pose.theta() + rot1;
  return SE2d(pose.x() + trans * std::cos(heading), pose.y() + trans * std::sin(heading), Wrap(heading + rot2));
}

}  // namespace localization
}  // namespace tether
