#pragma once
// Trajectories as TUM-style text: one pose per line, `timestamp x y z qx qy qz qw` (seconds,
// metres, a unit quaternion), `#` comments. A planar pose is written with z = 0 and the
// rotation about z; reading back keeps x, y and the yaw of the quaternion.
#include <iosfwd>
#include <string>
#include <vector>

#include "tether/core/trajectory_error.h"
#include "tether/frontends/lidar/sensor/odometry_track.h"

namespace tether {
namespace lidar {

/// Writes the poses (stamps with 9 decimals, positions and quaternions with 17 significant
/// digits, so reading back gives the same doubles up to the quaternion's round trip).
void WriteTum(std::ostream& out, const std::vector<StampedPose2>& poses);
/// Writes through an OutputFile (temporary file renamed into place). Throws IoError.
void WriteTumFile(const std::string& path, const std::vector<StampedPose2>& poses);

/// Reads TUM text; `name` is used in messages. Throws ParseError "name:line: ..." on a line
/// without 8 numbers, a non-finite number, or a quaternion far from unit length (|q| outside
/// [0.9, 1.1]; others are normalised).
std::vector<StampedPose2> ReadTum(std::istream& in, const std::string& name);
/// Throws IoError where the file cannot be opened.
std::vector<StampedPose2> ReadTumFile(const std::string& path);

/// The absolute trajectory error (rigid alignment; tether/core/trajectory_error.h) of the
/// poses of `estimate` whose stamps `truth` has too, within `tolerance` seconds (both sorted by
/// stamp, as a run and a TUM file are). poses == 0 where no stamp matches.
TrajectoryError StampedTrajectoryError(const std::vector<StampedPose2>& estimate,
                                       const std::vector<StampedPose2>& truth, double tolerance = 1e-6);

}  // namespace lidar
}  // namespace tether
