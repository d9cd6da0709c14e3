#pragma once
// Small ROS 1 bags written in tests with the bag library tether reads them with: scans
// (sensor_msgs/LaserScan on /scan) and an IMU's yaw rate (sensor_msgs/Imu). Only where the tests
// were built with the library (TETHER_TEST_WRITE_BAGS, set by tests/CMakeLists.txt where bag
// support is on); callers skip otherwise.
#include <string>
#include <vector>

#include "tether/frontends/lidar/sensor/imu_yaw.h"
#include "tether/frontends/lidar/sensor/laser_scan.h"

#ifdef TETHER_TEST_WRITE_BAGS
#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/LaserScan.h>
#endif

namespace tether {
namespace testing {

#ifdef TETHER_TEST_WRITE_BAGS
constexpr bool kCanWriteBags = true;

/// Writes `scans` on /scan (frame "laser") and `imu` on `imu_topic` (sensor_msgs/Imu, or
/// nav_msgs/Odometry where `imu_as_odometry`: a topic of the wrong type).
inline void WriteBag(const std::string& path, const std::vector<lidar::LaserScan>& scans,
                     const std::vector<lidar::ImuSample>& imu, const std::string& imu_topic = "/imu",
                     bool imu_as_odometry = false) {
  rosbag::Bag bag(path, rosbag::bagmode::Write);
  for (const lidar::LaserScan& s : scans) {
    sensor_msgs::LaserScan m;
    m.header.stamp = ros::Time(s.stamp);
    m.header.frame_id = "laser";
    m.angle_min = static_cast<float>(s.angle_min);
    m.angle_increment = static_cast<float>(s.angle_increment);
    m.angle_max = static_cast<float>(s.angle_min + s.angle_increment * static_cast<double>(s.ranges.size() - 1));
    m.range_min = static_cast<float>(s.range_min);
    m.range_max = static_cast<float>(s.range_max);
    m.ranges = s.ranges;
    bag.write("/scan", m.header.stamp, m);
  }
  for (const lidar::ImuSample& i : imu) {
    if (imu_as_odometry) {
      nav_msgs::Odometry m;
      m.header.stamp = ros::Time(i.stamp);
      m.pose.pose.orientation.w = 1;
      bag.write(imu_topic, m.header.stamp, m);
      continue;
    }
    sensor_msgs::Imu m;
    m.header.stamp = ros::Time(i.stamp);
    m.header.frame_id = "imu";
    m.orientation.w = 1;
    m.angular_velocity.z = i.yaw_rate;
    bag.write(imu_topic, m.header.stamp, m);
  }
  bag.close();
}
#else
constexpr bool kCanWriteBags = false;
inline void WriteBag(const std::string&, const std::vector<lidar::LaserScan>&, const std::vector<lidar::ImuSample>&,
                     const std::string& = "/imu", bool = false) {}
#endif

/// Why a test that writes bags skips.
constexpr const char* kNoBagWriting =
    "the tests were built without the ROS 1 bag library (TETHER_WITH_ROSBAG=OFF): no bag can be written";

}  // namespace testing
}  // namespace tether
