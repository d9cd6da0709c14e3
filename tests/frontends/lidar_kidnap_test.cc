// The kidnapped robot in LiDAR SLAM (LidarSlam2D): a simulated robot carried across the office
// while its scanner was off is detected at the scan it reappears, mapped on a new trajectory,
// and joined to the first map by a global search, both onto the ground truth; the same log
// without the kidnap gives no detection.
#include <gtest/gtest.h>

#include <cmath>
#include <map>

#include "tether/frontends/lidar/io/degrade_log.h"
#include "tether/frontends/lidar/lidar_slam_2d.h"
#include "tether/frontends/simulation/lidar_world.h"

namespace tether {
namespace lidar {
namespace {

SimulatedLidar Office() {
  LidarSimOptions o;
  o.scans = 1500;
  o.seed = 4;
  return SimulateLidar(o);
}

LidarSlamOptions TestOptions() {
  LidarSlamOptions o;
  o.pose_graph.threads = 2;
  return o;
}

// The largest distance between the run's poses and the truth at the same stamps, the truth
// moved rigidly so that the run's first pose lies on it.
double MaxError(const std::vector<StampedPose2>& run, const std::vector<StampedPose2>& truth) {
  std::map<double, SE2d> at;
  for (const StampedPose2& t : truth) at[t.stamp] = t.pose;
  const SE2d align = at.at(run.front().stamp) * run.front().pose.Inverse();
  double worst = 0;
  for (const StampedPose2& p : run) {
    worst = std::max(worst, ((align * p.pose).translation() - at.at(p.stamp).translation()).norm());
  }
  return worst;
}

TEST(LidarKidnapTest, ACarriedRobotIsDetectedMappedAnewAndJoined) {
  const SimulatedLidar sim = Office();
  DegradeOptions cut;
  cut.kidnap_at = 100;  // on the second lap: the map already holds where it reappears
  cut.kidnap_seconds = 15;
  cut.kidnap_offset = SE2<double>(0.4, -0.3, 1.0);
  std::size_t kidnap = 0;
  const LidarLog log = DegradeLog(sim.log, cut, &kidnap);
  ASSERT_LT(kidnap, log.scans.size());
  LidarSlam2D slam(TestOptions());
  slam.Run(log);
  const LidarSlamReport& r = slam.report();
  ASSERT_EQ(r.trajectories.size(), 2u) << r.KidnapSummary();
  EXPECT_GE(r.trajectories[1].first_scan, static_cast<long>(kidnap));
  EXPECT_LE(r.trajectories[1].first_scan, static_cast<long>(kidnap) + 3);
  EXPECT_NE(r.KidnapSummary().find("kidnap detected at scan " + std::to_string(r.trajectories[1].first_scan + 1)),
            std::string::npos);
  ASSERT_GE(r.trajectories[1].joined_scan, r.trajectories[1].first_scan) << r.KidnapSummary();
  EXPECT_LT(MaxError(slam.Trajectory(), sim.truth), 0.15);
  // The trajectory file names each pose's trajectory.
  for (const LidarOutput& o : slam.Outputs()) {
    if (o.name != "trajectory.csv") continue;
    EXPECT_NE(o.bytes.find("\n" + std::to_string(r.trajectories[1].first_scan + 1) + " "), std::string::npos);
  }
}

TEST(LidarKidnapTest, NoKidnapNoDetection) {
  const SimulatedLidar sim = Office();
  LidarSlam2D slam(TestOptions());
  slam.Run(sim.log);
  EXPECT_EQ(slam.report().trajectories.size(), 1u) << slam.report().KidnapSummary();
  EXPECT_LT(MaxError(slam.Trajectory(), sim.truth), 0.15);
}

}  // namespace
}  // namespace lidar
}  // namespace tether
