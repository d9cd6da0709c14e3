// The ROS 1 bag reader on the benchmark bags: topics by name, wrong topics and files that are
// not bags. Skipped (with the reason) where tether was built without bag support or the bags
// are absent.
#include <gtest/gtest.h>

#include "testing/lidar_files.h"
#include "tether/core/error.h"
#include "tether/frontends/lidar/lidar_log.h"
#include "tether/frontends/lidar/rosbag_reader.h"

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

TEST(RosBagSupport, WithoutItTheReaderSaysHowToGetIt) {
  if (RosBagSupported()) GTEST_SKIP() << "built with ROS 1 bag support: the fallback is not compiled";
  const std::string m = ErrorOf<InvalidArgument>([] { ReadRosBag("x.bag"); });
  EXPECT_NE(m.find("built without ROS 1 bag support"), std::string::npos) << m;
}

}  // namespace
}  // namespace lidar
}  // namespace tether
