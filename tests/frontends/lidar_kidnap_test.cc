// The kidnapped robot in LiDAR SLAM (LidarSlam2D): a simulated robot carried across the office
// while its scanner was off is detected at the scan it reappears and mapped on a new
// trajectory, joined to the first map where it belongs or kept apart (never joined elsewhere);
// the same log without the kidnap gives no detection.
#include <gtest/gtest.h>

#include <algorithm>
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

// The distance of each pose of trajectory `run` from the truth at its stamp, the truth moved
// rigidly so that pose `align` lies on it. Scans from `shifted` on were stamped `shift` seconds
// early (a cut whose gap was closed).
std::vector<double> Errors(const std::vector<StampedPose2>& run, std::size_t align,
                           const std::vector<StampedPose2>& truth, std::size_t shifted = SIZE_MAX, double shift = 0) {
  std::map<double, SE2d> at;
  for (const StampedPose2& t : truth) at[t.stamp] = t.pose;
  const auto truth_of = [&](std::size_t i) {
    auto it = at.lower_bound(run[i].stamp + (i >= shifted ? shift : 0) - 1e-6);
    if (it == at.end()) ADD_FAILURE() << "no truth at scan " << i;
    return it == at.end() ? SE2d() : it->second;
  };
  const SE2d to_truth = truth_of(align) * run[align].pose.Inverse();
  std::vector<double> e(run.size());
  for (std::size_t i = 0; i < run.size(); ++i)
    e[i] = ((to_truth * run[i].pose).translation() - truth_of(i).translation()).norm();
  return e;
}

// The largest error of the poses [from, to) of `run`, aligned at `from` (Errors).
double MaxError(const std::vector<StampedPose2>& run, std::size_t from, std::size_t to,
                const std::vector<StampedPose2>& truth) {
  const std::vector<double> e = Errors(run, from, truth);
  return *std::max_element(e.begin() + static_cast<long>(from), e.begin() + static_cast<long>(to));
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

// A stall of the logger without odometry: two seconds of scans lost while the robot stopped and
// turned. Scan-only local SLAM loses the robot there and both signals fire, but the robot was
// not carried off: the scan fits the current submap near where it last was. The declaration is
// withdrawn, the trajectory goes on, and it stays on the truth; with the relocation turned off
// the same log starts a new trajectory.
TEST(LidarKidnapTest, AStallWithoutOdometryIsNoKidnap) {
  const SimulatedLidar sim = Office();
  DegradeOptions cut;
  cut.kidnap_at = 35;  // the robot stops and turns in place there: constant velocity misses it
  cut.kidnap_seconds = 2;
  cut.kidnap_close_gap = true;
  cut.drop_odometry = true;
  std::size_t stall = 0;
  const LidarLog log = DegradeLog(sim.log, cut, &stall);
  LidarSlamOptions options = TestOptions();
  options.pose_graph.loop_closure = false;  // the decision is local SLAM's
  LidarSlam2D slam(options);
  slam.Run(log);
  const LidarSlamReport& r = slam.report();
  EXPECT_EQ(r.trajectories.size(), 1u) << r.KidnapSummary();
  ASSERT_EQ(r.relocations.size(), 1u) << r.KidnapSummary();
  EXPECT_GE(r.relocations[0], static_cast<long>(stall));
  EXPECT_LE(r.relocations[0], static_cast<long>(stall) + 3);
  EXPECT_NE(r.KidnapSummary().find("lost and found again"), std::string::npos);
  // Across the stall (aligned 5 s before it), the trajectory stays on the truth from the scan
  // that was found again: it took its right pose, not one near it. (The scans before it, since
  // the break, are the ones local SLAM lost; the whole run drifts without odometry or loop
  // closure.)
  const std::vector<double> e = Errors(slam.Trajectory(), stall - 50, sim.truth, stall, cut.kidnap_seconds);
  const std::size_t found = static_cast<std::size_t>(r.relocations[0]);
  EXPECT_LT(*std::max_element(e.begin() + static_cast<long>(stall) - 50, e.begin() + static_cast<long>(stall)), 0.05);
  EXPECT_LT(*std::max_element(e.begin() + static_cast<long>(found), e.begin() + static_cast<long>(stall) + 50), 0.05);

  options.local.kidnap.relocate_window = 0;
  LidarSlam2D without(options);
  without.Run(log);
  EXPECT_EQ(without.report().trajectories.size(), 2u) << without.report().KidnapSummary();
  EXPECT_TRUE(without.report().relocations.empty());
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
