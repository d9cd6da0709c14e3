#pragma once
// Shared test helper: a 2D world of wall segments and laser scans ray-cast into it.
#include <Eigen/Core>
#include <cmath>
#include <vector>

#include "tether/core/se2.h"
#include "tether/frontends/simulation/lidar_world.h"

namespace tether {
namespace testing {

using Segment = lidar::WallSegment;

/// Adds the four walls of the rectangle [x0, x1] x [y0, y1].
inline void AddRectangle(double x0, double y0, double x1, double y1, std::vector<Segment>* s) {
  s->push_back({{x0, y0}, {x1, y0}});
  s->push_back({{x1, y0}, {x1, y1}});
  s->push_back({{x1, y1}, {x0, y1}});
  s->push_back({{x0, y1}, {x0, y0}});
}

/// The distance from `origin` along the unit direction `d` to the nearest segment (infinity
/// where none is hit): the simulator's ray caster.
using lidar::CastRay;

/// The room of the LiDAR pose-graph tests: 24 m x 18 m with five boxes.
inline std::vector<Segment> RoomWithBoxes() {
  std::vector<Segment> s;
  AddRectangle(0, 0, 24, 18, &s);
  AddRectangle(3, 3, 4, 5, &s);
  AddRectangle(19, 2, 21, 3, &s);
  AddRectangle(11, 8, 13, 10.5, &s);
  AddRectangle(5, 13, 8, 14, &s);
  AddRectangle(18, 14, 19, 16, &s);
  return s;
}

/// Ranges of `beams` beams from angle_min in steps of `increment` (the sensor's frame) seen
/// from `pose`; beams that hit nothing get +infinity.
inline std::vector<double> RayCastScan(const std::vector<Segment>& walls, const SE2d& pose, int beams, double angle_min,
                                       double increment) {
  std::vector<double> ranges;
  for (int i = 0; i < beams; ++i) {
    const double a = pose.theta() + angle_min + i * increment;
    ranges.push_back(CastRay(walls, pose.translation(), Eigen::Vector2d(std::cos(a), std::sin(a))));
  }
  return ranges;
}

/// The points (the sensor's frame) of a scan of `beams` beams over 360 degrees from -pi seen
/// from `pose`: the nearest wall of each beam closer than max_range.
inline std::vector<Eigen::Vector2d> ScanPoints(const std::vector<Segment>& walls, const SE2d& pose, int beams,
                                               double max_range) {
  std::vector<Eigen::Vector2d> points;
  const std::vector<double> ranges = RayCastScan(walls, pose, beams, -M_PI, 2 * M_PI / beams);
  for (int i = 0; i < beams; ++i) {
    const double a = -M_PI + 2 * M_PI * i / beams;
    const double r = ranges[static_cast<std::size_t>(i)];
    if (std::isfinite(r) && r < max_range) points.push_back(r * Eigen::Vector2d(std::cos(a), std::sin(a)));
  }
  return points;
}

}  // namespace testing
}  // namespace tether
