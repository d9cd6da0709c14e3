// The kidnapped robot in LiDAR SLAM (LidarSlam2D): a simulated robot carried across the office
// while its scanner was off is detected at the scan it reappears and mapped on a new
// trajectory, joined to the first map where it belongs or kept apart (never joined elsewhere);
// the same log without the kidnap gives no detection.
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

// The largest distance between the poses of trajectory `t` (scans [from, to)) and the truth at
// the same stamps, the truth moved rigidly so that the first of them lies on it.
double MaxError(const std::vector<StampedPose2>& run, std::size_t from, std::size_t to,
                const std::vector<StampedPose2>& truth) {
  std::map<double, SE2d> at;
  for (const StampedPose2& t : truth) at[t.stamp] = t.pose;
  const SE2d align = at.at(run[from].stamp) * run[from].pose.Inverse();
  double worst = 0;
  for (std::size_t i = from; i < to; ++i) {
    worst = std::max(worst, ((align * run[i].pose).translation() - at.at(run[i].stamp).translation()).norm());
  }
  return worst;
}

// The office's rooms are alike (boxes apart): a global match to one of them is no proof, and a
// trajectory joins only where matches to two submaps 5 m apart place it alike. Either way the
// result must be right: joined where it belongs, or kept apart, never joined elsewhere.
TEST(LidarKidnapTest, ACarriedRobotIsDetectedAndMappedAnew) {
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
  const std::size_t first = static_cast<std::size_t>(r.trajectories[1].first_scan);
  EXPECT_GE(first, kidnap);
  EXPECT_LE(first, kidnap + 3);
  EXPECT_NE(r.KidnapSummary().find("kidnap detected at scan " + std::to_string(first + 1)), std::string::npos);
  const std::vector<StampedPose2> t = slam.Trajectory();
  EXPECT_LT(MaxError(t, 0, first, sim.truth), 0.15);         // the first trajectory
  EXPECT_LT(MaxError(t, first, t.size(), sim.truth), 0.15);  // the second, in its own frame
  if (r.trajectories[1].joined_scan >= 0) {
    EXPECT_LT(MaxError(t, 0, t.size(), sim.truth), 0.15) << r.KidnapSummary();  // joined where it belongs
  } else {
    double right = -1e9, left = 1e9;  // kept apart, beside the map
    for (std::size_t i = 0; i < first; ++i) right = std::max(right, t[i].pose.x());
    for (std::size_t i = first; i < t.size(); ++i) left = std::min(left, t[i].pose.x());
    EXPECT_GT(left, right) << r.KidnapSummary();
  }
  // The trajectory file names each pose's trajectory.
  for (const LidarOutput& o : slam.Outputs()) {
    if (o.name == "trajectory.csv") {
      EXPECT_NE(o.bytes.find("\n" + std::to_string(first + 1) + " "), std::string::npos);
    }
  }
}

TEST(LidarKidnapTest, NoKidnapNoDetection) {
  const SimulatedLidar sim = Office();
  LidarSlam2D slam(TestOptions());
  slam.Run(sim.log);
  EXPECT_EQ(slam.report().trajectories.size(), 1u) << slam.report().KidnapSummary();
  const std::vector<StampedPose2> t = slam.Trajectory();
  EXPECT_LT(MaxError(t, 0, t.size(), sim.truth), 0.15);
}

}  // namespace
}  // namespace lidar
}  // namespace tether
