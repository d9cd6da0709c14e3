// The part of the ROS 1 bag reader that needs the ROS libraries, built as its own module
// (libtether_rosbag.so) that rosbag_reader.cc loads at the first bag read: a program that never
// reads a bag never loads the bag library and what it pulls in (Python, boost and some twenty
// other libraries), which made up most of every tether command's start-up.
#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/LaserScan.h>

#include <cmath>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "tether/core/error.h"
#include "tether/core/registry.h"
#include "tether/frontends/lidar/io/rosbag_reader.h"
#include "tether/frontends/lidar/sensor/laser_scan.h"

namespace tether {
namespace lidar {
namespace {

double Yaw(double x, double y, double z, double w) { return std::atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)); }

std::string MessageWhere(const std::string& path, long index, const std::string& topic) {
  return path + ": message " + std::to_string(index) + " on " + topic + ": ";
}

// /tf_static is a tf2_msgs/TFMessage: a sequence of geometry_msgs/TransformStamped, read here
// without tf2_msgs' headers. Returns the first transform whose child frame is `child`.
bool FindStaticTransform(const rosbag::MessageInstance& m, const std::string& child, SE2<double>* out) {
  std::vector<std::uint8_t> buf(m.size());
  ros::serialization::OStream os(buf.data(), static_cast<std::uint32_t>(buf.size()));
  m.write(os);
  ros::serialization::IStream is(buf.data(), static_cast<std::uint32_t>(buf.size()));
  std::uint32_t n = 0;
  is >> n;
  for (std::uint32_t i = 0; i < n; ++i) {
    geometry_msgs::TransformStamped t;
    ros::serialization::deserialize(is, t);
    if (t.child_frame_id == child || (!child.empty() && child[0] != '/' && t.child_frame_id == "/" + child)) {
      const auto& q = t.transform.rotation;
      *out = SE2<double>(t.transform.translation.x, t.transform.translation.y, Yaw(q.x, q.y, q.z, q.w));
      return true;
    }
  }
  return false;
}

// Reads the bag's messages into *out (scans, odometry, IMU samples, the laser's mounting).
void ReadBagMessages(const std::string& path, const LidarReadOptions& options, LidarLog* out) {
  LidarLog& log = *out;
  rosbag::Bag bag;
  try {
    bag.open(path, rosbag::bagmode::Read);
  } catch (const std::exception& e) {
    throw ParseError(path + ": not a readable ROS 1 bag (" + e.what() + ")");
  }
  std::string laser_frame;
  long index = 0;
  try {
    std::vector<std::string> topics = {options.scan_topic, options.odom_topic, "/tf_static"};
    if (!options.imu_topic.empty()) topics.push_back(options.imu_topic);
    rosbag::View view(bag, rosbag::TopicQuery(topics));
    bool scan_topic_seen = false, imu_topic_seen = false;
    for (const rosbag::ConnectionInfo* c : view.getConnections()) {
      if (!options.imu_topic.empty() && c->topic == options.imu_topic) {
        imu_topic_seen = true;
        if (c->datatype != "sensor_msgs/Imu") {
          throw ParseError(path + ": topic " + options.imu_topic + " holds " + c->datatype + ", not sensor_msgs/Imu");
        }
      }
      if (c->topic == options.scan_topic) {
        scan_topic_seen = true;
        if (c->datatype != "sensor_msgs/LaserScan") {
          throw ParseError(path + ": topic " + options.scan_topic + " holds " + c->datatype +
                           ", not sensor_msgs/LaserScan");
        }
      }
      if (c->topic == options.odom_topic && c->datatype != "nav_msgs/Odometry") {
        throw ParseError(path + ": topic " + options.odom_topic + " holds " + c->datatype + ", not nav_msgs/Odometry");
      }
    }
    if (!scan_topic_seen || (!options.imu_topic.empty() && !imu_topic_seen)) {
      std::string have;
      rosbag::View all(bag);
      for (const rosbag::ConnectionInfo* c : all.getConnections()) have += " " + c->topic + " (" + c->datatype + ")";
      const bool scan = !scan_topic_seen;
      throw ParseError(path + ": no topic " + (scan ? options.scan_topic : options.imu_topic) + "; the bag has" +
                       (have.empty() ? " none" : have) + (scan ? "; choose the scan topic" : "; choose the IMU topic"));
    }
    std::vector<std::pair<long, rosbag::MessageInstance>> statics;
    for (const rosbag::MessageInstance& m : view) {
      ++index;
      if (m.getTopic() == options.scan_topic) {
        const sensor_msgs::LaserScan::ConstPtr msg = m.instantiate<sensor_msgs::LaserScan>();
        if (!msg) throw ParseError(MessageWhere(path, index, m.getTopic()) + "not a sensor_msgs/LaserScan");
        LaserScan s;
        s.stamp = msg->header.stamp.toSec();
        s.logger_stamp = s.stamp;
        s.angle_min = msg->angle_min;
        s.angle_increment = msg->angle_increment;
        s.range_min = msg->range_min;
        s.range_max = msg->range_max;
        s.ranges = msg->ranges;
        s.source_index = index;
        const std::string why = ScanProblem(s);
        if (!why.empty()) throw ParseError(MessageWhere(path, index, m.getTopic()) + why);
        if (laser_frame.empty()) laser_frame = msg->header.frame_id;
        log.scans.push_back(std::move(s));
      } else if (m.getTopic() == options.odom_topic) {
        const nav_msgs::Odometry::ConstPtr msg = m.instantiate<nav_msgs::Odometry>();
        if (!msg) throw ParseError(MessageWhere(path, index, m.getTopic()) + "not a nav_msgs/Odometry");
        const auto& p = msg->pose.pose.position;
        const auto& q = msg->pose.pose.orientation;
        const double norm = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !(std::abs(norm - 1) < 0.1)) {
          throw ParseError(MessageWhere(path, index, m.getTopic()) +
                           "non-finite position or a quaternion far from unit length");
        }
        const double yaw = Yaw(q.x, q.y, q.z, q.w);
        std::string why = PoseProblem(p.x, p.y, yaw);
        if (why.empty()) why = StampProblem(msg->header.stamp.toSec());
        if (!why.empty()) throw ParseError(MessageWhere(path, index, m.getTopic()) + why);
        log.odometry.Add(msg->header.stamp.toSec(), SE2<double>(p.x, p.y, yaw));
      } else if (!options.imu_topic.empty() && m.getTopic() == options.imu_topic) {
        const sensor_msgs::Imu::ConstPtr msg = m.instantiate<sensor_msgs::Imu>();
        if (!msg) throw ParseError(MessageWhere(path, index, m.getTopic()) + "not a sensor_msgs/Imu");
        const double stamp = msg->header.stamp.toSec();
        std::string why = StampProblem(stamp);
        // A gyro reads a few rad/s at most; beyond 1000 rad/s a message is damaged.
        if (why.empty() && !(std::abs(msg->angular_velocity.z) <= 1000)) {
          why = "angular_velocity.z " + FormatDouble(msg->angular_velocity.z) + " rad/s is not finite or beyond 1000";
        }
        if (!why.empty()) throw ParseError(MessageWhere(path, index, m.getTopic()) + why);
        log.imu.samples.push_back(ImuSample{stamp, msg->angular_velocity.z});
      } else {
        statics.emplace_back(index, m);
      }
    }
    if (log.scans.empty()) throw ParseError(path + ": no message on " + options.scan_topic + ": not a laser log");
    SE2<double> laser_in_robot;
    for (const auto& [static_index, m] : statics) {
      if (!FindStaticTransform(m, laser_frame, &laser_in_robot)) continue;
      const std::string why = PoseProblem(laser_in_robot.x(), laser_in_robot.y(), laser_in_robot.theta());
      if (!why.empty()) {
        throw ParseError(MessageWhere(path, static_index, m.getTopic()) + "the transform to the laser frame '" +
                         laser_frame + "': " + why);
      }
      break;
    }
    for (LaserScan& s : log.scans) s.laser_in_robot = laser_in_robot;
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw ParseError(path + ": reading message " + std::to_string(index) + ": " + e.what());
  }
}

}  // namespace
}  // namespace lidar
}  // namespace tether

// The module's one entry point (rosbag_reader.cc, kRosBagEntry): fills *log with the bag's
// scans, odometry, IMU samples and laser mounting; throws tether's errors as ReadRosBag does.
extern "C" void tether_rosbag_read_v1(const std::string& path, const tether::lidar::LidarReadOptions& options,
                                      tether::lidar::LidarLog* log) {
  tether::lidar::ReadBagMessages(path, options, log);
}
