// The readers on the benchmark logs (../shared/datasets/lidar): scan counts, the first scan,
// the CARMEN log and the ROS bag of the same log giving the same trajectory, and the relations
// metric of the raw odometry and of the corrected logs. Skipped where the datasets are absent.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "testing/lidar_files.h"
#include "tether/frontends/lidar/eval/relations_metric.h"
#include "tether/frontends/lidar/io/carmen_reader.h"
#include "tether/frontends/lidar/io/lidar_log.h"
#include "tether/frontends/lidar/io/restamp.h"
#include "tether/frontends/lidar/io/rosbag_reader.h"

namespace tether {
namespace lidar {
namespace {

using testing::LidarDataset;

#define REQUIRE_DATASET(var, name)                                                                          \
  const std::string var = LidarDataset(name);                                                               \
  if (var.empty()) {                                                                                        \
    GTEST_SKIP() << "dataset lidar/" << (name) << " absent (../shared/datasets not beside the repository)"; \
  }

#define REQUIRE_BAGS()                      \
  if (!RosBagSupported()) {                 \
    GTEST_SKIP() << testing::kNoBagSupport; \
  }

struct LogFacts {
  const char* name;
  std::size_t scans, odometry, beams;
  double first_stamp;
  float first_ranges[3];
};

const LogFacts kLogs[] = {
    {"intel", 13631, 26915, 180, 976052857.337530, {1.07f, 1.07f, 1.08f}},
    {"aces", 7374, 7375, 180, 70.289900, {46.56f, 47.31f, 12.51f}},
    {"fr079", 4934, 8951, 360, 1211.520329, {1.67f, 1.65f, 1.64f}},
};

void PrintTo(const LogFacts& f, std::ostream* os) { *os << f.name; }

class RawLogTest : public ::testing::TestWithParam<LogFacts> {};

TEST_P(RawLogTest, CarmenLogHasItsScansAndOdometry) {
  const LogFacts& f = GetParam();
  REQUIRE_DATASET(path, std::string("raw/") + f.name + ".clf.gz");
  const LidarLog log = ReadLidarLog(path);
  EXPECT_EQ(log.format, LogFormat::kCarmen);
  ASSERT_EQ(log.scans.size(), f.scans);
  EXPECT_EQ(log.odometry.size(), f.odometry);
  const LaserScan& s = log.scans[0];
  EXPECT_EQ(s.ranges.size(), f.beams);
  EXPECT_DOUBLE_EQ(s.stamp, f.first_stamp);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(s.ranges[i], f.first_ranges[i]) << i;
  EXPECT_DOUBLE_EQ(s.angle_min, -M_PI / 2);
  EXPECT_NEAR(s.angle_increment * static_cast<double>(f.beams - 1), M_PI, 1e-12);
  for (const LaserScan& scan : log.scans) ASSERT_EQ(scan.odometry_origin, OdometryOrigin::kScanLine);
}

// The bags' /scan stamps are the CARMEN ipc_timestamps and their /odom the ODOM lines: with the
// odometry interpolated from those in both, the two sources give the same scans and trajectory.
TEST_P(RawLogTest, BagAndCarmenLogGiveTheSameTrajectory) {
  REQUIRE_BAGS();
  const LogFacts& f = GetParam();
  REQUIRE_DATASET(carmen_path, std::string("raw/") + f.name + ".clf.gz");
  REQUIRE_DATASET(bag_path, std::string("bags/") + f.name + ".bag");
  LidarReadOptions o;
  o.odometry = OdometrySource::kInterpolated;
  LidarLog carmen = ReadLidarLog(carmen_path, o);
  LidarLog bag = ReadLidarLog(bag_path, o);
  EXPECT_EQ(bag.format, LogFormat::kRosBag);
  ASSERT_EQ(bag.scans.size(), carmen.scans.size());
  EXPECT_EQ(bag.odometry.size(), carmen.odometry.size());
  EXPECT_EQ(bag.clamped_odometry, carmen.clamped_odometry);
  // The bag is in time order, the log in file order (the intel log is not sorted by time).
  const auto by_stamp = [](const LaserScan& a, const LaserScan& b) { return a.stamp < b.stamp; };
  std::stable_sort(carmen.scans.begin(), carmen.scans.end(), by_stamp);
  std::stable_sort(bag.scans.begin(), bag.scans.end(), by_stamp);
  double worst_stamp = 0, worst_position = 0, worst_angle = 0;
  std::size_t same_ranges = 0;
  for (std::size_t i = 0; i < bag.scans.size(); ++i) {
    const LaserScan& a = carmen.scans[i];
    const LaserScan& b = bag.scans[i];
    worst_stamp = std::max(worst_stamp, std::abs(a.stamp - b.stamp));
    worst_position = std::max(worst_position, (a.odometry.translation() - b.odometry.translation()).norm());
    worst_angle = std::max(worst_angle, std::abs(WrapAngle(a.odometry.theta() - b.odometry.theta())));
    same_ranges += a.ranges == b.ranges ? 1 : 0;
    EXPECT_NEAR(a.angle_increment, b.angle_increment, 1e-7);
  }
  EXPECT_LT(worst_stamp, 1e-6);  // ROS time (ns) against the log's microseconds, as doubles
  EXPECT_LT(worst_position, 1e-6);
  EXPECT_LT(worst_angle, 1e-6);
  EXPECT_EQ(same_ranges, bag.scans.size());
  EXPECT_GT(bag.scans[0].range_max, 0);
}

INSTANTIATE_TEST_SUITE_P(Logs, RawLogTest, ::testing::ValuesIn(kLogs),
                         [](const ::testing::TestParamInfo<LogFacts>& i) { return std::string(i.param.name); });

TEST(RawLogs, Fr079LaserSitsBehindTheRobotInTheLogButAheadInTheBag) {
  REQUIRE_DATASET(path, "raw/fr079.clf.gz");
  const LidarLog log = ReadLidarLog(path);
  // FLASER's laser pose is 0.04 m behind the odometry pose (PARAM robot_frontlaser_offset -0.04).
  EXPECT_NEAR(log.scans[0].laser_in_robot.x(), -0.04, 1e-5);
  EXPECT_NEAR(log.scans[0].laser_in_robot.y(), 0, 1e-5);
  REQUIRE_BAGS();
  REQUIRE_DATASET(bag_path, "bags/fr079.bag");
  // The bag's /tf_static says base_link -> laser +0.04 m: the sign differs from the log's.
  EXPECT_NEAR(ReadLidarLog(bag_path).scans[0].laser_in_robot.x(), 0.04, 1e-12);
}

// The raw odometry against the relations: every relation's stamps are scans of the log.
TEST(RelationsOnLogs, RawOdometry) {
  const struct {
    const char* name;
    std::size_t relations;
    double translation, rotation;
  } cases[] = {{"intel", 2984, 7.3702, 39.166}, {"aces", 1279, 0.5493, 2.328}, {"fr079", 1685, 6.5042, 30.292}};
  for (const auto& c : cases) {
    REQUIRE_DATASET(log_path, std::string("raw/") + c.name + ".clf.gz");
    REQUIRE_DATASET(rel_path, std::string("raw/") + c.name + ".relations");
    const RelationsResult r =
        EvaluateRelations(OdometryTrajectory(ReadLidarLog(log_path)), ReadRelationsFile(rel_path));
    EXPECT_EQ(r.relations, c.relations) << c.name;
    EXPECT_EQ(r.matched, c.relations) << c.name;
    EXPECT_EQ(r.max_stamp_difference, 0) << c.name;
    EXPECT_NEAR(r.translation.mean, c.translation, 1e-4) << c.name;
    EXPECT_NEAR(r.rotation.mean, c.rotation, 1e-3) << c.name;
  }
}

// The corrected logs carry the raw logs' logger timestamps (6 significant digits), not the ipc
// timestamps of the relations: as read, no relation matches; restamped from the raw log by
// their ranges, every scan is found.
TEST(RelationsOnLogs, CorrectedLogsNeedTheRawLogsStamps) {
  const struct {
    const char* raw;
    const char* corrected;
    std::size_t scans, scored;
  } cases[] = {{"intel", "intel", 910, 90}, {"aces", "aces", 440, 3}, {"fr079", "freiburg-079", 4791, 1672}};
  for (const auto& c : cases) {
    REQUIRE_DATASET(raw_path, std::string("raw/") + c.raw + ".clf.gz");
    REQUIRE_DATASET(rel_path, std::string("raw/") + c.raw + ".relations");
    REQUIRE_DATASET(cor_path, std::string("corrected/") + c.corrected + "-corrected.log.gz");
    const LidarLog corrected = ReadLidarLog(cor_path);
    ASSERT_EQ(corrected.scans.size(), c.scans) << c.raw;
    const std::vector<Relation> relations = ReadRelationsFile(rel_path);
    EXPECT_EQ(EvaluateRelations(OdometryTrajectory(corrected), relations).matched, 0u) << c.raw;
    const RestampResult restamped = RestampByReference(corrected, ReadLidarLog(raw_path), 0.011);
    EXPECT_EQ(restamped.by_ranges, c.scans) << c.raw;
    EXPECT_EQ(restamped.dropped, 0u) << c.raw;
    RelationsOptions exact;
    exact.tolerance = 0;
    const RelationsResult r = EvaluateRelations(restamped.poses, relations, exact);
    EXPECT_EQ(r.matched, c.scored) << c.raw;
    EXPECT_LT(r.translation.mean, 0.1) << c.raw;
    EXPECT_LT(r.rotation.mean, 1.0) << c.raw;
  }
}

}  // namespace
}  // namespace lidar
}  // namespace tether
