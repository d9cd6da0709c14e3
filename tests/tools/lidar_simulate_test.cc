// tether simulate lidar: the simulated office world written as a CARMEN log with its true
// trajectory, the same bytes for a seed, the lds preset, and the options' errors.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "testing/cli.h"
#include "testing/lidar_files.h"
#include "tether/frontends/lidar/io/carmen_reader.h"
#include "tether/frontends/lidar/io/occupancy_map.h"
#include "tether/frontends/lidar/io/tum_trajectory.h"
#include "tether/frontends/simulation/lidar_world.h"

namespace tether {
namespace {

using testing::CliRun;
using testing::Tether;

using SimulateLidarTest = testing::LidarFilesTest;

TEST_F(SimulateLidarTest, WritesTheLogAndItsTruthTheSameForASeed) {
  const std::string args = "simulate lidar --scans 200 --beams 180 --seed 5";
  CliRun r = Tether(args + " -o " + P("a.log") + " --truth " + P("a.tum"));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("wrote " + P("a.log") +
                          ": tether simulate lidar: the office world, seed 5, 200 scans of 180 "
                          "beams, max range 20 m, odometry"),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("wrote the true trajectory " + P("a.tum") + " (200 poses)"), std::string::npos) << r.output;
  const lidar::LidarLog log = lidar::ReadCarmenLog(P("a.log"));
  const std::vector<lidar::StampedPose2> truth = lidar::ReadTumFile(P("a.tum"));
  ASSERT_EQ(log.scans.size(), 200u);
  ASSERT_EQ(truth.size(), 200u);
  for (std::size_t k = 0; k < 200; ++k) {
    EXPECT_NEAR(log.scans[k].stamp, truth[k].stamp, 1e-9);
    EXPECT_EQ(log.scans[k].ranges.size(), 180u);
    EXPECT_EQ(log.scans[k].odometry_origin, lidar::OdometryOrigin::kScanLine);
  }
  // The odometry starts at the truth.
  EXPECT_NEAR((log.scans[0].odometry.translation() - truth[0].pose.translation()).norm(), 0, 1e-9);
  ASSERT_EQ(Tether(args + " -o " + P("b.log") + " --truth " + P("b.tum")).code, 0);
  EXPECT_TRUE(Read("a.log") == Read("b.log"));
  EXPECT_TRUE(Read("a.tum") == Read("b.tum"));
  ASSERT_EQ(Tether("simulate lidar --scans 200 --beams 180 --seed 6 -o " + P("c.log")).code, 0);
  EXPECT_FALSE(Read("a.log") == Read("c.log"));
}

TEST_F(SimulateLidarTest, PresetAndNoOdometry) {
  CliRun r =
      Tether("simulate lidar --scans 100 --preset lds --no-odometry -o " + P("l.log") + " --truth " + P("l.tum"));
  ASSERT_EQ(r.code, 0) << r.output;
  const lidar::LidarLog log = lidar::ReadCarmenLog(P("l.log"));
  const std::vector<lidar::StampedPose2> truth = lidar::ReadTumFile(P("l.tum"));
  ASSERT_EQ(log.scans.size(), 50u);  // every other scan: 5 Hz
  ASSERT_EQ(truth.size(), 50u);
  EXPECT_TRUE(log.odometry.empty());
  std::size_t valid = 0, beams = 0;
  for (std::size_t k = 0; k < 50; ++k) {
    const lidar::LaserScan& s = log.scans[k];
    EXPECT_NEAR(s.stamp, truth[k].stamp, 1e-9);
    EXPECT_EQ(s.odometry_origin, lidar::OdometryOrigin::kNone);
    EXPECT_EQ(s.ranges.size(), 360u);
    EXPECT_EQ(s.range_max, 6);
    valid += s.ValidCount();
    beams += s.ranges.size();
  }
  EXPECT_LT(valid, beams * 96 / 100);  // 5% dropped, and walls beyond 6 m
}

TEST_F(SimulateLidarTest, Errors) {
  CliRun r = Tether("simulate manhattan -o " + P("m.g2o") + " --truth " + P("m.tum"));
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("are for the lidar world (got 'manhattan')"), std::string::npos) << r.output;
  r = Tether("simulate lidar -o " + P("x.log") + " --ground-truth " + P("x.g2o"));
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("use --truth, not --ground-truth"), std::string::npos) << r.output;
  r = Tether("simulate lidar -o " + P("x.log") + " --scans 1");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("scans must be in [2, 10000000]"), std::string::npos) << r.output;
  r = Tether("simulate lidar -o " + P("x.log") + " --preset sick");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("--preset takes lds"), std::string::npos) << r.output;
  r = Tether("simulate lidar -o " + P("x.log") + " --truth " + P("x.log"));
  EXPECT_EQ(r.code, 2) << r.output;
  r = Tether("simulate lidar -o " + P("no/dir/x.log"));
  EXPECT_EQ(r.code, 4) << r.output;
  EXPECT_FALSE(std::ifstream(P("x.log")).good());
  // The other worlds are as they were.
  EXPECT_EQ(Tether("simulate manhattan --poses 20 -o " + P("m.g2o")).code, 0);
}

// --world maze: the maze's run, the same as SimulateLidar's; --map-out: the world's map beside it.
using MazeSimulateLidarTest = SimulateLidarTest;

TEST_F(MazeSimulateLidarTest, WritesTheMazeRunAndTheMap) {
  CliRun r = Tether("simulate lidar --world maze --scans 120 --beams 90 --seed 4 -o " + P("m.log") + " --truth " +
                    P("m.tum") + " --map-out " + P("m.yaml"));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("the maze world (8 x 8 cells of 2 m), seed 4, 120 scans of 90 beams"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("wrote the world's map " + P("m.yaml") + " and " + P("m.pgm")), std::string::npos)
      << r.output;
  lidar::LidarSimOptions o;
  o.world = lidar::LidarWorld::kMaze;
  o.scans = 120;
  o.beams = 90;
  o.seed = 4;
  const lidar::SimulatedLidar sim = lidar::SimulateLidar(o);
  const std::vector<lidar::StampedPose2> truth = lidar::ReadTumFile(P("m.tum"));
  ASSERT_EQ(truth.size(), 120u);
  for (std::size_t k = 0; k < 120; ++k) {
    EXPECT_LT((truth[k].pose.translation() - sim.truth[k].pose.translation()).norm(), 1e-6) << k;
  }
  const lidar::OccupancyImage map = lidar::RasterizeWalls(sim.walls, 0.05);
  EXPECT_TRUE(Read("m.pgm") == lidar::PgmBytes(map));
  EXPECT_EQ(Read("m.yaml"), lidar::MapYaml(map, "m.pgm"));
  // The office's map at another resolution; a map path that is not YAML is refused.
  ASSERT_EQ(
      Tether("simulate lidar --scans 5 -o " + P("o.log") + " --map-out " + P("o.yml") + " --map-resolution 0.1").code,
      0);
  EXPECT_NE(Read("o.yml").find("resolution: 0.1"), std::string::npos);
  EXPECT_NE(Read("o.pgm").find("\n421 321\n"), std::string::npos);  // 40 m x 30 m at 0.1 m, 10 pixels round
  r = Tether("simulate lidar --scans 5 -o " + P("x.log") + " --map-out " + P("x.pgm"));
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_FALSE(std::ifstream(P("x.log")).good());
  r = Tether("simulate lidar --scans 5 --world castle -o " + P("x.log"));
  EXPECT_EQ(r.code, 2) << r.output;
  r = Tether("simulate manhattan -o " + P("x.g2o") + " --world maze");
  EXPECT_EQ(r.code, 2) << r.output;
}

}  // namespace
}  // namespace tether
