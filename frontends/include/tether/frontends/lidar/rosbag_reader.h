#pragma once
// ROS 1 bags: sensor_msgs/LaserScan on options.scan_topic, nav_msgs/Odometry on
// options.odom_topic (its pose as the robot's odometry pose; the yaw of its quaternion), and the
// robot -> laser transform from /tf_static where one is there. Read with Debian's
// librosbag-storage-dev; a build without it (TETHER_WITH_ROSBAG=OFF) throws InvalidArgument.
#include <string>

#include "tether/frontends/lidar/lidar_log.h"

namespace tether {
namespace lidar {

/// True where tether was built with ROS 1 bag support.
bool RosBagSupported();

/// Reads the scans and odometry of a bag; scans in the bag's time order. Throws IoError where
/// it cannot be opened, ParseError "path: message N on TOPIC: ..." where the bag or a message is
/// malformed or the scan topic is missing or of another type, InvalidArgument without bag support.
LidarLog ReadRosBag(const std::string& path, const LidarReadOptions& options = {});

}  // namespace lidar
}  // namespace tether
