// The ROS 1 bag reader on the benchmark bags: topics by name, wrong topics and files that are
// not bags. Skipped (with the reason) where tether was built without bag support or the bags
// are absent.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "testing/lidar_files.h"
#include "testing/synthetic_room.h"
#include "testing/write_bag.h"
#include "tether/core/error.h"
#include "tether/frontends/lidar/io/lidar_log.h"
#include "tether/frontends/lidar/io/rosbag_reader.h"
#include "tether/frontends/lidar/lidar_slam_2d.h"

namespace tether {
namespace lidar {
namespace {

using testing::ErrorOf;

class RosBagTest : public testing::LidarFilesTest {
 protected:
  void SetUp() override {
    LidarFilesTest::SetUp();
    if (!RosBagSupported()) {
      GTEST_SKIP() << testing::kNoBagSupport;
    }
    bag_ = testing::LidarDataset("bags/aces.bag");
    if (bag_.empty())
      GTEST_SKIP() << "dataset lidar/bags/aces.bag absent (../shared/datasets not beside the repository)";
  }
  std::string bag_;
};

TEST_F(RosBagTest, ReadsScansAndOdometryOfTheNamedTopics) {
  EXPECT_EQ(DetectLogFormat(bag_), LogFormat::kRosBag);
  const LidarLog log = ReadRosBag(bag_);
  ASSERT_EQ(log.scans.size(), 7374u);
  EXPECT_EQ(log.odometry.size(), 7375u);
  const LaserScan& s = log.scans[0];
  EXPECT_NEAR(s.stamp, 70.2899, 1e-9);
  EXPECT_EQ(s.ranges.size(), 180u);
  EXPECT_EQ(s.ranges[0], 46.56f);
  EXPECT_NEAR(s.angle_min, -M_PI / 2, 1e-7);
  EXPECT_NEAR(s.range_max, 50, 1e-6);
  EXPECT_NEAR(s.range_min, 0.3, 1e-6);
  // No scan line: auto interpolates from /odom.
  EXPECT_EQ(s.odometry_origin, OdometryOrigin::kInterpolated);
  EXPECT_NEAR(s.odometry.theta(), -M_PI / 2, 1e-6);
  for (std::size_t i = 1; i < log.scans.size(); ++i) ASSERT_GE(log.scans[i].stamp, log.scans[i - 1].stamp);
}

TEST_F(RosBagTest, TopicsAreConfigurableAndCheckedByType) {
  LidarReadOptions o;
  o.scan_topic = "/base_scan";
  std::string m = ErrorOf<ParseError>([&] { ReadRosBag(bag_, o); });
  EXPECT_NE(m.find("no topic /base_scan; the bag has"), std::string::npos) << m;
  EXPECT_NE(m.find("/scan (sensor_msgs/LaserScan)"), std::string::npos) << m;
  o.scan_topic = "/odom";
  m = ErrorOf<ParseError>([&] { ReadRosBag(bag_, o); });
  EXPECT_NE(m.find("topic /odom holds nav_msgs/Odometry, not sensor_msgs/LaserScan"), std::string::npos) << m;
  o.scan_topic = "/scan";
  o.odom_topic = "/tf";
  m = ErrorOf<ParseError>([&] { ReadRosBag(bag_, o); });
  EXPECT_NE(m.find("topic /tf holds tf2_msgs/TFMessage, not nav_msgs/Odometry"), std::string::npos) << m;
  // An odometry topic that is not there: no odometry; auto leaves the scans without, interpolated refuses.
  o.odom_topic = "/wheel_odom";
  const LidarLog none = ReadRosBag(bag_, o);
  EXPECT_EQ(none.odometry.size(), 0u);
  EXPECT_EQ(none.scans.at(0).odometry_origin, OdometryOrigin::kNone);
  o.odometry = OdometrySource::kInterpolated;
  EXPECT_NE(ErrorOf<ParseError>([&] { ReadRosBag(bag_, o); }).find("no odometry messages"), std::string::npos);
  o = {};
  o.odometry = OdometrySource::kScanLine;
  EXPECT_NE(ErrorOf<ParseError>([&] { ReadRosBag(bag_, o); }).find("carries no odometry of its own"),
            std::string::npos);
}

TEST_F(RosBagTest, FilesThatAreNotBags) {
  const std::string text = Write("fake.bag", "#ROSBAG V2.0\nthis is not a bag");
  EXPECT_EQ(DetectLogFormat(text), LogFormat::kRosBag);
  std::string m = ErrorOf<ParseError>([&] { ReadLidarLog(text); });
  EXPECT_NE(m.find(text + ": not a readable ROS 1 bag"), std::string::npos) << m;
  const std::string empty = Write("empty.bag", "");
  LidarReadOptions o;
  o.format = LogFormat::kRosBag;
  m = ErrorOf<ParseError>([&] { ReadLidarLog(empty, o); });
  EXPECT_NE(m.find("not a readable ROS 1 bag"), std::string::npos) << m;
  EXPECT_NE(ErrorOf<IoError>([&] { ReadRosBag(P("none.bag")); }).find("cannot open the bag"), std::string::npos);
  // The first half of a real bag.
  std::string bytes;
  {
    std::ifstream in(bag_, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  const std::string cut = Write("cut.bag", bytes.substr(0, bytes.size() / 2));
  m = ErrorOf<ParseError>([&] { ReadRosBag(cut); });
  EXPECT_NE(m.find(cut + ":"), std::string::npos) << m;
}

// A ROS 1 bag record: header fields (4-byte length, "name=value"), then the data.
std::string BagRecord(const std::vector<std::string>& fields, const std::string& data) {
  const auto u32 = [](std::size_t v) {
    std::string b(4, '\0');
    for (int k = 0; k < 4; ++k) b[k] = static_cast<char>((v >> (8 * k)) & 0xff);
    return b;
  };
  std::string header;
  for (const std::string& f : fields) header += u32(f.size()) + f;
  return u32(header.size()) + header + u32(data.size()) + data;
}

// Lengths inside a bag made huge: refused by position before the bag library would allocate
// them (it read 8 GB before).
TEST(BagRecordCheck, DamagedLengthsAreRefusedBeforeAnythingIsAllocated) {
  const std::string message = BagRecord({std::string("op=\x02", 4), "conn=0000"}, std::string(40, 'x'));
  const std::string chunk =
      BagRecord({std::string("op=\x05", 4), "compression=none", "size=" + std::string("\x30\0\0\0", 4)}, message);
  const std::string good = "#ROSBAG V2.0\n" + BagRecord({std::string("op=\x03", 4)}, std::string(16, ' ')) + chunk;
  char tmpl[] = "/tmp/tether_bag_XXXXXX";
  ASSERT_NE(::mkdtemp(tmpl), nullptr);
  const std::string dir = tmpl;
  const auto write = [&](const std::string& name, const std::string& bytes) {
    std::ofstream(dir + "/" + name, std::ios::binary) << bytes;
    return dir + "/" + name;
  };
  EXPECT_NO_THROW(CheckBagRecords(write("good.bag", good)));
  // The message's data length inside the uncompressed chunk.
  std::string damaged = good;
  const std::size_t message_at = good.size() - message.size();
  const std::size_t data_len_at = message_at + 4 + (message.size() - 8 - 40);
  damaged[data_len_at + 3] = '\x7f';
  std::string m = ErrorOf<ParseError>([&] { CheckBagRecords(write("inner.bag", damaged)); });
  EXPECT_NE(m.find("inner.bag: not a readable ROS 1 bag (byte " + std::to_string(data_len_at)), std::string::npos) << m;
  EXPECT_NE(m.find("past its end"), std::string::npos) << m;
  EXPECT_NE(m.find("in the chunk at byte"), std::string::npos) << m;
  // A header field longer than its header.
  damaged = good;
  damaged[13 + 4 + 3] = '\x7f';
  m = ErrorOf<ParseError>([&] { CheckBagRecords(write("field.bag", damaged)); });
  EXPECT_NE(m.find("a header field claims"), std::string::npos) << m;
  // A chunk that claims 4 GB uncompressed.
  damaged = good;
  const std::size_t size_at = good.find("size=") + 5;
  damaged.replace(size_at, 4, "\xff\xff\xff\xff");
  m = ErrorOf<ParseError>([&] { CheckBagRecords(write("size.bag", damaged)); });
  EXPECT_NE(m.find("a chunk claims 4294967295 bytes uncompressed"), std::string::npos) << m;
  // Cut anywhere: refused, never read past the end.
  for (std::size_t n = 14; n < good.size(); n += 7) {
    EXPECT_THROW(CheckBagRecords(write("cut.bag", good.substr(0, n))), ParseError) << n;
  }
  std::filesystem::remove_all(dir);
}

// A bag with an IMU: a robot in a round room (5 m across; from its centre every heading looks
// the same) stands 1 s, turns 0.4 rad a scan for 15 scans at 10 Hz, and stands again; a gyro at
// 200 Hz reads 0.01 rad/s high.
class RosBagImuTest : public testing::LidarFilesTest {
 protected:
  void SetUp() override {
    LidarFilesTest::SetUp();
    if (!RosBagSupported()) GTEST_SKIP() << testing::kNoBagSupport;
    if (!testing::kCanWriteBags) GTEST_SKIP() << testing::kNoBagWriting;
    const testing::RoundRoomTurn turn = testing::TurnInARoundRoom();
    truth_ = turn.truth;
    scans_ = turn.scans;
    imu_ = turn.imu;
  }
  std::vector<double> truth_;
  std::vector<LaserScan> scans_;
  std::vector<ImuSample> imu_;
};

TEST_F(RosBagImuTest, TheYawRateIsReadAndTurnsTheScanOnlyPrediction) {
  const std::string bag = P("round.bag");
  testing::WriteBag(bag, scans_, imu_);
  // Without --imu-topic the IMU is not read.
  const LidarLog plain = ReadLidarLog(bag);
  EXPECT_TRUE(plain.imu.empty());
  EXPECT_FALSE(plain.scans.at(12).has_imu_yaw);
  LidarReadOptions o;
  o.imu_topic = "/imu";
  const LidarLog log = ReadLidarLog(bag, o);
  ASSERT_EQ(log.imu.samples.size(), imu_.size());
  EXPECT_NEAR(log.imu.samples[3].yaw_rate, 0.01, 1e-12);
  EXPECT_TRUE(log.imu.bias_estimated) << log.imu.bias_why;
  EXPECT_NEAR(log.imu.bias, 0.01, 1e-12);
  ASSERT_EQ(log.scans.size(), scans_.size());
  EXPECT_EQ(log.imu.scans_with_yaw, 40);
  for (std::size_t i = 0; i < log.scans.size(); ++i) {
    ASSERT_TRUE(log.scans[i].has_imu_yaw);
    EXPECT_NEAR(log.scans[i].imu_yaw, truth_[i], 0.011) << i;  // the trapezoid's ramp at the step
  }
  // Mapped scan-only: the IMU's turn holds the heading the scans cannot see.
  LidarSlamOptions so;
  so.pose_graph.loop_closure = false;
  so.pose_graph.threads = 0;
  so.self_check.sample_every = 0;
  double with = 0, without = 0;
  for (const LidarLog* l : {&log, &plain}) {
    LidarSlam2D slam(so);
    slam.Run(*l);
    const std::vector<StampedPose2> t = slam.Trajectory();
    for (std::size_t i = 0; i < t.size(); ++i) {
      double& worst = l == &log ? with : without;
      worst = std::max(worst, std::abs(WrapAngle(t[i].pose.theta() - truth_[i])));
    }
    if (l == &log) {
      EXPECT_EQ(slam.report().imu_turns, 39);
    }
  }
  EXPECT_LT(with, 0.15);
  EXPECT_GT(without, 1.0);
}

TEST_F(RosBagImuTest, AMissingOrMistypedImuTopicIsAnError) {
  const std::string bag = P("round.bag");
  testing::WriteBag(bag, scans_, imu_);
  LidarReadOptions o;
  o.imu_topic = "/gyro";
  std::string m = ErrorOf<ParseError>([&] { ReadLidarLog(bag, o); });
  EXPECT_NE(m.find("no topic /gyro; the bag has"), std::string::npos) << m;
  EXPECT_NE(m.find("/imu (sensor_msgs/Imu)"), std::string::npos) << m;
  EXPECT_NE(m.find("choose the IMU topic"), std::string::npos) << m;
  const std::string odometry = P("odometry_on_imu.bag");
  testing::WriteBag(odometry, scans_, imu_, "/imu", /*imu_as_odometry=*/true);
  o.imu_topic = "/imu";
  m = ErrorOf<ParseError>([&] { ReadLidarLog(odometry, o); });
  EXPECT_NE(m.find("topic /imu holds nav_msgs/Odometry, not sensor_msgs/Imu"), std::string::npos) << m;
  // A gyro reading beyond any robot's.
  std::vector<ImuSample> wild = imu_;
  wild[5].yaw_rate = 1e6;
  const std::string damaged = P("wild.bag");
  testing::WriteBag(damaged, scans_, wild);
  m = ErrorOf<ParseError>([&] { ReadLidarLog(damaged, o); });
  EXPECT_NE(m.find("angular_velocity.z 1e+06 rad/s is not finite or beyond 1000"), std::string::npos) << m;
  // Turning from the start: no bias taken off, and why.
  std::vector<ImuSample> turning = imu_;
  for (ImuSample& s : turning) s.yaw_rate += 0.5;
  const std::string spinning = P("spinning.bag");
  testing::WriteBag(spinning, scans_, turning);
  const LidarLog log = ReadLidarLog(spinning, o);
  EXPECT_FALSE(log.imu.bias_estimated);
  EXPECT_NE(log.imu.bias_why.find("the robot turned in the first 1 s"), std::string::npos) << log.imu.bias_why;
}

TEST(RosBagSupport, WithoutItTheReaderSaysHowToGetIt) {
  if (RosBagSupported()) GTEST_SKIP() << "built with ROS 1 bag support: the fallback is not compiled";
  const std::string m = ErrorOf<InvalidArgument>([] { ReadRosBag("x.bag"); });
  EXPECT_NE(m.find("built without ROS 1 bag support"), std::string::npos) << m;
}

}  // namespace
}  // namespace lidar
}  // namespace tether
