#pragma once
// The robot's own body in its scans: beams that end on the robot (a mast, a bumper, the
// laser's own housing) are at very short range or in a fixed angular sector of the laser.
// Left in, they are points that move with the robot: the matchers are pulled towards keeping
// them where they were (no motion) and the map gets a trail of the robot. A BodyMask makes
// such beams no return before anything uses the scan (LidarSlamOptions::mask: local matching,
// the submaps, loop closure and the final map all see the masked scan).
//
//   tether::lidar::BodyMask mask;
//   mask.min_range = 0.15;                                        // m
//   std::string why;
//   ParseAngleSectors("160:200", &mask.sectors, &why);            // degrees: the back
//   std::size_t masked = ApplyBodyMask(mask, &scan);
#include <cstddef>
#include <string>
#include <vector>

#include "tether/frontends/lidar/sensor/laser_scan.h"

namespace tether {
namespace lidar {

/// Beam angles from `from` counter-clockwise to `to` (radians in the laser's frame, x forward;
/// each taken modulo a full turn, so 170 to 190 degrees is the sector across the back, and so
/// is 170 to -170).
struct AngleSector {
  double from = 0;
  double to = 0;
  /// True where `angle` (any radians) lies in the sector, its edges included.
  bool Contains(double angle) const;
};

struct BodyMask {
  /// Beams shorter than this are no return (m; 0: none). Applies on top of the scan's own
  /// range_min.
  double min_range = 0;
  /// Beams whose angle lies in one of these are no return.
  std::vector<AngleSector> sectors;
  bool empty() const { return min_range <= 0 && sectors.empty(); }
  /// False (and why) for a minimum range that is negative, not finite or beyond
  /// scan_bounds::kMaxRange, a sector whose ends are not finite or whose width (counter-clockwise
  /// from `from` to `to`) is zero.
  bool IsValid(std::string* why) const;
};

/// Sets the masked beams of `scan` to NaN (no return) and returns how many valid beams were
/// masked. An empty mask changes nothing.
std::size_t ApplyBodyMask(const BodyMask& mask, LaserScan* scan);

/// Parses "a:b[,c:d...]" (degrees, each sector from a counter-clockwise to b) into radians.
/// False (and why, naming the part) for an empty text, a part without one ':', a number that is
/// not one, or a sector of zero width. `out` is set only on success.
bool ParseAngleSectors(const std::string& text, std::vector<AngleSector>* out, std::string* why);
/// The sectors as ParseAngleSectors reads them ("160:200,-10:10"; degrees, shortest form).
std::string FormatAngleSectors(const std::vector<AngleSector>& sectors);

}  // namespace lidar
}  // namespace tether
