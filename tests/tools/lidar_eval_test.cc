// tether lidar-eval: the relations metric of TUM trajectories and laser logs through the
// command line, its errors and exit codes, and the benchmark logs where present.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include "testing/cli.h"
#include "testing/lidar_files.h"
#include "tether/frontends/lidar/eval/relations_metric.h"
#include "tether/frontends/lidar/io/tum_trajectory.h"

namespace tether {
namespace {

using testing::CliRun;
using testing::Tether;

class LidarEvalTest : public testing::LidarFilesTest {
 protected:
  // A square path of 8 poses, one per second, and relations between consecutive poses plus
  // one loop; the estimate is the truth with pose 3 moved 0.2 m sideways.
  void SetUp() override {
    LidarFilesTest::SetUp();
    std::vector<lidar::StampedPose2> truth, estimate;
    for (int i = 0; i < 8; ++i) {
      const double a = M_PI / 4 * i;
      truth.push_back({100.0 + i, SE2<double>(std::cos(a), std::sin(a), a + M_PI / 2)});
    }
    estimate = truth;
    estimate[3].pose = estimate[3].pose * SE2<double>(0, 0.2, 0);
    std::ostringstream rel;
    rel.precision(17);
    for (int i = 0; i < 8; ++i) {
      const int j = (i + 1) % 8;
      const SE2<double> d = truth[i].pose.Inverse() * truth[j].pose;
      rel << truth[i].stamp << " " << truth[j].stamp << " " << d.x() << " " << d.y() << " 0 0 0 " << d.theta() << "\n";
    }
    rel << "999 100 0 0 0 0 0 0\n";  // no pose at 999: unmatched
    Write("r.relations", rel.str());
    lidar::WriteTumFile(P("est.txt"), estimate);
  }
};

TEST_F(LidarEvalTest, ScoresATumTrajectory) {
  const CliRun r = Tether("lidar-eval " + P("est.txt") + " " + P("r.relations"));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("trajectory: 8 poses (TUM text)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("relations: 9 in the file, 8 scored, 1 unmatched"), std::string::npos) << r.output;
  // Relations 2->3 and 3->4 are off by 0.2 m each: mean 0.4 / 8 = 0.05.
  EXPECT_NE(r.output.find("translational error: 0.0500 +- 0.0926 m (max 0.2000)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("rotational error:    0.000 +- 0.000 deg"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("squared translational error: 0.010000"), std::string::npos) << r.output;
}

TEST_F(LidarEvalTest, PoseOffsetComposesEveryPose) {
  // The truth moved 0.3 m along each pose's own x axis: scored as is, off; with the offset
  // -0.3,0,0 back on the relations exactly.
  std::vector<lidar::StampedPose2> truth = lidar::ReadTumFile(P("est.txt"));
  truth[3].pose = truth[3].pose * SE2<double>(0, -0.2, 0);
  for (lidar::StampedPose2& p : truth) p.pose = p.pose * SE2<double>(0.3, 0, 0);
  lidar::WriteTumFile(P("fwd.txt"), truth);
  CliRun r = Tether("lidar-eval " + P("fwd.txt") + " " + P("r.relations"));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_EQ(r.output.find("translational error: 0.0000"), std::string::npos) << r.output;
  r = Tether("lidar-eval " + P("fwd.txt") + " " + P("r.relations") + " --pose-offset=-0.3,0,0 --trajectory-out " +
             P("back.tum"));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("every pose composed with the offset (-0.3, 0, 0)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("translational error: 0.0000 +- 0.0000 m"), std::string::npos) << r.output;
  EXPECT_NEAR(lidar::ReadTumFile(P("back.tum"))[0].pose.x(), 1,
              1e-12);  // written after the offset: pose 0 back at (1, 0)
  for (const char* bad : {"1,2", "1,2,3,4", "a,0,0", "1,,0", "1,2,nan"}) {
    r = Tether("lidar-eval " + P("fwd.txt") + " " + P("r.relations") + " --pose-offset=" + bad);
    EXPECT_EQ(r.code, 2) << bad << ": " << r.output;
    EXPECT_NE(r.output.find("--pose-offset takes x,y,theta"), std::string::npos) << r.output;
  }
}

TEST_F(LidarEvalTest, ScoresALogAndWritesItsTrajectory) {
  // A CARMEN log of the same poses (FLASER lines carry them), gzip-compressed.
  std::ostringstream log;
  log.precision(17);
  const std::vector<lidar::StampedPose2> est = lidar::ReadTumFile(P("est.txt"));
  for (const lidar::StampedPose2& p : est) {
    const std::string pose =
        std::to_string(p.pose.x()) + " " + std::to_string(p.pose.y()) + " " + std::to_string(p.pose.theta());
    log << "FLASER 3 1 2 3 " << pose << " " << pose << " " << p.stamp << " h " << p.stamp - 100 << "\n";
  }
  WriteGz("est.clf.gz", log.str());
  const CliRun r = Tether("lidar-eval " + P("est.clf.gz") + " " + P("r.relations") + " --trajectory-out " + P("o.tum"));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("trajectory: 8 scans (carmen), odometry: auto"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("translational error: 0.0500"), std::string::npos) << r.output;
  EXPECT_EQ(lidar::ReadTumFile(P("o.tum")).size(), 8u);
  // --format tum on a log is a parse error with file:line.
  const CliRun bad = Tether("lidar-eval " + P("est.clf.gz") + " " + P("r.relations") + " --format tum");
  EXPECT_EQ(bad.code, 1) << bad.output;
  EXPECT_NE(bad.output.find("est.clf.gz:1:"), std::string::npos) << bad.output;
}

TEST_F(LidarEvalTest, ErrorsAndExitCodes) {
  Write("bad.relations", "100 101 0 0 0 0 0 0\n100 x 0 0 0 0 0 0\n");
  CliRun r = Tether("lidar-eval " + P("est.txt") + " " + P("bad.relations"));
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_NE(r.output.find("bad.relations:2: t2 'x' is not a number"), std::string::npos) << r.output;
  r = Tether("lidar-eval " + P("none.txt") + " " + P("r.relations"));
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_NE(r.output.find("cannot open"), std::string::npos) << r.output;
  r = Tether("lidar-eval " + P("est.txt") + " " + P("r.relations") + " --format xml");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("--format takes auto, tum or log"), std::string::npos) << r.output;
  r = Tether("lidar-eval " + P("est.txt") + " " + P("r.relations") + " --odometry wheel");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("--odometry takes auto, scan-line, interpolated or none"), std::string::npos) << r.output;
  r = Tether("lidar-eval " + P("est.txt") + " " + P("r.relations") + " --tolerance -1");
  EXPECT_EQ(r.code, 2) << r.output;
  r = Tether("lidar-eval " + P("est.txt") + " " + P("r.relations") + " --time-reference " + P("est.txt"));
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("--time-reference needs a log"), std::string::npos) << r.output;
  r = Tether("lidar-eval " + P("est.txt") + " " + P("r.relations") + " --trajectory-out " + P("nodir/o.tum"));
  EXPECT_EQ(r.code, 4) << r.output;
  r = Tether("lidar-eval " + P("est.txt") + " " + P("r.relations") + " --trajectory-out " + P("est.txt"));
  EXPECT_EQ(r.code, 2) << r.output;  // an output naming the input
  r = Tether("lidar-eval " + P("est.txt"));
  EXPECT_EQ(r.code, 2) << r.output;
  // Stamps a second off: nothing matches, and the command says why.
  std::vector<lidar::StampedPose2> late = lidar::ReadTumFile(P("est.txt"));
  for (lidar::StampedPose2& p : late) p.stamp += 0.5;
  lidar::WriteTumFile(P("late.txt"), late);
  r = Tether("lidar-eval " + P("late.txt") + " " + P("r.relations"));
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("0 scored, 9 unmatched"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("no relation matched the trajectory's stamps"), std::string::npos) << r.output;
}

TEST(LidarEvalDatasets, CorrectedLogRestampedFromItsRawLog) {
  const std::string cor = testing::LidarDataset("corrected/freiburg-079-corrected.log.gz");
  const std::string raw = testing::LidarDataset("raw/fr079.clf.gz");
  const std::string rel = testing::LidarDataset("raw/fr079.relations");
  if (cor.empty() || raw.empty() || rel.empty()) {
    GTEST_SKIP() << "lidar datasets absent (../shared/datasets not beside the repository)";
  }
  CliRun r = Tether("lidar-eval " + cor + " " + rel);
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("0 scored, 1685 unmatched"), std::string::npos) << r.output;
  r = Tether("lidar-eval " + cor + " " + rel + " --time-reference " + raw + " --tolerance 0");
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("4791 scans by their ranges, 0 by time only, 0 without a raw scan"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("1672 scored, 13 unmatched"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("translational error: 0.0582"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace tether
