#include "tether/frontends/lidar/sensor/odometry_track.h"

#include <algorithm>
#include <cmath>

namespace tether {
namespace lidar {

void OdometryTrack::Add(double stamp, const SE2<double>& pose) {
  if (!poses_.empty() && stamp < poses_.back().stamp) sorted_ = false;
  poses_.push_back({stamp, pose});
}

const std::vector<StampedPose2>& OdometryTrack::Sorted() const {
  if (!sorted_) {
    std::stable_sort(poses_.begin(), poses_.end(),
                     [](const StampedPose2& a, const StampedPose2& b) { return a.stamp < b.stamp; });
    sorted_ = true;
  }
  return poses_;
}

OdometryOrigin OdometryTrack::At(double stamp, SE2<double>* pose) const {
  const std::vector<StampedPose2>& p = Sorted();
  if (p.empty()) {
    *pose = SE2<double>();
    return OdometryOrigin::kNone;
  }
  if (stamp < p.front().stamp) {
    *pose = p.front().pose;
    return OdometryOrigin::kClamped;
  }
  if (stamp > p.back().stamp) {
    *pose = p.back().pose;
    return OdometryOrigin::kClamped;
  }
  // The first pose not before `stamp`; an exact stamp gives that pose.
  const auto it =
      std::lower_bound(p.begin(), p.end(), stamp, [](const StampedPose2& a, double t) { return a.stamp < t; });
  if (it->stamp == stamp || it == p.begin()) {
    *pose = it->pose;
    return OdometryOrigin::kInterpolated;
  }
  const StampedPose2& a = *(it - 1);
  const StampedPose2& b = *it;
  const double u = (stamp - a.stamp) / (b.stamp - a.stamp);
  const double dtheta = WrapAngle(b.pose.theta() - a.pose.theta());
  *pose = SE2<double>(a.pose.x() + u * (b.pose.x() - a.pose.x()), a.pose.y() + u * (b.pose.y() - a.pose.y()),
                      a.pose.theta() + u * dtheta);
  return OdometryOrigin::kInterpolated;
}

}  // namespace lidar
}  // namespace tether
