// The simulated LiDAR world: deterministic for a seed, its scans on the walls at the true
// poses, odometry equal to the truth without noise and drifting with it, a path that stays
// clear of the walls and comes round the loop again.
#include "tether/frontends/simulation/lidar_world.h"

#include <gtest/gtest.h>

#include <cmath>

#include "tether/core/error.h"
#include "tether/core/so2.h"

namespace tether {
namespace lidar {
namespace {

TEST(LidarWorldTest, TheSameSeedGivesTheSameRun) {
  LidarSimOptions o;
  o.scans = 300;
  o.seed = 11;
  const SimulatedLidar a = SimulateLidar(o), b = SimulateLidar(o);
  ASSERT_EQ(a.log.scans.size(), 300u);
  ASSERT_EQ(a.truth.size(), 300u);
  for (std::size_t k = 0; k < 300; ++k) {
    EXPECT_EQ(a.log.scans[k].ranges, b.log.scans[k].ranges);
    EXPECT_EQ(a.truth[k].pose.translation(), b.truth[k].pose.translation());
    EXPECT_EQ(a.log.scans[k].odometry.translation(), b.log.scans[k].odometry.translation());
  }
  o.seed = 12;
  const SimulatedLidar c = SimulateLidar(o);
  int different = 0;
  for (std::size_t k = 0; k < 300; ++k) different += a.log.scans[k].ranges != c.log.scans[k].ranges ? 1 : 0;
  EXPECT_GT(different, 250);
  // The walls move with the seed only in the boxes.
  EXPECT_EQ(OfficeWorld(11).size(), a.walls.size());
}

TEST(LidarWorldTest, ScanPointsAtTheTruePoseLieOnTheWalls) {
  LidarSimOptions o;
  o.scans = 1000;
  o.range_noise = 0.01;
  const SimulatedLidar sim = SimulateLidar(o);
  std::size_t points = 0, far = 0;
  for (std::size_t k = 0; k < sim.log.scans.size(); k += 37) {
    const LaserScan& s = sim.log.scans[k];
    EXPECT_EQ(s.stamp, sim.truth[k].stamp);
    EXPECT_GT(s.ValidCount(), s.ranges.size() / 2);
    for (const Eigen::Vector2d& p : ScanToPoints(s)) {
      const double d = DistanceToWalls(sim.walls, sim.truth[k].pose * p);
      ++points;
      far += d > 4 * o.range_noise ? 1 : 0;
      EXPECT_LT(d, 6 * o.range_noise);
    }
  }
  EXPECT_GT(points, 5000u);
  EXPECT_LT(far, points / 1000 + 1);  // 4 sigmas: about 6 in 100000
  // Without noise, on the walls to rounding.
  o.range_noise = 0;
  o.scans = 50;
  const SimulatedLidar exact = SimulateLidar(o);
  for (std::size_t k = 0; k < exact.log.scans.size(); k += 7) {
    for (const Eigen::Vector2d& p : ScanToPoints(exact.log.scans[k])) {
      EXPECT_LT(DistanceToWalls(exact.walls, exact.truth[k].pose * p), 1e-5);
    }
  }
}

TEST(LidarWorldTest, OdometryIsTheTruthWithoutNoiseAndDriftsWithIt) {
  LidarSimOptions o;
  o.scans = 1500;
  o.translation_noise = o.rotation_noise = o.rotation_per_metre = 0;
  const SimulatedLidar exact = SimulateLidar(o);
  ASSERT_EQ(exact.log.odometry.size(), 1500u);
  for (std::size_t k = 0; k < exact.truth.size(); ++k) {
    const LaserScan& s = exact.log.scans[k];
    EXPECT_EQ(s.odometry_origin, OdometryOrigin::kScanLine);
    EXPECT_LT((s.odometry.translation() - exact.truth[k].pose.translation()).norm(), 1e-9) << k;
    EXPECT_LT(std::abs(WrapAngle(s.odometry.theta() - exact.truth[k].pose.theta())), 1e-9) << k;
  }
  // With the default noise the odometry drifts; the truth is the same.
  const SimulatedLidar noisy = SimulateLidar(LidarSimOptions{[] {
    LidarSimOptions d;
    d.scans = 1500;
    return d;
  }()});
  const double drift = (noisy.log.scans.back().odometry.translation() - noisy.truth.back().pose.translation()).norm();
  EXPECT_GT(drift, 0.1);
  EXPECT_LT(drift, 20.0);
  EXPECT_EQ(noisy.truth.back().pose.translation(), exact.truth.back().pose.translation());
  // Without odometry: none on the scans, no messages.
  o.odometry = false;
  o.scans = 20;
  const SimulatedLidar none = SimulateLidar(o);
  EXPECT_TRUE(none.log.odometry.empty());
  for (const LaserScan& s : none.log.scans) EXPECT_EQ(s.odometry_origin, OdometryOrigin::kNone);
}

TEST(LidarWorldTest, ThePathStaysClearAndComesRoundAgain) {
  const LidarSimOptions o;
  const SimulatedLidar sim = SimulateLidar(o);
  ASSERT_EQ(sim.truth.size(), 3000u);
  EXPECT_GE(sim.laps, 2);
  EXPECT_GE(sim.rooms_visited, 3);
  EXPECT_GT(sim.distance, 200);
  double nearest = INFINITY;
  for (std::size_t k = 0; k < sim.truth.size(); ++k) {
    nearest = std::min(nearest, DistanceToWalls(sim.walls, sim.truth[k].pose.translation()));
    if (k == 0) continue;
    const SE2<double> step = sim.truth[k - 1].pose.Inverse() * sim.truth[k].pose;
    EXPECT_LE(step.translation().norm(), o.step + 1e-9) << k;
    EXPECT_LE(std::abs(step.theta()), o.max_turn + 1e-9) << k;
  }
  EXPECT_GT(nearest, 0.25);  // a robot 0.5 m across fits everywhere it goes
  // It comes back: a pose of the second half near one of the first half.
  bool revisited = false;
  for (std::size_t k = 2000; k < sim.truth.size() && !revisited; k += 10) {
    for (std::size_t j = 0; j + 500 < k && !revisited; j += 5) {
      revisited = (sim.truth[k].pose.translation() - sim.truth[j].pose.translation()).norm() < 0.5;
    }
  }
  EXPECT_TRUE(revisited);
}

TEST(LidarWorldTest, FieldOfViewAndUnusableOptions) {
  LidarSimOptions o;
  o.scans = 3;
  o.fov = M_PI;
  o.beams = 181;
  const SimulatedLidar sim = SimulateLidar(o);
  EXPECT_DOUBLE_EQ(sim.log.scans[0].angle_min, -M_PI / 2);
  EXPECT_NEAR(sim.log.scans[0].Angle(180), M_PI / 2, 1e-12);
  o = {};
  EXPECT_NEAR(SimulateLidar([] {
                LidarSimOptions d;
                d.scans = 2;
                return d;
              }())
                  .log.scans[0]
                  .angle_increment,
              2 * M_PI / 360, 1e-15);
  std::string why;
  o.scans = 1;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_EQ(why, "scans must be in [2, 10000000]");
  o = {};
  o.fov = 7;
  EXPECT_FALSE(o.IsValid(&why));
  o = {};
  o.range_noise = -1;
  try {
    SimulateLidar(o);
    ADD_FAILURE() << "no error";
  } catch (const InvalidArgument& e) {
    EXPECT_STREQ(e.what(), "lidar simulation: noise standard deviations must be finite and not negative");
  }
  EXPECT_TRUE(LidarSimOptions().IsValid(&why));
}

}  // namespace
}  // namespace lidar
}  // namespace tether
