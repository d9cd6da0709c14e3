// Scans to points with range limits, the voxel filter and odometry interpolation.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "testing/lidar_files.h"
#include "tether/core/error.h"
#include "tether/frontends/lidar/io/lidar_log.h"
#include "tether/frontends/lidar/sensor/laser_scan.h"
#include "tether/frontends/lidar/sensor/odometry_track.h"
#include "tether/frontends/lidar/sensor/voxel_filter.h"

namespace tether {
namespace lidar {
namespace {

LaserScan FourBeams() {
  LaserScan s;
  s.angle_min = -M_PI / 2;
  s.angle_increment = M_PI / 2;
  s.range_min = 0.5;
  s.range_max = 10;
  s.ranges = {2.0f, 0.25f, std::numeric_limits<float>::quiet_NaN(), 10.0f, 3.0f};
  return s;
}

TEST(ScanToPoints, DropsInvalidBeamsAndKeepsAngles) {
  const LaserScan s = FourBeams();
  EXPECT_EQ(s.ValidCount(), 2u);
  EXPECT_FALSE(s.Valid(1));  // below range_min
  EXPECT_FALSE(s.Valid(2));  // NaN
  EXPECT_FALSE(s.Valid(3));  // at range_max: no return
  EXPECT_FALSE(s.Valid(7));  // no such beam
  const std::vector<Eigen::Vector2d> p = ScanToPoints(s);
  ASSERT_EQ(p.size(), 2u);
  EXPECT_NEAR(p[0].x(), 0, 1e-12);
  EXPECT_NEAR(p[0].y(), -2, 1e-12);
  EXPECT_NEAR(p[1].x(), 0, 1e-12);  // beam 4 at angle 3 pi / 2
  EXPECT_NEAR(p[1].y(), -3, 1e-12);
  RangeLimits tight;
  tight.max_range = 2.5;
  ASSERT_EQ(ScanToPoints(s, tight).size(), 1u);
  tight = {};
  tight.min_range = 2.5;
  EXPECT_EQ(ScanToPoints(s, tight).size(), 1u);
  tight.min_range = 0.1;  // looser than the scan's own: the scan's limit holds
  EXPECT_EQ(ScanToPoints(s, tight).size(), 2u);
}

TEST(ScanToPoints, AZeroRangeIsNoReturnEvenWithoutAMinimum) {
  // Low-cost scanners write 0 where a beam saw nothing; a point at the laser would be a hit
  // inserted where the robot stands.
  LaserScan s = FourBeams();
  s.range_min = 0;
  s.ranges = {0.0f, 1.5f, -0.0f, 2.0f};
  EXPECT_FALSE(s.Valid(0));
  EXPECT_TRUE(s.Valid(1));
  EXPECT_FALSE(s.Valid(2));
  EXPECT_EQ(ScanToPoints(s).size(), 2u);
}

TEST(VoxelFilter, OneCentroidPerCellInFirstSeenOrder) {
  const std::vector<Eigen::Vector2d> points = {{0.1, 0.1}, {0.3, 0.3},  {-0.1, 0.1}, {0.45, 0.2},
                                               {5.0, 5.0}, {-0.2, 0.3}, {NAN, 0}};
  const std::vector<Eigen::Vector2d> f = VoxelFilter(points, 0.5);
  ASSERT_EQ(f.size(), 3u);
  EXPECT_NEAR(f[0].x(), (0.1 + 0.3 + 0.45) / 3, 1e-12);
  EXPECT_NEAR(f[0].y(), (0.1 + 0.3 + 0.2) / 3, 1e-12);
  EXPECT_NEAR(f[1].x(), -0.15, 1e-12);  // the cell left of the origin
  EXPECT_NEAR(f[1].y(), 0.2, 1e-12);
  EXPECT_NEAR(f[2].x(), 5.0, 1e-12);
  EXPECT_EQ(VoxelFilter(points, 100).size(), 2u);  // cells are aligned on the origin: x < 0 is another
  EXPECT_TRUE(VoxelFilter({}, 0.1).empty());
  for (double bad : {0.0, -1.0, std::numeric_limits<double>::infinity(), std::nan("")}) {
    EXPECT_THROW(VoxelFilter(points, bad), InvalidArgument) << bad;
  }
}

TEST(OdometryTrack, InterpolatesTheShortWayRoundAndClamps) {
  OdometryTrack t;
  SE2<double> p;
  EXPECT_EQ(t.At(1, &p), OdometryOrigin::kNone);
  t.Add(2, SE2<double>(2, 0, -3.0));
  t.Add(1, SE2<double>(0, 0, 3.0));
  t.Add(3, SE2<double>(2, 2, -3.0));
  ASSERT_EQ(t.Sorted().size(), 3u);
  EXPECT_DOUBLE_EQ(t.Sorted()[0].stamp, 1);
  EXPECT_EQ(t.At(1.5, &p), OdometryOrigin::kInterpolated);
  EXPECT_DOUBLE_EQ(p.x(), 1);
  // From 3.0 to -3.0 through pi, not through 0.
  EXPECT_NEAR(std::abs(p.theta()), M_PI, 1e-12);
  EXPECT_EQ(t.At(2.75, &p), OdometryOrigin::kInterpolated);
  EXPECT_DOUBLE_EQ(p.y(), 1.5);
  EXPECT_EQ(t.At(0.5, &p), OdometryOrigin::kClamped);
  EXPECT_DOUBLE_EQ(p.theta(), 3.0);
  EXPECT_EQ(t.At(4, &p), OdometryOrigin::kClamped);
  EXPECT_DOUBLE_EQ(p.y(), 2);
  EXPECT_EQ(t.At(1, &p), OdometryOrigin::kInterpolated);
  EXPECT_DOUBLE_EQ(p.theta(), 3.0);
}

TEST(AttachOdometry, ScanLineNeedsTheLinesPose) {
  LidarLog log;
  log.path = "x.bag";
  log.scans.resize(2);
  log.scans[0].stamp = 1.5;
  log.scans[0].source_index = 7;
  log.scans[1].stamp = 1.0;
  log.scans[1].odometry_origin = OdometryOrigin::kScanLine;
  log.scans[1].odometry = SE2<double>(5, 5, 0);
  log.odometry.Add(1, SE2<double>(0, 0, 0));
  log.odometry.Add(2, SE2<double>(1, 0, 0));
  const std::string message =
      testing::ErrorOf<ParseError>([&] { AttachOdometry(log.path, OdometrySource::kScanLine, &log); });
  EXPECT_NE(message.find("x.bag: scan 7 carries no odometry of its own"), std::string::npos) << message;
  AttachOdometry(log.path, OdometrySource::kAuto, &log);
  EXPECT_DOUBLE_EQ(log.scans[0].odometry.x(), 0.5);
  EXPECT_DOUBLE_EQ(log.scans[1].odometry.x(), 5);  // its own line's
  AttachOdometry(log.path, OdometrySource::kInterpolated, &log);
  EXPECT_DOUBLE_EQ(log.scans[1].odometry.x(), 0);
  EXPECT_EQ(log.scans[1].odometry_origin, OdometryOrigin::kInterpolated);
  const std::vector<StampedPose2> traj = OdometryTrajectory(log);
  ASSERT_EQ(traj.size(), 2u);
  EXPECT_DOUBLE_EQ(traj[0].stamp, 1.5);
  EXPECT_DOUBLE_EQ(traj[0].pose.x(), 0.5);
}

}  // namespace
}  // namespace lidar
}  // namespace tether
