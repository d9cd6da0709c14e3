#pragma once
// Shared test helper: a 2D world of wall segments and laser scans ray-cast into it.
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <vector>

#include "tether/core/se2.h"
#include "tether/frontends/lidar/sensor/imu_yaw.h"
#include "tether/frontends/lidar/sensor/laser_scan.h"
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

/// A round room, 5 m across, walls of 180 sides: from its centre a scan looks the same at every
/// heading, so neither scan-to-scan matching nor a submap can see a turn.
inline std::vector<Segment> RoundRoom() {
  std::vector<Segment> walls;
  const int sides = 180;
  for (int i = 0; i < sides; ++i) {
    const double a = 2 * M_PI * i / sides, b = 2 * M_PI * (i + 1) / sides;
    walls.push_back({{2.5 * std::cos(a), 2.5 * std::sin(a)}, {2.5 * std::cos(b), 2.5 * std::sin(b)}});
  }
  return walls;
}

/// A robot at the round room's centre stands 1 s, turns 0.4 rad a scan (a fast turn at 10 Hz)
/// for 15 scans and stands again: 40 scans of 360 beams (6 m) from t = 20 s, each scan's true
/// heading, and a gyro at 200 Hz reading 0.01 rad/s high over the run.
struct RoundRoomTurn {
  std::vector<double> truth;
  std::vector<lidar::LaserScan> scans;
  std::vector<lidar::ImuSample> imu;
};

inline RoundRoomTurn TurnInARoundRoom() {
  const std::vector<Segment> room = RoundRoom();
  RoundRoomTurn turn;
  for (int k = 0; k < 40; ++k) {
    const double heading = 0.4 * std::clamp(k - 10, 0, 15);
    turn.truth.push_back(heading);
    lidar::LaserScan s;
    s.stamp = 20 + 0.1 * k;
    s.angle_min = -M_PI;
    s.angle_increment = 2 * M_PI / 360;
    s.range_min = 0.05;
    s.range_max = 6;
    for (double r : RayCastScan(room, SE2d(0, 0, heading), 360, s.angle_min, s.angle_increment)) {
      s.ranges.push_back(static_cast<float>(r));
    }
    turn.scans.push_back(std::move(s));
  }
  for (int k = 0; k <= 4 * 200; ++k) {
    const double t = 20 + 0.005 * k;
    const double rate = t > 21 + 1e-9 && t <= 22.5 + 1e-9 ? 4.0 : 0.0;  // 0.4 rad in 0.1 s
    turn.imu.push_back({t, rate + 0.01});
  }
  return turn;
}

}  // namespace testing
}  // namespace tether
