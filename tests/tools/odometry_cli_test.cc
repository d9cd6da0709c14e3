// tether odometry: a log's wheel odometry through the odometry front-end into a pose graph and
// a trajectory, on a simulated log whose odometry is known; its errors.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "testing/cli.h"
#include "testing/lidar_files.h"
#include "tether/core/graph_io.h"
#include "tether/factors/builtin.h"
#include "tether/frontends/lidar/io/carmen_reader.h"
#include "tether/frontends/lidar/io/tum_trajectory.h"

namespace tether {
namespace {

using testing::CliRun;
using testing::Tether;

using OdometryCliTest = testing::LidarFilesTest;

TEST_F(OdometryCliTest, TheLogsOdometryBecomesAPoseGraphAndItsTrajectory) {
  ASSERT_EQ(Tether("simulate lidar --scans 120 --beams 90 --seed 4 -q -o " + P("o.log")).code, 0);
  CliRun r =
      Tether("odometry " + P("o.log") + " -o " + P("g.g2o") + " --trajectory " + P("t.tum") + " --controls-per-pose 2");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("odometry: 120 poses over "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("; 61 poses in the graph"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("wrote " + P("g.g2o") + " and " + P("t.tum")), std::string::npos) << r.output;
  // The graph: ids 0..60, the prior and a BetweenSE2 per pose, its poses those of the log's
  // odometry (every second message, and the last: 119 steps), so the dead-reckoned values have
  // chi2 0.
  const GraphFile g = ReadGraphFile(P("g.g2o"), DefaultRegistry());
  ASSERT_EQ(g.values.size(), 61u);
  EXPECT_EQ(g.graph.size(), 61u);
  EXPECT_LT(g.graph.Chi2(g.values), 1e-9);
  const lidar::LidarLog log = lidar::ReadCarmenLog(P("o.log"));
  const std::vector<lidar::StampedPose2>& odom = log.odometry.Sorted();
  ASSERT_EQ(odom.size(), 120u);
  const std::vector<lidar::StampedPose2> tum = lidar::ReadTumFile(P("t.tum"));
  ASSERT_EQ(tum.size(), 61u);
  EXPECT_NEAR((tum[60].pose.translation() - odom[119].pose.translation()).norm(), 0, 1e-6);
  EXPECT_NEAR(tum[60].stamp, odom[119].stamp, 1e-6);
  for (std::size_t i = 0; i < 60; ++i) {
    const lidar::StampedPose2& want = odom[i == 0 ? 0 : 2 * i];
    EXPECT_NEAR(tum[i].stamp, want.stamp, 1e-6) << i;
    EXPECT_NEAR((tum[i].pose.translation() - want.pose.translation()).norm(), 0, 1e-6) << i;
    const SE2d v = g.values.At<SE2d>(Key(i));
    EXPECT_NEAR((v.translation() - want.pose.translation()).norm(), 0, 1e-6) << i;
  }
  // `tether optimize` takes the graph as it is: odometry alone is already its optimum.
  CliRun opt = Tether("optimize " + P("g.g2o") + " -q");
  ASSERT_EQ(opt.code, 0) << opt.output;
  EXPECT_NE(opt.output.find("converged"), std::string::npos) << opt.output;
}

TEST_F(OdometryCliTest, ALogWithoutOdometryAndBadOptionsAreRefused) {
  ASSERT_EQ(Tether("simulate lidar --scans 40 --no-odometry -q -o " + P("n.log")).code, 0);
  CliRun r = Tether("odometry " + P("n.log") + " -o " + P("g.g2o"));
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_NE(r.output.find("has 0 odometry poses"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(P("g.g2o")));
  ASSERT_EQ(Tether("simulate lidar --scans 40 -q -o " + P("o.log")).code, 0);
  r = Tether("odometry " + P("o.log") + " -o " + P("no/such/folder/g.g2o"));
  EXPECT_EQ(r.code, 4) << r.output;
  r = Tether("odometry " + P("o.log") + " -o " + P("g.g2o") + " --controls-per-pose 0");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("--controls-per-pose"), std::string::npos) << r.output;
  r = Tether("odometry " + P("o.log") + " -o " + P("o.log"));
  EXPECT_EQ(r.code, 2) << r.output;
  r = Tether("odometry " + P("missing.log") + " -o " + P("g.g2o"));
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_NE(r.output.find("missing.log"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace tether
