#pragma once
// ROS 1 bags: sensor_msgs/LaserScan on options.scan_topic, nav_msgs/Odometry on
// options.odom_topic (its pose as the robot's odometry pose; the yaw of its quaternion), and the
// robot -> laser transform from /tf_static where one is there; sensor_msgs/Imu on
// options.imu_topic where one is named (its angular_velocity.z, imu_yaw.h). Read with Debian's
// librosbag-storage-dev; a build without it (TETHER_WITH_ROSBAG=OFF) throws InvalidArgument.
#include <string>

#include "tether/frontends/lidar/io/lidar_log.h"

namespace tether {
namespace lidar {

/// True where tether was built with ROS 1 bag support.
bool RosBagSupported();

/// Reads the scans and odometry of a bag; scans in the bag's time order. Throws IoError where
/// it cannot be opened, ParseError "path: message N on TOPIC: ..." where the bag or a message is
/// malformed or the scan topic is missing or of another type, InvalidArgument without bag support.
LidarLog ReadRosBag(const std::string& path, const LidarReadOptions& options = {});

/// Checks that every record of a ROS 1 bag (v2.0), and every record inside an uncompressed
/// chunk, lies within the file or chunk holding it, and that no chunk claims more than 1 GB
/// uncompressed; throws ParseError "path: byte N: ..." otherwise. ReadRosBag calls it before
/// the bag library reads anything, so that a damaged length is never allocated. Needs no ROS.
void CheckBagRecords(const std::string& path);

}  // namespace lidar
}  // namespace tether
