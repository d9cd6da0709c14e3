// tether lidar-degrade: a CARMEN log degraded through the command line, the same bytes for a
// seed, the preset and the flags over it, errors and exit codes.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include "testing/cli.h"
#include "testing/lidar_files.h"
#include "tether/frontends/lidar/io/carmen_reader.h"

namespace tether {
namespace {

using testing::CliRun;
using testing::Tether;

class LidarDegradeTest : public testing::LidarFilesTest {
 protected:
  // 30 FLASER scans of 181 beams (ranges 0.5 to 12 m, every 10th 81.9: no return) with ODOM
  // lines between them.
  void SetUp() override {
    LidarFilesTest::SetUp();
    std::ostringstream s;
    s.precision(17);
    for (int k = 0; k < 30; ++k) {
      const double t = 100 + 0.1 * k;
      s << "ODOM " << 0.1 * k << " 0 " << 0.01 * k << " 0 0 0 " << t - 0.05 << " h " << t - 0.05 << "\n";
      s << "FLASER 181";
      for (int i = 0; i < 181; ++i) s << " " << (i % 10 == 0 ? 81.9 : 0.5 + std::fmod(0.29 * i + 0.07 * k, 11.5));
      s << " " << 0.1 * k << " 0 " << 0.01 * k << " " << 0.1 * k << " 0 " << 0.01 * k << " " << t << " h " << t << "\n";
    }
    Write("in.clf", s.str());
  }
};

TEST_F(LidarDegradeTest, PresetAndSeedGiveTheSameBytes) {
  CliRun r = Tether("lidar-degrade " + P("in.clf") + " -o " + P("a.log") + " --preset lds --seed 3");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("read " + P("in.clf") + ": 30 scans (carmen, 181 beams on average), 30 odometry messages"),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("wrote " + P("a.log") + ": 15 scans"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("beams 360, max range 6 m, noise 0.02 m, drop 0.05"), std::string::npos) << r.output;
  const lidar::LidarLog log = lidar::ReadCarmenLog(P("a.log"));
  ASSERT_EQ(log.scans.size(), 15u);
  for (const lidar::LaserScan& s : log.scans) {
    EXPECT_EQ(s.ranges.size(), 360u);
    EXPECT_EQ(s.range_max, 6);
    EXPECT_EQ(s.odometry_origin, lidar::OdometryOrigin::kScanLine);
  }
  EXPECT_EQ(Read("a.log").rfind("# degraded from " + P("in.clf"), 0), 0u);
  ASSERT_EQ(Tether("lidar-degrade " + P("in.clf") + " -o " + P("b.log") + " --preset lds --seed 3").code, 0);
  EXPECT_TRUE(Read("a.log") == Read("b.log"));
  ASSERT_EQ(Tether("lidar-degrade " + P("in.clf") + " -o " + P("c.log") + " --preset lds --seed 4").code, 0);
  EXPECT_FALSE(Read("a.log") == Read("c.log"));
  // A flag given changes the preset's value; --no-odometry gives a log without odometry.
  r = Tether("lidar-degrade " + P("in.clf") + " -o " + P("d.log") + " --preset lds --keep-every 1 --beams 90 " +
             "--no-odometry --max-scans 20");
  ASSERT_EQ(r.code, 0) << r.output;
  const lidar::LidarLog d = lidar::ReadCarmenLog(P("d.log"));
  ASSERT_EQ(d.scans.size(), 20u);
  EXPECT_EQ(d.scans[0].ranges.size(), 90u);
  EXPECT_TRUE(d.odometry.empty());
  for (const lidar::LaserScan& s : d.scans) EXPECT_EQ(s.odometry_origin, lidar::OdometryOrigin::kNone);
}

TEST_F(LidarDegradeTest, WithoutOptionsTheScansReadBackTheSame) {
  ASSERT_EQ(Tether("lidar-degrade " + P("in.clf") + " -o " + P("same.log")).code, 0);
  const lidar::LidarLog a = lidar::ReadCarmenLog(P("in.clf")), b = lidar::ReadCarmenLog(P("same.log"));
  ASSERT_EQ(a.scans.size(), b.scans.size());
  for (std::size_t k = 0; k < a.scans.size(); ++k) {
    EXPECT_EQ(a.scans[k].ValidCount(), b.scans[k].ValidCount());
    for (std::size_t i = 0; i < a.scans[k].ranges.size(); ++i) {
      if (a.scans[k].Valid(i)) {
        EXPECT_EQ(a.scans[k].ranges[i], b.scans[k].ranges[i]);
      }
    }
    EXPECT_NEAR(a.scans[k].odometry.x(), b.scans[k].odometry.x(), 1e-12);
    EXPECT_NEAR(a.scans[k].Angle(180), b.scans[k].Angle(180), 1e-12);
  }
}

TEST_F(LidarDegradeTest, ErrorsAndExitCodes) {
  const std::string in = P("in.clf");
  CliRun r = Tether("lidar-degrade " + in + " -o " + P("x.log") + " --preset sick");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("--preset takes lds (got 'sick')"), std::string::npos) << r.output;
  r = Tether("lidar-degrade " + in + " -o " + P("x.log") + " --drop 1.5");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("--drop: '1.5' is outside its range [0, 1]"), std::string::npos) << r.output;
  r = Tether("lidar-degrade " + in + " -o " + P("x.log") + " --beams 1");
  EXPECT_EQ(r.code, 2) << r.output;
  r = Tether("lidar-degrade " + in + " -o " + P("x.log") + " --odometry wheel");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("--odometry takes auto, scan-line, interpolated or none"), std::string::npos) << r.output;
  r = Tether("lidar-degrade " + in + " -o " + P("x.log") + " --first-scan 30");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("beyond the log's 30 scans"), std::string::npos) << r.output;
  r = Tether("lidar-degrade " + in + " -o " + in);
  EXPECT_EQ(r.code, 2) << r.output;
  r = Tether("lidar-degrade " + P("none.clf") + " -o " + P("x.log"));
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_NE(r.output.find("cannot open the log"), std::string::npos) << r.output;
  Write("bad.clf", "FLASER 2 1 x 1 2 0.5 1 2 0.5 7 h 1\n");
  r = Tether("lidar-degrade " + P("bad.clf") + " -o " + P("x.log"));
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_NE(r.output.find(P("bad.clf") + ":1: FLASER"), std::string::npos) << r.output;
  r = Tether("lidar-degrade " + in + " -o " + P("no/such/dir/x.log"));
  EXPECT_EQ(r.code, 4) << r.output;
  EXPECT_FALSE(std::ifstream(P("x.log")).good());  // nothing written by the failures
}

}  // namespace
}  // namespace tether
