#pragma once
// Time-stamped odometry poses (CARMEN ODOM lines, nav_msgs/Odometry messages) and the pose at
// any time between them.
#include <vector>

#include "tether/core/se2.h"
#include "tether/frontends/lidar/sensor/laser_scan.h"

namespace tether {
namespace lidar {

struct StampedPose2 {
  double stamp = 0;
  SE2<double> pose;
};

class OdometryTrack {
 public:
  /// Adds a pose; any order (logs are not always sorted by time).
  void Add(double stamp, const SE2<double>& pose);
  std::size_t size() const { return poses_.size(); }
  bool empty() const { return poses_.empty(); }
  /// The poses sorted by time (stable: equal stamps keep their order of arrival). Sorts on the
  /// first call after an Add (so two threads must not make that call at once; a log's track
  /// comes sorted from the readers).
  const std::vector<StampedPose2>& Sorted() const;

  /// The pose at `stamp`: linear in x, y and in the shortest-way angle between the two poses
  /// around it (kInterpolated; an exact stamp gives that pose), or the first / last pose where
  /// `stamp` lies outside (kClamped). kNone (and the identity) where the track is empty.
  OdometryOrigin At(double stamp, SE2<double>* pose) const;

 private:
  mutable std::vector<StampedPose2> poses_;
  mutable bool sorted_ = true;
};

}  // namespace lidar
}  // namespace tether
