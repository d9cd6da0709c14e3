// EstimateLaserOffset: the laser's place on the robot from the log's turns in place.
#include "tether/frontends/lidar/io/laser_offset.h"

#include <gtest/gtest.h>

#include <cmath>

#include "testing/synthetic_room.h"
#include "tether/core/error.h"

namespace tether {
namespace lidar {
namespace {

// A robot that drives 1 m, turns 1.2 rad in place in 0.1 rad steps, and again, in a room with
// boxes; the laser at `laser` on it, the odometry the truth.
LidarLog TurningLog(const SE2d& laser) {
  std::vector<testing::Segment> world;
  testing::AddRectangle(0, 0, 16, 12, &world);
  testing::AddRectangle(3, 3, 4, 5, &world);
  testing::AddRectangle(10, 7, 12, 8.5, &world);
  LidarLog log;
  SE2d robot(6, 5, 0);
  for (int k = 0; k < 120; ++k) {
    robot = robot * (k % 20 < 8 ? SE2d(0.125, 0, 0) : SE2d(0, 0, 0.1));
    LaserScan s;
    s.stamp = 0.1 * k;
    s.angle_min = -M_PI / 2;
    s.angle_increment = M_PI / 359;
    s.range_max = 30;
    for (double r : testing::RayCastScan(world, robot * laser, 360, s.angle_min, s.angle_increment)) {
      s.ranges.push_back(static_cast<float>(std::isfinite(r) ? r : 30.0));
    }
    s.odometry = robot;
    s.odometry_origin = OdometryOrigin::kScanLine;
    log.scans.push_back(std::move(s));
  }
  return log;
}

TEST(LaserOffsetTest, TurnsInPlaceGiveTheLasersPlace) {
  LidarLog log = TurningLog(SE2d(0.2, 0.05, 0));
  // The log says the laser is at the centre: the estimate says where it is.
  const LaserOffsetEstimate e = EstimateLaserOffset(log);
  ASSERT_GE(e.turns, 5);
  EXPECT_NEAR(e.x, 0.2, 0.01);
  EXPECT_NEAR(e.y, 0.05, 0.01);
  EXPECT_LT(e.rms, 0.005);
  EXPECT_GT(e.rms_at_log, 0.05);
  // With the log's mounting right, the residual at the log's is the estimate's.
  for (LaserScan& s : log.scans) s.laser_in_robot = SE2d(0.2, 0.05, 0);
  const LaserOffsetEstimate right = EstimateLaserOffset(log);
  EXPECT_LT(right.rms_at_log, 0.005);
}

TEST(LaserOffsetTest, NoTurnsNoEstimateAndBadOptions) {
  LidarLog log = TurningLog(SE2d());
  for (LaserScan& s : log.scans) s.odometry_origin = OdometryOrigin::kNone;
  EXPECT_EQ(EstimateLaserOffset(log).turns, 0);
  LaserOffsetOptions bad;
  bad.min_turn = 0;
  EXPECT_THROW(EstimateLaserOffset(log, bad), InvalidArgument);
}

}  // namespace
}  // namespace lidar
}  // namespace tether
