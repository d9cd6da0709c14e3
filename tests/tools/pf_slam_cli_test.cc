// tether pf-slam: a simulated log mapped by the grid particle filter, the files it writes, the
// same bytes for a seed whatever the threads, and its errors.
#include <gtest/gtest.h>

#include <filesystem>

#include "testing/cli.h"
#include "testing/lidar_files.h"
#include "tether/core/trajectory_error.h"
#include "tether/frontends/lidar/io/tum_trajectory.h"

namespace tether {
namespace {

using testing::CliRun;
using testing::Tether;

class PfSlamCliTest : public testing::LidarFilesTest {};

TEST_F(PfSlamCliTest, MapsASimulatedLogAndWritesItsFiles) {
  ASSERT_EQ(Tether("simulate lidar --scans 200 --beams 180 --seed 4 -o " + P("s.log") + " --truth " + P("s.tum")).code,
            0);
  const CliRun r = Tether("pf-slam " + P("s.log") + " -o " + P("out") + " --particles 10");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("200 scans; 10 particles"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("processed"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("wrote"), std::string::npos) << r.output;
  const std::vector<lidar::StampedPose2> estimate = lidar::ReadTumFile(P("out/trajectory.tum"));
  ASSERT_EQ(estimate.size(), 200u);
  const TrajectoryError e = lidar::StampedTrajectoryError(estimate, lidar::ReadTumFile(P("s.tum")));
  EXPECT_LT(e.rmse, 0.1);
  EXPECT_EQ(Read("out/map.png").rfind("\x89PNG", 0), 0u);
  EXPECT_EQ(Read("out/map.pgm").rfind("P5", 0), 0u);
  EXPECT_NE(Read("out/map.yaml").find("image: map.pgm"), std::string::npos);
  // The same bytes for a seed, whatever the threads.
  ASSERT_EQ(Tether("pf-slam " + P("s.log") + " -o " + P("again") + " --particles 10 --threads 1 -q").code, 0);
  EXPECT_EQ(Read("again/trajectory.tum"), Read("out/trajectory.tum"));
  EXPECT_EQ(Read("again/map.pgm"), Read("out/map.pgm"));
}

TEST_F(PfSlamCliTest, ScanOnlyAndClearErrors) {
  // A log without odometry maps by scan-to-scan matching.
  ASSERT_EQ(Tether("simulate lidar --scans 20 --beams 90 --no-odometry -o " + P("n.log")).code, 0);
  const CliRun n = Tether("pf-slam " + P("n.log") + " -o " + P("n") + " --particles 4");
  EXPECT_EQ(n.code, 0) << n.output;
  EXPECT_NE(n.output.find("no odometry: 19 moved by scan-to-scan matching"), std::string::npos) << n.output;
  EXPECT_TRUE(std::filesystem::exists(P("n/trajectory.tum")));
  // --odometry none drops a log's odometry: the same scans, scan-only.
  ASSERT_EQ(Tether("simulate lidar --scans 20 --beams 90 -o " + P("o.log")).code, 0);
  const CliRun none = Tether("pf-slam " + P("o.log") + " -o " + P("o") + " --particles 4 --odometry none");
  EXPECT_EQ(none.code, 0) << none.output;
  EXPECT_NE(none.output.find("no odometry: 19 moved"), std::string::npos) << none.output;
  // Bad options: exit 2.
  EXPECT_EQ(Tether("pf-slam " + P("n.log") + " -o " + P("b") + " --odometry sometimes").code, 2);
  EXPECT_EQ(Tether("pf-slam " + P("n.log") + " -o " + P("b") + " --particles 0").code, 2);
  EXPECT_EQ(Tether("pf-slam " + P("n.log") + " -o " + P("b") + " --resample-fraction 2").code, 2);
  // A file that is not there.
  EXPECT_EQ(Tether("pf-slam " + P("none.log") + " -o " + P("b")).code, 1);
}

}  // namespace
}  // namespace tether
