// Scan-to-scan matching (point-to-line ICP, scan_to_scan_2d.h): the motion between two ray-cast
// scans, what the pairs see of it (their normal equations), the lines fitted to a noisy wall, and
// the directions of translation a corridor leaves unseen.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <random>

#include "testing/synthetic_room.h"
#include "tether/core/error.h"
#include "tether/frontends/lidar/mapping/local_slam_2d.h"
#include "tether/frontends/lidar/scan_matching/scan_to_scan_2d.h"

namespace tether {
namespace lidar {
namespace {

using testing::Segment;

// A corridor 2 m wide along x, far longer than the scanner's range: nothing in it shows how far
// along it a scan was taken.
std::vector<Segment> Corridor() { return {{{-100, -1}, {100, -1}}, {{-100, 1}, {100, 1}}}; }

// The same corridor closed by a wall across it at x = 4.
std::vector<Segment> ClosedCorridor() {
  std::vector<Segment> s = Corridor();
  s.push_back({{4, -1}, {4, 1}});
  return s;
}

std::vector<Eigen::Vector2d> Scan(const std::vector<Segment>& walls, const SE2d& pose, double noise = 0,
                                  unsigned seed = 1) {
  std::vector<Eigen::Vector2d> points = testing::ScanPoints(walls, pose, 360, 8);
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0, noise);
  if (noise > 0) {
    for (Eigen::Vector2d& p : points) p *= 1 + n(rng) / p.norm();  // noise along the beam
  }
  return points;
}

// The smallest eigenvalue of the translation block with the rotation marginalised out.
double SmallestTranslationInformation(const Eigen::Matrix3d& h) {
  const Eigen::Matrix2d t = h.topLeftCorner<2, 2>() - h.topRightCorner<2, 1>() * h.bottomLeftCorner<1, 2>() / h(2, 2);
  return std::min(t(0, 0) + t(1, 1) - std::hypot(t(0, 0) - t(1, 1), 2 * t(0, 1)),
                  t(0, 0) + t(1, 1) + std::hypot(t(0, 0) - t(1, 1), 2 * t(0, 1))) /
         2;
}

TEST(DegenerateTranslations, FindsTheDirectionsTheInformationLacks) {
  // Pairs whose normals all point across a corridor along x: y and the turn are seen, x is not.
  Eigen::Matrix3d corridor = Eigen::Matrix3d::Zero();
  corridor(1, 1) = 100;
  corridor(2, 2) = 50;
  const Eigen::Matrix2d px = DegenerateTranslations(corridor, 5);
  EXPECT_NEAR(px(0, 0), 1, 1e-12);
  EXPECT_NEAR(px(1, 1), 0, 1e-12);
  EXPECT_NEAR(px(0, 1), 0, 1e-12);
  // A corridor along the diagonal: the projector onto (1, 1) / sqrt(2).
  const double c = std::sqrt(0.5);
  Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
  r.topLeftCorner<2, 2>() << c, -c, c, c;
  const Eigen::Matrix2d pd = DegenerateTranslations(r * corridor * r.transpose(), 5);
  EXPECT_NEAR(pd(0, 0), 0.5, 1e-12);
  EXPECT_NEAR(pd(0, 1), 0.5, 1e-12);
  EXPECT_NEAR(pd(1, 1), 0.5, 1e-12);
  // Both seen: nothing degenerate; nothing seen: both.
  Eigen::Matrix3d room = corridor;
  room(0, 0) = 80;
  EXPECT_TRUE(DegenerateTranslations(room, 5).isZero());
  EXPECT_TRUE(DegenerateTranslations(Eigen::Matrix3d::Zero(), 5).isIdentity());
  // x seen only together with the turn (every x-facing pair far ahead on the beam): once the
  // turn is marginalised out, x is not seen. The threshold is on that, not on the raw diagonal.
  Eigen::Matrix3d coupled = corridor;
  coupled(0, 0) = 40;
  coupled(0, 2) = coupled(2, 0) = std::sqrt(40.0 * 50.0) * 0.999;
  EXPECT_NEAR(DegenerateTranslations(coupled, 5)(0, 0), 1, 1e-6);
  EXPECT_TRUE(DegenerateTranslations(coupled, 0).isZero());
}

TEST(ScanToScan, RecoversTheMotionWhereTheScansSeeIt) {
  const std::vector<Segment> walls = testing::RoomWithBoxes();
  const SE2d a(12, 9, 0.3), b = a * SE2d(0.2, -0.05, 0.04);
  for (double radius : {0.0, 0.2}) {
    ScanToScanOptions options;
    options.normal_radius = radius;
    const ScanToScanMatch m = MatchScanToScan(Scan(walls, a), Scan(walls, b), SE2d(0.1, 0, 0), options);
    ASSERT_TRUE(m.ok) << radius;
    const SE2d truth = a.Inverse() * b;
    EXPECT_NEAR(m.motion.x(), truth.x(), 0.005) << radius;
    EXPECT_NEAR(m.motion.y(), truth.y(), 0.005) << radius;
    EXPECT_NEAR(m.motion.theta(), truth.theta(), 0.002) << radius;
    EXPECT_GT(SmallestTranslationInformation(m.information), 20) << radius;
    EXPECT_TRUE(DegenerateTranslations(m.information, 5).isZero()) << radius;
  }
}

TEST(ScanToScan, FittedLinesDoNotInventInformationAlongANoisyCorridor) {
  // 1 cm of range noise: the line through a point's two neighbours (1-2 cm apart near the
  // robot) tilts by tens of degrees, and the pairs seem to see along the corridor what they
  // cannot (aces without odometry, benchmarks/RESULTS.md "LiDAR XI"). A line fitted to the
  // neighbours within 0.2 m does not.
  const SE2d a(0, 0.1, 0), b(0.1, 0.1, 0);
  const std::vector<Eigen::Vector2d> pa = Scan(Corridor(), a, 0.01, 1), pb = Scan(Corridor(), b, 0.01, 2);
  ScanToScanOptions neighbours;
  neighbours.normal_radius = 0;
  const ScanToScanMatch two = MatchScanToScan(pa, pb, SE2d(0.1, 0, 0), neighbours);
  ScanToScanOptions fit;
  fit.normal_radius = 0.2;
  const ScanToScanMatch fitted = MatchScanToScan(pa, pb, SE2d(0.1, 0, 0), fit);
  ASSERT_TRUE(two.ok);
  ASSERT_TRUE(fitted.ok);
  const double seen_two = SmallestTranslationInformation(two.information);
  const double seen_fitted = SmallestTranslationInformation(fitted.information);
  EXPECT_GT(seen_two, 5) << "the two-neighbour lines should tilt with the noise";
  EXPECT_LT(seen_fitted, 0.3 * seen_two);
  EXPECT_LT(seen_fitted, 3);
  // Across the corridor both see plenty.
  EXPECT_GT(fitted.information(1, 1), 100);
}

TEST(ScanToScan, AlongACorridorTheUnseenDirectionKeepsTheGuess) {
  const SE2d a(0, 0.2, 0.02), b(0.12, 0.15, 0.05);
  const std::vector<Eigen::Vector2d> pa = Scan(Corridor(), a, 0.005, 3), pb = Scan(Corridor(), b, 0.005, 4);
  const SE2d truth = a.Inverse() * b;
  ScanToScanOptions options;
  options.normal_radius = 0.2;
  options.degenerate_information = 5;
  // A guess 8 cm short along the corridor (in the first scan's frame, nearly its x) and off
  // across it and in the turn.
  const SE2d guess(truth.x() - 0.08, truth.y() + 0.03, truth.theta() - 0.02);
  const ScanToScanMatch m = MatchScanToScan(pa, pb, guess, options);
  ASSERT_TRUE(m.ok);
  // Across the corridor and the turn: found. Along it: the guess's, exactly.
  const Eigen::Vector2d along = SO2d(-a.theta()) * Eigen::Vector2d(1, 0);
  const Eigen::Vector2d across(-along.y(), along.x());
  EXPECT_NEAR(across.dot(m.motion.translation() - truth.translation()), 0, 0.005);
  EXPECT_NEAR(m.motion.theta(), truth.theta(), 0.002);
  EXPECT_NEAR(along.dot(m.motion.translation() - guess.translation()), 0, 0.002);
  EXPECT_NEAR(m.degenerate(0, 0), 1, 0.01);
  // With the corridor closed by a wall ahead, the direction is seen and the motion found.
  const ScanToScanMatch closed =
      MatchScanToScan(Scan(ClosedCorridor(), a, 0.005, 3), Scan(ClosedCorridor(), b, 0.005, 4), guess, options);
  ASSERT_TRUE(closed.ok);
  EXPECT_TRUE(closed.degenerate.isZero());
  EXPECT_NEAR(closed.motion.x(), truth.x(), 0.01);
  EXPECT_NEAR(closed.motion.y(), truth.y(), 0.01);
}

TEST(ScanToScan, OptionsAreValidated) {
  ScanToScanOptions o;
  std::string why;
  EXPECT_TRUE(o.IsValid(&why)) << why;
  o.normal_radius = -1;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("normal_radius"), std::string::npos);
  o = ScanToScanOptions();
  o.degenerate_information = std::nan("");
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("degenerate_information"), std::string::npos);
  EXPECT_THROW(MatchScanToScan({{1, 0}}, {{1, 0}}, SE2d(), o), InvalidArgument);
}

}  // namespace
}  // namespace lidar
}  // namespace tether

namespace tether {
namespace lidar {
namespace {

// Local SLAM without odometry down a corridor: 360 beams, 8 m range, 1 cm range noise; a wall
// behind the start (x = -2) shows the motion for the first 6 m, then 14 m of nothing but the
// two walls. Returns the error along the corridor of the last scan's pose (negative: behind).
double CorridorDriveError(const LocalSlamOptions& options, double step, int scans) {
  std::vector<Segment> walls = Corridor();
  walls.push_back({{-2, -1}, {-2, 1}});
  LocalSlam2D slam(options);
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0, 0.01);
  double error = 0;
  for (int k = 0; k < scans; ++k) {
    const SE2d truth(step * k, 0.1, 0);
    LaserScan s;
    s.stamp = 0.1 * k;
    s.angle_min = -M_PI;
    s.angle_increment = 2 * M_PI / 360;
    s.range_max = 8;
    for (double r : testing::RayCastScan(walls, truth, 360, s.angle_min, s.angle_increment)) {
      s.ranges.push_back(static_cast<float>(std::isfinite(r) && r < 8 ? r + noise(rng) : 8));
    }
    const LocalScanResult r = slam.AddScan(s);
    error = r.pose.x() - truth.x();
  }
  return error;
}

TEST(LocalSlam2DCorridor, WithoutOdometryTheUnseenDirectionKeepsTheMotion) {
  // 0.1 m a scan for 200 scans. Without the degeneracy rule, the matches settle where the
  // submap's own scans were taken and local SLAM stalls: the last pose lies metres behind.
  // With it, the motion learnt while the wall behind was in range carries on.
  LocalSlamOptions off;
  off.scan_to_scan_options.normal_radius = 0.2;
  const double stalled = CorridorDriveError(off, 0.1, 200);
  EXPECT_LT(stalled, -5);
  LocalSlamOptions on = off;
  on.scan_to_scan_options.degenerate_information = 5;
  const double held = CorridorDriveError(on, 0.1, 200);
  EXPECT_LT(std::abs(held), 0.5);
  // Lines through the next point each way tilt with the range noise: the pairs seem to see
  // along the corridor, the rule does not apply, and local SLAM stalls as without it.
  LocalSlamOptions two = on;
  two.scan_to_scan_options.normal_radius = 0;
  const double noisy_lines = CorridorDriveError(two, 0.1, 200);
  EXPECT_LT(noisy_lines, -5);
  std::cout << "corridor, 20 m without odometry: last pose " << stalled << " m along it without the rule, " << held
            << " m with it, " << noisy_lines << " m with it and two-neighbour lines\n";
}

}  // namespace
}  // namespace lidar
}  // namespace tether
