// LidarSlam2D, the library class behind `tether lidar`: scan-only mapping of a simulated room to
// its ground truth, the laser's mounting, results independent of the thread count, and the
// self-check finding a stretch moved on purpose.
#include "tether/frontends/lidar/lidar_slam_2d.h"

#include <gtest/gtest.h>

#include <cmath>

#include "testing/synthetic_room.h"
#include "tether/core/error.h"

namespace tether {
namespace lidar {
namespace {

using testing::Segment;

std::vector<Segment> World() { return testing::RoomWithBoxes(); }

constexpr double kRangeMax = 15;

// Two laps of a circle of radius 5 m around the room's centre in 0.25 m steps at 10 Hz, with
// the laser at `laser` on the robot; the odometry is the truth where `odometry`, else none.
struct Trip {
  std::vector<SE2d> truth;
  std::vector<LaserScan> scans;
};

Trip Drive(bool odometry, const SE2d& laser = SE2d()) {
  Trip trip;
  const std::vector<Segment> world = World();
  for (int k = 0; k < 2 * 126; ++k) {
    const double a = 2 * M_PI * k / 126.0;
    const SE2d truth(12 + 5 * std::sin(a), 9 - 5 * std::cos(a), a);
    trip.truth.push_back(truth);
    LaserScan s;
    s.stamp = 100 + 0.1 * k;
    s.angle_min = -M_PI;
    s.angle_increment = 2 * M_PI / 360;
    s.range_max = kRangeMax;
    for (double r : testing::RayCastScan(world, truth * laser, 360, s.angle_min, s.angle_increment)) {
      s.ranges.push_back(static_cast<float>(std::isfinite(r) && r < kRangeMax ? r : kRangeMax));
    }
    s.laser_in_robot = laser;
    if (odometry) {
      s.odometry = truth;
      s.odometry_origin = OdometryOrigin::kScanLine;
    }
    trip.scans.push_back(std::move(s));
  }
  return trip;
}

LidarSlamOptions TestOptions(int threads) {
  LidarSlamOptions o;
  o.local.submaps.scans_per_submap = 30;
  o.pose_graph.threads = threads;
  o.pose_graph.search_every_n_scans = 4;
  o.self_check.part_scans = 20;
  o.self_check.min_separation_scans = 60;
  o.self_check.sample_every = 4;
  return o;
}

// The largest distance between the trajectory and the truth, both taken relative to their
// first pose.
double MaxError(const std::vector<StampedPose2>& t, const std::vector<SE2d>& truth) {
  double worst = 0;
  for (std::size_t i = 0; i < t.size(); ++i) {
    const SE2d a = t[0].pose.Inverse() * t[i].pose, b = truth[0].Inverse() * truth[i];
    worst = std::max(worst, (a.translation() - b.translation()).norm());
  }
  return worst;
}

std::vector<StampedPose2> Slam(const Trip& trip, const LidarSlamOptions& options, LidarSlamReport* report = nullptr) {
  LidarSlam2D slam(options);
  for (const LaserScan& s : trip.scans) slam.AddScan(s);
  slam.Finish();
  if (report != nullptr) *report = slam.report();
  return slam.Trajectory();
}

TEST(LidarSlam2DTest, ScanOnlyMappingFollowsTheTruth) {
  const Trip trip = Drive(/*odometry=*/false);
  LidarSlamReport report;
  const std::vector<StampedPose2> t = Slam(trip, TestOptions(2), &report);
  ASSERT_EQ(t.size(), trip.truth.size());
  EXPECT_EQ(report.scan_only, static_cast<long>(trip.scans.size()));
  EXPECT_LT(MaxError(t, trip.truth), 0.05);
  EXPECT_GT(report.loop_closures, 0);
  // Every scan after the first is predicted by scan-to-scan matching.
  EXPECT_EQ(report.scan_to_scan, static_cast<long>(trip.scans.size()) - 1);
  EXPECT_TRUE(report.self_check.stretches.empty());
  EXPECT_GT(report.self_check.FitShare(), 0.95);
}

TEST(LidarSlam2DTest, ScanOnlyRecoversFromAStandingStart) {
  // The first two scans at the same place: the velocity starts at zero, the robot then moves
  // 0.25 m a scan, beyond the correlative window around a constant-velocity prediction; the
  // scan-to-scan match sees the move.
  Trip trip = Drive(false);
  trip.scans.insert(trip.scans.begin(), trip.scans.front());
  trip.truth.insert(trip.truth.begin(), trip.truth.front());
  for (std::size_t i = 1; i < trip.scans.size(); ++i) trip.scans[i].stamp = trip.scans[i - 1].stamp + 0.1;
  LidarSlamReport report;
  const std::vector<StampedPose2> t = Slam(trip, TestOptions(2), &report);
  EXPECT_LT(MaxError(t, trip.truth), 0.05);
  EXPECT_EQ(report.scan_to_scan, static_cast<long>(trip.scans.size()) - 1);
}

TEST(LidarSlam2DTest, ScanOnlyIgnoresBunchedStamps) {
  // Stamps as a logger writes them: bunched and stalled (Intel: 0.01, 0.14, 0.54, 0, 0 s
  // between scans of a 5 Hz scanner). The motion is per scan; the prediction must not scale
  // with the stamps.
  Trip trip = Drive(false);
  const double steps[] = {0.01, 0.14, 0.54, 0, 0, 0.2, 0.1};
  for (std::size_t i = 1; i < trip.scans.size(); ++i) trip.scans[i].stamp = trip.scans[i - 1].stamp + steps[i % 7];
  LidarSlamReport report;
  const std::vector<StampedPose2> t = Slam(trip, TestOptions(2), &report);
  EXPECT_LT(MaxError(t, trip.truth), 0.05);
}

TEST(LidarSlam2DTest, TheLasersMountingIsApplied) {
  const SE2d laser(0.3, 0.1, 0.2);
  const Trip trip = Drive(/*odometry=*/true, laser);
  LidarSlamOptions options = TestOptions(2);
  const std::vector<StampedPose2> t = Slam(trip, options);
  // The robot's poses, not the laser's: the first at the odometry pose, the rest within 2 cm.
  EXPECT_LT((t[0].pose.translation() - trip.truth[0].translation()).norm(), 1e-12);
  double worst = 0;
  for (std::size_t i = 0; i < t.size(); ++i) {
    worst = std::max(worst, (t[i].pose.translation() - trip.truth[i].translation()).norm());
    EXPECT_NEAR(WrapAngle(t[i].pose.theta() - trip.truth[i].theta()), 0, 0.01) << i;
  }
  EXPECT_LT(worst, 0.04);
  // The same scans with the mounting ignored place the laser where the robot is: off by the
  // offset's length as the robot turns.
  Trip wrong = trip;
  for (LaserScan& s : wrong.scans) s.laser_in_robot = SE2d();
  const std::vector<StampedPose2> w = Slam(wrong, options);
  double worst_wrong = 0;
  for (std::size_t i = 0; i < w.size(); ++i) {
    worst_wrong = std::max(worst_wrong, (w[i].pose.translation() - trip.truth[i].translation()).norm());
  }
  EXPECT_GT(worst_wrong, 0.2);
}

TEST(LidarSlam2DTest, ResultsDoNotDependOnTheThreadCount) {
  const Trip trip = Drive(false);
  const std::vector<StampedPose2> one = Slam(trip, TestOptions(1));
  for (int threads : {0, 2, 4}) {
    const std::vector<StampedPose2> other = Slam(trip, TestOptions(threads));
    ASSERT_EQ(other.size(), one.size());
    for (std::size_t i = 0; i < one.size(); ++i) {
      EXPECT_EQ(other[i].pose.x(), one[i].pose.x()) << threads << " threads, scan " << i;
      EXPECT_EQ(other[i].pose.y(), one[i].pose.y());
      EXPECT_EQ(other[i].pose.theta(), one[i].pose.theta());
    }
  }
}

TEST(LidarSlam2DTest, TheDefaultSearchThreadsAreTheMachinesCores) {
  EXPECT_EQ(LidarSlamOptions().pose_graph.threads, DefaultSearchThreads());
  EXPECT_GE(DefaultSearchThreads(), 1);
}

TEST(LidarSlam2DTest, OutputsAndErrors) {
  LidarSlam2D slam(TestOptions(0));
  EXPECT_THROW(slam.Outputs(), InvalidArgument);
  EXPECT_THROW(slam.map(), InvalidArgument);
  const Trip trip = Drive(true);
  for (std::size_t i = 0; i < 40; ++i) slam.AddScan(trip.scans[i]);
  slam.Finish();
  EXPECT_THROW(slam.AddScan(trip.scans[40]), InvalidArgument);
  const std::vector<LidarOutput> out = slam.Outputs();
  ASSERT_EQ(out.size(), LidarSlam2D::OutputNames().size());
  for (const LidarOutput& o : out) EXPECT_FALSE(o.bytes.empty()) << o.name;
  EXPECT_EQ(out[0].name, "trajectory.tum");
  for (const LidarOutput& o : out) {
    if (o.name == "self_check.png") {
      EXPECT_EQ(o.bytes.substr(1, 3), "PNG");
    } else if (o.name == "kidnap.svg") {
      EXPECT_EQ(o.bytes.substr(0, 4), "<svg");
    } else if (o.name == "kidnap.csv") {
      EXPECT_EQ(std::count(o.bytes.begin(), o.bytes.end(), '\n'), 41);  // a header and 40 scans
    }
  }
  LidarSlamOptions bad;
  bad.self_check.fit_fraction = 2;
  std::string why;
  EXPECT_FALSE(bad.IsValid(&why));
  EXPECT_NE(why.find("fit_fraction"), std::string::npos) << why;
  EXPECT_THROW(LidarSlam2D{bad}, InvalidArgument);
}

// A scan that cannot be used is refused before anything changes; one that maps far outside any
// grid fails part-way, names its line through Run, and the run cannot go on.
TEST(LidarSlam2DTest, ScansThatCannotBeMappedAreRefusedByName) {
  const Trip trip = Drive(true);
  LidarSlam2D slam(TestOptions(0));
  slam.AddScan(trip.scans[0]);
  LaserScan bad = trip.scans[1];
  bad.angle_increment = 1e-300;
  std::string m;
  try {
    slam.AddScan(bad);
  } catch (const InvalidArgument& e) {
    m = e.what();
  }
  EXPECT_NE(m.find("scan 1: the angle step 1e-300 rad"), std::string::npos) << m;
  EXPECT_EQ(slam.scan_count(), 1);
  slam.AddScan(trip.scans[1]);  // nothing changed: the run goes on

  LidarLog log;
  log.path = "far.clf";
  log.format = LogFormat::kCarmen;
  for (int i = 0; i < 3; ++i) {
    LaserScan s = trip.scans[static_cast<std::size_t>(i)];
    s.source_index = 10 + i;
    if (i == 2) s.odometry = SE2d(1e6, 0, 0);  // within the reader's bounds, far outside any map
    log.scans.push_back(s);
  }
  LidarSlam2D far(TestOptions(0));
  m.clear();
  try {
    far.Run(log);
  } catch (const ParseError& e) {
    m = e.what();
  }
  EXPECT_NE(m.find("far.clf:12: scan 2: ProbabilityGrid: writing cell"), std::string::npos) << m;
  EXPECT_THROW(far.AddScan(trip.scans[3]), InvalidArgument);  // failed part-way: no more scans
}

// The self-check on the true poses: everything fits; with the last 40 scans moved 1 m aside and
// turned 1.7 degrees (a stretch a wrong closure would pull away), the stretch is found, and
// nothing else.
TEST(SelfCheck2DTest, FindsAStretchMovedOnPurpose) {
  const Trip trip = Drive(true);
  std::vector<SE2d> poses = trip.truth;
  std::vector<std::vector<Eigen::Vector2d>> points;
  std::vector<const std::vector<Eigen::Vector2d>*> pointers;
  for (const LaserScan& s : trip.scans) points.push_back(ScanToPoints(s));
  for (const auto& p : points) pointers.push_back(&p);
  SelfCheckOptions o = TestOptions(1).self_check;
  const SelfCheckResult good = CheckSelfConsistency(poses, pointers, o);
  EXPECT_GT(good.judged.size(), 40u);
  EXPECT_EQ(good.fitting, static_cast<long>(good.judged.size()));
  EXPECT_TRUE(good.stretches.empty());

  const std::size_t first_moved = poses.size() - 40;
  for (std::size_t i = first_moved; i < poses.size(); ++i) poses[i] = SE2d(0.8, 0.6, 0.03) * poses[i];
  const SelfCheckResult bad = CheckSelfConsistency(poses, pointers, o);
  ASSERT_EQ(bad.stretches.size(), 1u);
  EXPECT_GE(bad.stretches[0].first_scan, static_cast<long>(first_moved));
  EXPECT_LE(bad.stretches[0].first_scan, static_cast<long>(first_moved) + 8);
  EXPECT_EQ(bad.stretches[0].last_scan, static_cast<long>(poses.size()) - 4);
  for (const ScanFit& f : bad.judged) EXPECT_EQ(f.fits, f.scan < static_cast<long>(first_moved)) << f.scan;

  o.fit_fraction = 2;
  EXPECT_THROW(CheckSelfConsistency(poses, pointers, o), InvalidArgument);
  pointers.pop_back();
  EXPECT_THROW(CheckSelfConsistency(poses, pointers, SelfCheckOptions{}), InvalidArgument);
}

}  // namespace
}  // namespace lidar
}  // namespace tether
