#pragma once
// CARMEN logs (text, one message per line; plain or gzip, read through zlib):
//   ODOM x y theta tv rv accel ipc_timestamp host logger_timestamp
//   FLASER n r1..rn x y theta odom_x odom_y odom_theta ipc_timestamp host logger_timestamp
//   ROBOTLASER1 laser_type start_angle fov angular_resolution max_range accuracy remission_mode
//               n r1..rn m e1..em laser_x laser_y laser_theta robot_x robot_y robot_theta
//               tv rv forward_safety_dist side_safety_dist turn_axis ipc_timestamp host logger_timestamp
//   RAWLASER1 laser_type start_angle fov angular_resolution max_range accuracy remission_mode
//             n r1..rn m e1..em ipc_timestamp host logger_timestamp
// FLASER's x y theta is the laser's pose and odom_x.. the robot's; the scan's stamp is the
// ipc_timestamp. RAWLASER1 carries no pose: its scans take their odometry from the ODOM lines
// (none where the log has none) and the laser sits at the robot's origin. Every other message
// (PARAM, SYNC, NEFF, RLASER, ...) and `#` comments are skipped. docs/lidar.md has the details.
#include <string>

#include "tether/frontends/lidar/io/lidar_log.h"

namespace tether {
namespace lidar {

/// Reads a CARMEN log, plain or gzip. Throws IoError where it cannot be opened or read,
/// ParseError "path:line: ..." naming the message and field that is malformed.
LidarLog ReadCarmenLog(const std::string& path, const LidarReadOptions& options = {});

}  // namespace lidar
}  // namespace tether
