// tether lidar: a CARMEN log of a simulated room in, trajectory, pose graph and map out; usage
// and input errors.
#include "tether/tools/lidar_slam.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>

#include "testing/cli.h"
#include "testing/lidar_files.h"
#include "testing/synthetic_room.h"
#include "testing/write_bag.h"
#include "tether/core/graph_io.h"
#include "tether/factors/builtin.h"
#include "tether/frontends/lidar/io/rosbag_reader.h"
#include "tether/frontends/lidar/io/tum_trajectory.h"
#include "tether/frontends/lidar/lidar_slam_2d.h"

namespace tether {
namespace {

using testing::Tether;

class LidarSlamTest : public testing::LidarFilesTest {};

std::string Bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// 80 scans on a circle in a 24 m x 18 m room with boxes: FLASER lines (180 beams over 180
// degrees), odometry = truth.
std::string RoomLog() {
  std::vector<testing::Segment> world;
  testing::AddRectangle(0, 0, 24, 18, &world);
  testing::AddRectangle(3, 3, 4, 5, &world);
  testing::AddRectangle(11, 8, 13, 10.5, &world);
  testing::AddRectangle(18, 14, 19, 16, &world);
  std::ostringstream log;
  log.precision(10);
  for (int k = 0; k < 80; ++k) {
    const double a = 2 * M_PI * k / 80.0;
    const SE2d pose(12 + 5 * std::sin(a), 9 - 5 * std::cos(a), a);
    const std::vector<double> ranges = testing::RayCastScan(world, pose, 180, -M_PI / 2, M_PI / 179);
    log << "FLASER 180";
    for (double r : ranges) log << " " << (std::isfinite(r) ? r : 81.9);
    log << " " << pose.x() << " " << pose.y() << " " << pose.theta() << " " << pose.x() << " " << pose.y() << " "
        << pose.theta() << " " << 1000.0 + k * 0.2 << " sim " << k * 0.2 << "\n";
  }
  return log.str();
}

TEST_F(LidarSlamTest, WritesTrajectoryGraphAndMap) {
  const std::string log = Write("room.log", RoomLog());
  const auto run = Tether("lidar " + log + " -o " + P("out") + " --scans-per-submap 20 --threads 2 --search-every 3");
  ASSERT_EQ(run.code, 0) << run.output;
  EXPECT_NE(run.output.find("scans 80, submaps "), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("real-time factor"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("; kept by the solution "), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("odometry: yes"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("self-check: "), std::string::npos) << run.output;
  // One pose per scan, with the scans' stamps, near the truth. (Odometry is perfect here; how
  // closely local SLAM's matching keeps to it is its own tests' business: this checks the
  // plumbing.)
  const std::vector<lidar::StampedPose2> t = lidar::ReadTumFile(P("out/trajectory.tum"));
  ASSERT_EQ(t.size(), 80u);
  for (int k = 0; k < 80; ++k) {
    const double a = 2 * M_PI * k / 80.0;
    EXPECT_DOUBLE_EQ(t[static_cast<std::size_t>(k)].stamp, 1000.0 + k * 0.2);
    EXPECT_LT(
        (t[static_cast<std::size_t>(k)].pose.translation() - Eigen::Vector2d(12 + 5 * std::sin(a), 9 - 5 * std::cos(a)))
            .norm(),
        1.0)
        << k;
  }
  // The graph reads back (80 scans and the submaps) and is at its optimum.
  const GraphFile g = ReadGraphFile(P("out/pose_graph.g2o"), DefaultRegistry());
  EXPECT_GT(g.values.size(), 80u);
  EXPECT_GT(g.graph.size(), 80u);
  const GraphFile trajectory = ReadGraphFile(P("out/trajectory.g2o"), DefaultRegistry());
  EXPECT_EQ(trajectory.values.size(), 80u);
  // The map: PGM header, YAML naming it, a PNG.
  std::ifstream pgm(P("out/map.pgm"), std::ios::binary);
  std::string magic;
  pgm >> magic;
  EXPECT_EQ(magic, "P5");
  std::ifstream yaml(P("out/map.yaml"));
  std::stringstream y;
  y << yaml.rdbuf();
  EXPECT_NE(y.str().find("image: map.pgm"), std::string::npos);
  std::ifstream png(P("out/map.png"), std::ios::binary);
  std::string sig(8, '\0');
  png.read(&sig[0], 8);
  EXPECT_EQ(sig, std::string("\x89PNG\r\n\x1a\n"));
  // Every loop closure with its violation by the final solution: as many lines as the summary
  // counts, each "kept" exactly where it is violated by less than 20 cm and 1 degree, and as
  // many kept as the summary says.
  const std::size_t at = run.output.find("loop closures ");
  ASSERT_NE(at, std::string::npos) << run.output;
  const long closures = std::stol(run.output.substr(at + 14));
  EXPECT_GT(closures, 0) << run.output;  // the lap's end meets its start
  const std::size_t kept_at = run.output.find("% (");
  ASSERT_NE(kept_at, std::string::npos) << run.output;
  const long kept = std::stol(run.output.substr(kept_at + 3));
  std::ifstream lines(P("out/loop_closures.txt"));
  std::string line;
  ASSERT_TRUE(std::getline(lines, line));
  EXPECT_EQ(line.rfind("# scan submap score", 0), 0u) << line;
  long rows = 0, kept_rows = 0;
  while (std::getline(lines, line)) {
    std::istringstream f(line);
    double v[12];
    for (double& x : v) ASSERT_TRUE(f >> x) << line;
    ++rows;
    EXPECT_GT(v[2], 0.55) << line;  // the score
    EXPECT_EQ(v[11] == 1, v[9] < 0.2 && v[10] < 1) << line;
    kept_rows += v[11] == 1 ? 1 : 0;
  }
  EXPECT_EQ(rows, closures);
  EXPECT_EQ(kept_rows, kept);
}

std::string FileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The command is LidarSlam2D and printing: the library's files are the command's, byte for
// byte, whatever the threads.
TEST_F(LidarSlamTest, TheCommandWritesTheLibrarysFiles) {
  const std::string log = Write("room.log", RoomLog());
  const auto run = Tether("lidar " + log + " -o " + P("cli") + " --scans-per-submap 20 --threads 1 --search-every 3");
  ASSERT_EQ(run.code, 0) << run.output;
  lidar::LidarSlamOptions options;
  options.local.submaps.scans_per_submap = 20;
  options.pose_graph.search_every_n_scans = 3;
  options.pose_graph.threads = 3;
  lidar::LidarSlam2D slam(options);
  slam.Run(lidar::ReadLidarLog(log));
  for (const lidar::LidarOutput& o : slam.Outputs()) {
    EXPECT_EQ(FileBytes(P("cli/" + o.name)), o.bytes) << o.name;
  }
}

TEST_F(LidarSlamTest, TheLaserOffsetReplacesTheLogs) {
  const std::string log = Write("room.log", RoomLog());
  const auto run = Tether("lidar " + log + " -o " + P("off") + " --laser-offset 0.5,0,0 --max-scans 30");
  ASSERT_EQ(run.code, 0) << run.output;
  EXPECT_NE(run.output.find("laser on the robot at (0.500 m, 0.000 m, 0.0 deg)"), std::string::npos) << run.output;
  EXPECT_EQ(Tether("lidar " + log + " -o " + P("off2") + " --laser-offset 0.5,0").code, 2);
  EXPECT_EQ(Tether("lidar " + log + " -o " + P("off3") + " --laser-offset 0.5,nan,0").code, 2);
}

// A simulated office without odometry, scored against its truth by --ground-truth.
TEST_F(LidarSlamTest, ScanOnlySimulatedOfficeAgainstItsTruth) {
  const auto sim = Tether("simulate lidar -o " + P("office.log") + " --truth " + P("office.tum") +
                          " --seed 2 --scans 600 --no-odometry");
  ASSERT_EQ(sim.code, 0) << sim.output;
  const auto run = Tether("lidar " + P("office.log") + " -o " + P("office") + " --ground-truth " + P("office.tum"));
  ASSERT_EQ(run.code, 0) << run.output;
  EXPECT_NE(run.output.find("odometry: none"), std::string::npos) << run.output;
  const std::size_t at = run.output.find("absolute trajectory error (rigid alignment) ");
  ASSERT_NE(at, std::string::npos) << run.output;
  const double ate = std::stod(run.output.substr(at + 44));
  EXPECT_LT(ate, 0.05) << run.output;
  EXPECT_NE(run.output.find("over 600 poses"), std::string::npos) << run.output;
  const auto missing = Tether("lidar " + P("office.log") + " -o " + P("office2") + " --ground-truth " + P("none.tum"));
  EXPECT_EQ(missing.code, 1) << missing.output;
  EXPECT_NE(missing.output.find("none.tum"), std::string::npos) << missing.output;
}

// A bag whose odometry topic is mistyped (or absent) maps scan-only, and says so.
TEST_F(LidarSlamTest, ABagWithoutMessagesOnTheOdometryTopicWarns) {
  const std::string bag = testing::LidarDataset("bags/aces.bag");
  if (bag.empty()) GTEST_SKIP() << "dataset lidar/bags/aces.bag absent (../shared/datasets not beside the repository)";
  if (!lidar::RosBagSupported()) GTEST_SKIP() << testing::kNoBagSupport;
  const auto r = Tether("lidar " + bag + " -o " + P("bag_out") + " -q --max-scans 30 --odom-topic /odomx");
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("has no message on the odometry topic /odomx: mapping scan-only"), std::string::npos)
      << r.output;
  const auto quiet = Tether("lidar " + bag + " -o " + P("bag_out2") + " -q --max-scans 30 --odometry none");
  EXPECT_EQ(quiet.output.find("warning"), std::string::npos) << quiet.output;
}

// The bag reader's ROS part is a module loaded beside libtether_frontends at the first bag read:
// where it is missing, reading a bag fails with exit 1 naming the module and what to do, and a
// CARMEN log still reads. (A copy of libtether_frontends in a folder without the module, found
// first through LD_LIBRARY_PATH, stands for an installation that lost it.)
TEST_F(LidarSlamTest, AMissingBagModuleIsAClearError) {
  const std::string bag = testing::LidarDataset("bags/fr079.bag");
  if (bag.empty()) GTEST_SKIP() << "dataset lidar/bags/fr079.bag absent (../shared/datasets not beside the repository)";
  if (!lidar::RosBagSupported()) GTEST_SKIP() << testing::kNoBagSupport;
  const std::filesystem::path lib =
      std::filesystem::path(TETHER_CLI).parent_path().parent_path() / "frontends" / "libtether_frontends.so";
  if (!std::filesystem::exists(lib)) GTEST_SKIP() << lib << " absent (not a build tree)";
  const std::filesystem::path lone = P("lone");
  std::filesystem::create_directories(lone);
  std::filesystem::copy_file(lib, lone / lib.filename());
  const std::string env = "LD_LIBRARY_PATH=" + lone.string();
  const auto r = Tether("lidar " + bag + " -o " + P("no_module") + " -q --max-scans 5", env);
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_NE(r.output.find("ROS 1 bag support could not be loaded: " + (lone / "libtether_rosbag.so").string()),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("rebuild tether"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(P("no_module") + "/trajectory.tum"));
  const auto carmen = Tether("lidar " + Write("room.log", RoomLog()) + " -o " + P("carmen") + " -q --max-scans 5", env);
  EXPECT_EQ(carmen.code, 0) << carmen.output;
}

// The scanner's class: chosen from the log (FLASER lines: 80 m, sick, the defaults), given by
// --sensor, and explicit flags kept over the preset's values.
TEST_F(LidarSlamTest, TheSensorClassFromTheLogOrTheFlag) {
  const std::string log = Write("room.log", RoomLog());
  const auto autod = Tether("lidar " + log + " -o " + P("auto") + " --threads 0");
  ASSERT_EQ(autod.code, 0) << autod.output;
  EXPECT_NE(autod.output.find("scanner: sick (maximum range 80.0 m, over 40 m: a SICK-class scanner's; "),
            std::string::npos)
      << autod.output;
  EXPECT_NE(autod.output.find("; no body mask\n"), std::string::npos) << autod.output;
  const auto sick = Tether("lidar " + log + " -o " + P("sick") + " --threads 0 --sensor sick");
  ASSERT_EQ(sick.code, 0) << sick.output;
  EXPECT_NE(sick.output.find("scanner: sick (given by --sensor;"), std::string::npos) << sick.output;
  for (const char* f : {"trajectory.tum", "map.pgm", "pose_graph.g2o"}) {
    EXPECT_EQ(Bytes(P("auto") + "/" + f), Bytes(P("sick") + "/" + f)) << f;
  }
  // lds: its minimum range; --min-range given keeps its own, as does --mask-angles.
  const auto lds = Tether("lidar " + log + " -o " + P("lds") + " --threads 0 --sensor lds");
  ASSERT_EQ(lds.code, 0) << lds.output;
  EXPECT_NE(lds.output.find("scanner: lds (given by --sensor; a low-cost 360-degree scanner"), std::string::npos)
      << lds.output;
  EXPECT_NE(lds.output.find("body mask: returns nearer than 0.15 m\n"), std::string::npos) << lds.output;
  const auto own = Tether("lidar " + log + " -o " + P("own") + " --threads 0 --sensor lds --min-range 0");
  ASSERT_EQ(own.code, 0) << own.output;
  EXPECT_NE(own.output.find("; no body mask\n"), std::string::npos) << own.output;
  const auto masked =
      Tether("lidar " + log + " -o " + P("masked") + " --threads 0 --min-range 0.3 --mask-angles 80:100,-100:-80");
  ASSERT_EQ(masked.code, 0) << masked.output;
  EXPECT_NE(masked.output.find("body mask: returns nearer than 0.3 m and at 80:100,-100:-80 degrees"),
            std::string::npos)
      << masked.output;
  EXPECT_NE(masked.output.find("the body mask made "), std::string::npos) << masked.output;
  // Bad values, refused before anything is written.
  const struct {
    const char* option;
    const char* message;
  } bad[] = {
      {"--sensor velodyne", "--sensor velodyne is not one of auto, lds, sick or hokuyo"},
      {"--mask-angles 10:10", "--mask-angles 10:10: the sector '10:10' has no width"},
      {"--mask-angles 160-200", "'160-200' is not a sector from:to"},
      {"--mask-angles 1:x", "'x' in the sector '1:x' is not a finite number of degrees"},
      {"--min-range -1", "--min-range: '-1' is outside"},
      {"--imu-bias-seconds -1", "--imu-bias-seconds: '-1' is outside"},
  };
  for (const auto& b : bad) {
    const auto r = Tether("lidar " + log + " -o " + P("bad") + " " + b.option);
    EXPECT_EQ(r.code, 2) << b.option << ": " << r.output;
    EXPECT_NE(r.output.find(b.message), std::string::npos) << b.option << ": " << r.output;
    EXPECT_FALSE(std::filesystem::exists(P("bad"))) << b.option << ": nothing is written";
  }
  // A minimum range above the log's maximum leaves nothing to map: refused by the options.
  const auto beyond = Tether("lidar " + log + " -o " + P("beyond") + " --min-range 0.5 --max-range 0.4");
  EXPECT_NE(beyond.code, 0) << beyond.output;
  // An IMU topic for a CARMEN log.
  const auto imu = Tether("lidar " + log + " -o " + P("imu") + " --imu-topic /imu");
  EXPECT_EQ(imu.code, 1) << imu.output;
  EXPECT_NE(imu.output.find("an IMU topic (/imu) is for ROS bags; a CARMEN log has no IMU messages"), std::string::npos)
      << imu.output;
  EXPECT_FALSE(std::filesystem::exists(P("imu")));
}

// An LDS-class simulated scanner (6 m): auto picks lds.
TEST_F(LidarSlamTest, AutoPicksLdsForALowCostScanner) {
  const auto sim =
      Tether("simulate lidar -o " + P("lds.log") + " --truth " + P("lds.tum") + " --seed 3 --scans 300 --preset lds");
  ASSERT_EQ(sim.code, 0) << sim.output;
  const auto run = Tether("lidar " + P("lds.log") + " -o " + P("lds") + " --ground-truth " + P("lds.tum"));
  ASSERT_EQ(run.code, 0) << run.output;
  EXPECT_NE(run.output.find("scanner: lds (maximum range 6.0 m, at most 16 m: a low-cost scanner's;"),
            std::string::npos)
      << run.output;
}

// A bag with an IMU topic: read where named (and said at the start), an error where missing.
TEST_F(LidarSlamTest, AnImuTopicIsReadWhereNamed) {
  if (!lidar::RosBagSupported()) GTEST_SKIP() << testing::kNoBagSupport;
  if (!testing::kCanWriteBags) GTEST_SKIP() << testing::kNoBagWriting;
  std::vector<testing::Segment> world;
  testing::AddRectangle(0, 0, 8, 6, &world);
  testing::AddRectangle(2, 2, 3, 3, &world);
  std::vector<lidar::LaserScan> scans;
  std::vector<lidar::ImuSample> imu;
  for (int k = 0; k < 30; ++k) {
    lidar::LaserScan s;
    s.stamp = 5 + 0.1 * k;
    s.angle_min = -M_PI;
    s.angle_increment = 2 * M_PI / 360;
    s.range_max = 10;
    for (double r : testing::RayCastScan(world, SE2d(5, 3, 0.05 * k), 360, s.angle_min, s.angle_increment)) {
      s.ranges.push_back(static_cast<float>(r));
    }
    scans.push_back(std::move(s));
  }
  for (int k = 0; k <= 300; ++k) imu.push_back({5 + 0.01 * k, 0.5});
  const std::string bag = P("turn.bag");
  testing::WriteBag(bag, scans, imu);
  const auto run = Tether("lidar " + bag + " -o " + P("turn") + " --imu-topic /imu --threads 0");
  ASSERT_EQ(run.code, 0) << run.output;
  EXPECT_NE(run.output.find("IMU: 301 messages, a heading for 30 of 30 scans; no bias taken off (the robot turned"),
            std::string::npos)
      << run.output;
  EXPECT_NE(run.output.find("it turns the scans without odometry"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find(", 29 turned by the IMU"), std::string::npos) << run.output;
  const auto missing = Tether("lidar " + bag + " -o " + P("gyro") + " --imu-topic /gyro");
  EXPECT_EQ(missing.code, 1) << missing.output;
  EXPECT_NE(missing.output.find("no topic /gyro; the bag has"), std::string::npos) << missing.output;
  EXPECT_NE(missing.output.find("choose the IMU topic"), std::string::npos) << missing.output;
  EXPECT_FALSE(std::filesystem::exists(P("gyro")));
}

TEST_F(LidarSlamTest, UsageAndInputErrors) {
  const std::string log = Write("room.log", RoomLog());
  EXPECT_EQ(Tether("lidar " + log).code, 2);  // -o is required
  EXPECT_EQ(Tether("lidar " + log + " -o " + P("o") + " --search-every 0").code, 2);
  const auto huber = Tether("lidar " + log + " -o " + P("o") + " --huber -1");
  EXPECT_EQ(huber.code, 2);
  EXPECT_NE(huber.output.find("--huber: '-1' is outside its range"), std::string::npos) << huber.output;
  const auto rival = Tether("lidar " + log + " -o " + P("o") + " --rival-ratio 1.5");
  EXPECT_EQ(rival.code, 2);
  EXPECT_NE(rival.output.find("--rival-ratio: '1.5' is outside its range [0, 1]"), std::string::npos) << rival.output;
  EXPECT_EQ(Tether("lidar " + log + " -o " + P("o") + " --local-sigma-t 0").code, 2);
  // Local matching's and the search window's options: out of their range, refused by name while
  // the command line is parsed; in range but inconsistent, by LocalSlamOptions::IsValid and
  // PoseGraphOptions::IsValid. Either way before anything is written.
  const struct {
    const char* option;
    const char* field;
  } local[] = {{"--min-match-probability 1.5", "--min-match-probability: '1.5' is outside its range"},
               {"--correlative-rotation-weight -1", "--correlative-rotation-weight: '-1' is outside"},
               {"--correlative-angle -5", "--correlative-angle: '-5' is outside"},
               {"--match-rotation-weight 0", "rotation"},
               {"--still-angle -1", "--still-angle: '-1' is outside"},
               {"--search-window -1", "--search-window: '-1' is outside"},
               {"--search-angle 200", "--search-angle: '200' is outside its range [0, 180]"},
               {"--search-voxel -1", "--search-voxel: '-1' is outside"},
               {"--search-window-growth -0.1", "--search-window-growth: '-0.1' is outside"},
               {"--max-search-window nan", "--max-search-window: 'nan' is not a finite number"},
               {"--max-search-angle 4", "--max-search-angle: '4' is outside"},
               {"--search-angle-growth -1", "--search-angle-growth: '-1' is outside"},
               {"--consecutive-sigma-r 0", "consecutive_rotation_sigma (--consecutive-sigma-r) must both be positive"},
               {"--local-huber -1", "--local-huber: '-1' is outside"}};
  for (const auto& l : local) {
    const auto r = Tether("lidar " + log + " -o " + P("o_local") + " " + l.option);
    EXPECT_EQ(r.code, 2) << l.option << ": " << r.output;
    EXPECT_NE(r.output.find(l.field), std::string::npos) << l.option << ": " << r.output;
    EXPECT_FALSE(std::filesystem::exists(P("o_local"))) << l.option << ": nothing is written";
  }
  const auto missing = Tether("lidar " + P("nothing.log") + " -o " + P("o"));
  EXPECT_EQ(missing.code, 1) << missing.output;
  EXPECT_NE(missing.output.find("nothing.log"), std::string::npos) << missing.output;
  const auto bad = Tether("lidar " + Write("bad.log", "FLASER 3 1 2\n") + " -o " + P("o"));
  EXPECT_EQ(bad.code, 1) << bad.output;
  EXPECT_NE(bad.output.find("bad.log:1"), std::string::npos) << bad.output;
  // An output folder that cannot be made.
  const std::string file = Write("plain", "x");
  EXPECT_EQ(Tether("lidar " + log + " -o " + file + "/sub").code, 4);
}

}  // namespace
}  // namespace tether
