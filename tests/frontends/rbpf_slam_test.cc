// Grid-based Rao-Blackwellised particle filter SLAM (frontends/lidar/mapping/rbpf_slam_2d.h).
#include <gtest/gtest.h>

#include <cmath>

#include "tether/core/error.h"
#include "tether/core/trajectory_error.h"
#include "tether/frontends/lidar/io/tum_trajectory.h"
#include "tether/frontends/lidar/rbpf_slam_2d.h"
#include "tether/frontends/simulation/lidar_world.h"

namespace tether {
namespace lidar {
namespace {

SimulatedLidar Office(int scans, bool odometry = true) {
  LidarSimOptions o;
  o.scans = scans;
  o.odometry = odometry;
  o.seed = 3;
  return SimulateLidar(o);
}

RbpfSlamOptions Small(int particles, int threads) {
  RbpfSlamOptions o;
  o.particles = particles;
  o.threads = threads;
  return o;
}

// The simulated office with its noisy odometry: the filter's trajectory lies near the truth,
// far nearer than the odometry's.
TEST(RbpfSlamTest, MapsTheSimulatedOfficeToItsTruth) {
  const SimulatedLidar sim = Office(400);
  RbpfSlam2D slam(Small(8, 0));
  for (const LaserScan& s : sim.log.scans) slam.AddScan(s);
  const std::vector<StampedPose2> trajectory = slam.Trajectory();
  ASSERT_EQ(trajectory.size(), sim.log.scans.size());
  std::vector<StampedPose2> odometry;
  for (const LaserScan& s : sim.log.scans) odometry.push_back(StampedPose2{s.stamp, s.odometry});
  const TrajectoryError filter = StampedTrajectoryError(trajectory, sim.truth);
  const TrajectoryError odo = StampedTrajectoryError(odometry, sim.truth);
  EXPECT_LT(filter.rmse, 0.05) << "odometry " << odo.rmse;
  EXPECT_LT(filter.rmse, 0.5 * odo.rmse);
  const RbpfSlamReport& r = slam.report();
  EXPECT_EQ(r.scans, 400);
  EXPECT_GT(r.processed, 50);
  EXPECT_GT(r.matched, 8 * (r.processed - 1) / 2);  // most particle-scans matched their maps
  // The map: the walls the scans saw are occupied cells of the heaviest particle's grid.
  const ProbabilityGrid map = slam.Map();
  int occupied = 0;
  for (const std::uint16_t v : map.values()) occupied += v != 0 && map.ValueToProbability(v) > 0.6 ? 1 : 0;
  EXPECT_GT(occupied, 500);
}

// A log without odometry: the scans are moved by scan-to-scan matching, and the filter maps the
// office as it does with odometry (the simulated odometry drifts; the matches barely do).
TEST(RbpfSlamTest, ScanOnlyMapsTheOfficeToo) {
  const SimulatedLidar sim = Office(400, false);
  RbpfSlam2D slam(Small(8, 0));
  for (const LaserScan& s : sim.log.scans) slam.AddScan(s);
  const TrajectoryError e = StampedTrajectoryError(slam.Trajectory(), sim.truth);
  EXPECT_LT(e.rmse, 0.1);
  EXPECT_EQ(slam.report().scan_to_scan, 399);
  EXPECT_NE(slam.report().Summary().find("no odometry: 399 moved by scan-to-scan matching"), std::string::npos);
}

// An odometry that is wrong for a stretch (here it says the robot drove backwards over 60 scans,
// as fr079's does at a door): the scan-to-scan check overrules it there, and the filter keeps
// to the truth; without the check the particles follow the odometry off.
TEST(RbpfSlamTest, TheScansOverruleAnOdometryThatIsWrongForAStretch) {
  SimulatedLidar sim = Office(300);
  SE2d corrupted = sim.log.scans.front().odometry;
  SE2d previous = corrupted;
  for (std::size_t k = 1; k < sim.log.scans.size(); ++k) {
    const SE2d step = previous.Inverse() * sim.log.scans[k].odometry;
    previous = sim.log.scans[k].odometry;
    corrupted = corrupted * (k >= 100 && k < 160 ? SE2d(-step.x(), -step.y(), step.theta()) : step);
    sim.log.scans[k].odometry = corrupted;
  }
  double rmse[2];
  long overruled[2];
  for (int check = 0; check < 2; ++check) {
    RbpfSlamOptions o = Small(8, 0);
    if (check == 0) o.odometry_check_translation = 0;
    RbpfSlam2D slam(o);
    for (const LaserScan& s : sim.log.scans) slam.AddScan(s);
    rmse[check] = StampedTrajectoryError(slam.Trajectory(), sim.truth).rmse;
    overruled[check] = slam.report().odometry_overruled;
  }
  EXPECT_EQ(overruled[0], 0);
  EXPECT_GE(overruled[1], 15);  // 23 of the stretch's processed scans
  EXPECT_LT(rmse[1], 0.1);
  EXPECT_GT(rmse[0], 3 * rmse[1]);
}

// The particles' maps share what they have in common: where a scan sees a small part of the map
// (here 5 m of a 40 m office), far less memory than particles x map.
TEST(RbpfSlamTest, MapsShareTheirTiles) {
  const SimulatedLidar sim = Office(500);
  RbpfSlamOptions o = Small(20, 0);
  o.max_range = 5;
  RbpfSlam2D slam(o);
  for (const LaserScan& s : sim.log.scans) slam.AddScan(s);
  const RbpfSlamReport& r = slam.report();
  const std::size_t one = slam.particle_map(0).tile_count();
  EXPECT_GT(r.resamplings, 0);
  EXPECT_LT(r.distinct_tiles, 20 * one / 3) << one;
  EXPECT_GE(r.distinct_tiles, one);
}

// The same seed gives the same trajectory bit for bit with 1 and 2 threads; another seed another.
TEST(RbpfSlamTest, DeterministicForASeedWhateverTheThreads) {
  const SimulatedLidar sim = Office(80);
  std::vector<std::vector<StampedPose2>> runs;
  for (const auto& [threads, seed] : {std::pair<int, int>{1, 1}, {2, 1}, {2, 2}}) {
    RbpfSlamOptions o = Small(8, threads);
    o.seed = static_cast<std::uint64_t>(seed);
    RbpfSlam2D slam(o);
    for (const LaserScan& s : sim.log.scans) slam.AddScan(s);
    runs.push_back(slam.Trajectory());
  }
  bool other = false;
  for (std::size_t i = 0; i < runs[0].size(); ++i) {
    EXPECT_EQ(runs[0][i].pose.x(), runs[1][i].pose.x());
    EXPECT_EQ(runs[0][i].pose.theta(), runs[1][i].pose.theta());
    other = other || runs[0][i].pose.x() != runs[2][i].pose.x();
  }
  EXPECT_TRUE(other);
}

TEST(RbpfSlamTest, BadInputIsAClearError) {
  RbpfSlamOptions o;
  o.particles = 0;
  EXPECT_THROW(RbpfSlam2D{o}, InvalidArgument);
  o = RbpfSlamOptions();
  o.resample_fraction = 2;
  EXPECT_THROW(RbpfSlam2D{o}, InvalidArgument);
  o = RbpfSlamOptions();
  o.likelihood_points = 0;
  EXPECT_THROW(RbpfSlam2D{o}, InvalidArgument);
  // A log is run with odometry throughout or without it throughout; a scan that breaks the rule
  // is refused, naming why, and changes nothing.
  const SimulatedLidar without = Office(5, false);
  const SimulatedLidar with = Office(5, true);
  RbpfSlam2D slam(Small(4, 1));
  slam.AddScan(with.log.scans[0]);
  try {
    slam.AddScan(without.log.scans[1]);
    FAIL() << "accepted a scan without odometry after one with";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("has no odometry"), std::string::npos) << e.what();
  }
  EXPECT_EQ(slam.report().scans, 1);
  // A particle that is not there.
  EXPECT_THROW(slam.Trajectory(4), InvalidArgument);
  EXPECT_THROW(slam.Map(99), InvalidArgument);
  EXPECT_EQ(slam.Trajectory(-1).size(), 1u);
  LaserScan bad = Office(2).log.scans.front();
  bad.ranges.clear();
  EXPECT_THROW(slam.AddScan(bad), InvalidArgument);
}

}  // namespace
}  // namespace lidar
}  // namespace tether
