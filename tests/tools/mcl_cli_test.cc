// tether mcl: a simulated robot localised in the simulated world's map, from its first pose and
// from a global start, the files it writes, the same bytes for a seed, and its errors;
// tether mcl-bench on a small generated map.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "testing/cli.h"
#include "testing/lidar_files.h"
#include "tether/core/registry.h"
#include "tether/frontends/lidar/io/tum_trajectory.h"
#include "tether/frontends/localization/mcl_localization_2d.h"

namespace tether {
namespace {

using testing::CliRun;
using testing::Tether;

class MclCliTest : public testing::LidarFilesTest {
 protected:
  // The maze run (600 scans, 0.1 m a scan, drifting odometry), its truth and map.
  void SimulateMaze(const std::string& extra = "") {
    const CliRun r = Tether("simulate lidar --world maze --scans 600 --beams 180 --seed 3 -o " + P("m.log") +
                            " --truth " + P("m.tum") + " --map-out " + P("m.yaml") + " " + extra);
    ASSERT_EQ(r.code, 0) << r.output;
  }
  std::string FirstPose() const {
    const std::vector<lidar::StampedPose2> truth = lidar::ReadTumFile(P("m.tum"));
    const SE2d& p = truth.front().pose;
    return FormatDouble(p.x()) + "," + FormatDouble(p.y()) + "," + FormatDouble(p.theta());
  }
};

TEST_F(MclCliTest, TracksTheSimulatedRobotInItsWorldsMap) {
  SimulateMaze();
  const CliRun r = Tether("mcl " + P("m.log") + " --map " + P("m.yaml") + " -o " + P("out") +
                          " --particles 500 --initial-pose=" + FirstPose() + " --reference " + P("m.tum"));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("600 scans; method auto, 500 particles, from the initial pose"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("converged (within 0.5 m and 10 degrees from then on) at pose 1,"), std::string::npos)
      << r.output;
  const std::vector<lidar::StampedPose2> estimate = lidar::ReadTumFile(P("out/trajectory.tum"));
  const std::vector<lidar::StampedPose2> truth = lidar::ReadTumFile(P("m.tum"));
  ASSERT_EQ(estimate.size(), 600u);
  const localization::LocalizationError e = localization::CompareWithReference(estimate, truth);
  EXPECT_EQ(e.matched, 600);
  EXPECT_LT(e.mean_error, 0.05);  // the map's cells are 0.05 m
  EXPECT_LT(e.max_error, 0.25);
  // The per-scan record and the picture.
  const std::string csv = Read("out/mcl_steps.csv");
  EXPECT_EQ(csv.rfind("scan,stamp,x,y,theta,sigma_x", 0), 0u);
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 601);
  EXPECT_EQ(Read("out/mcl.png").rfind("\x89PNG", 0), 0u);
  // The same bytes for a seed, whatever the threads.
  ASSERT_EQ(Tether("mcl " + P("m.log") + " --map " + P("m.yaml") + " -o " + P("again") +
                   " --particles 500 --threads 1 -q --initial-pose=" + FirstPose())
                .code,
            0);
  EXPECT_TRUE(Read("again/trajectory.tum") == Read("out/trajectory.tum"));
}

TEST_F(MclCliTest, FindsTheRobotFromAGlobalStart) {
  SimulateMaze();
  const CliRun r = Tether("mcl " + P("m.log") + " --map " + P("m.yaml") + " -o " + P("out") +
                          " --particles 5000 --method acmcl --reference " + P("m.tum"));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("global start"), std::string::npos) << r.output;
  const localization::LocalizationError e =
      localization::CompareWithReference(lidar::ReadTumFile(P("out/trajectory.tum")), lidar::ReadTumFile(P("m.tum")));
  ASSERT_GE(e.converged_index, 0) << r.output;
  EXPECT_LT(e.converged_index, 300) << r.output;  // within the first half of the run
  EXPECT_LT(e.mean_error_converged, 0.05);
}

TEST_F(MclCliTest, ErrorsNameTheFileAndWriteNothing) {
  SimulateMaze("--no-odometry");
  CliRun r = Tether("mcl " + P("m.log") + " --map " + P("m.yaml") + " -o " + P("out"));
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_NE(r.output.find("m.log:"), std::string::npos) << r.output;  // the scan's line
  EXPECT_NE(r.output.find("no odometry"), std::string::npos) << r.output;
  EXPECT_FALSE(std::ifstream(P("out/trajectory.tum")).good());
  r = Tether("mcl " + P("m.log") + " --map " + P("missing.yaml") + " -o " + P("out"));
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_NE(r.output.find("missing.yaml: cannot open"), std::string::npos) << r.output;
  r = Tether("mcl " + P("m.log") + " --map " + P("m.yaml") + " -o " + P("out") + " --method best");
  EXPECT_EQ(r.code, 2) << r.output;
  r = Tether("mcl " + P("m.log") + " --map " + P("m.yaml") + " -o " + P("out") + " --alpha-slow 0.5");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("alpha_slow (--alpha-slow)"), std::string::npos) << r.output;
  // A rule between two options names both flags the user typed (the library names its fields).
  r = Tether("mcl " + P("m.log") + " --map " + P("m.yaml") + " -o " + P("out") +
             " --kld --min-particles 900 --max-particles 500");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("min_particles (--min-particles) <= max_particles (--max-particles)"), std::string::npos)
      << r.output;
  r = Tether("mcl " + P("m.log") + " --map " + P("m.yaml") + " -o " + P("out") + " --initial-pose=1,2");
  EXPECT_EQ(r.code, 2) << r.output;
}

TEST_F(MclCliTest, BenchReportsEveryCase) {
  const CliRun r = Tether("mcl-bench --cells 400 --particles 300 --repeats 1");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("map: 400 x 400 cells"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("| around the pose (tracking) | 1 |"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("| spread over the map | 1 |"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("random 8-byte reads"), std::string::npos) << r.output;
  EXPECT_EQ(Tether("mcl-bench --cells 10").code, 2);
}

}  // namespace
}  // namespace tether
