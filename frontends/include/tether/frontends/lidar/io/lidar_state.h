#pragma once
// A saved LiDAR SLAM state (`tether lidar --save-state`, LidarSlam2D::State): what a finished
// run built, enough to localise in it (`tether localize`, localizer_2d.h) or to go on mapping.
//
// The file (docs/lidar_state.md has every field):
//
//   "tether lidar state\n"               19 bytes
//   u32 version                          1 (kLidarStateVersion)
//   u64 payload bytes, u64 stored bytes  the payload and its zlib stream
//   u32 CRC-32 of the payload
//   the payload, zlib-compressed
//
// The payload, little-endian: the trajectories; every scan (stamp, trajectory, global and local
// pose, the laser on the robot, the submaps it went into, its valid points in the laser's frame
// as float pairs); every submap (trajectory, global and local pose, scans, grid); the loop
// closures; and the map (every scan at its pose). A grid: resolution, origin, the probability
// range, the stored box (first cell and size) and its raw 15-bit values (ProbabilityGrid).
//
// The reader refuses, naming the file and what is wrong, any other version, a stream that does
// not unpack to the size it states or to its CRC, a count the bytes left cannot hold, an index
// out of range, a number that is not finite and bytes left over: it never reads past the data
// and never trusts a size before checking it against what is there.
#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "tether/core/se2.h"
#include "tether/factors/probability_grid.h"

namespace tether {
namespace lidar {

constexpr std::uint32_t kLidarStateVersion = 1;

struct SavedScan {
  double stamp = 0;
  int trajectory = 0;
  SE2d pose;        ///< the robot, the map's frame (the run's final estimate)
  SE2d local_pose;  ///< the robot, its local SLAM's frame
  SE2d laser_in_robot;
  std::vector<int> submaps;             ///< the submaps it went into (indices into LidarState::submaps)
  std::vector<Eigen::Vector2d> points;  ///< valid points, the laser's frame (stored as floats)
};

struct SavedSubmap {
  int trajectory = 0;
  SE2d pose;        ///< its origin, the map's frame
  SE2d local_pose;  ///< its origin, its local SLAM's frame (the grid's frame)
  int num_scans = 0;
  std::shared_ptr<const ProbabilityGrid> grid;
};

struct SavedClosure {
  int scan = 0;
  int submap = 0;
  SE2d relative;  ///< the scan in the submap's frame
  double score = 0;
};

struct LidarState {
  int trajectories = 1;
  std::vector<SavedScan> scans;
  std::vector<SavedSubmap> submaps;
  std::vector<SavedClosure> closures;
  std::shared_ptr<const ProbabilityGrid> map;  ///< every scan at its pose
  /// Empty where the state is whole; else what is wrong (an index out of range, a grid
  /// missing, a number not finite), as the reader would refuse it.
  std::string Problem() const;
};

/// The file's bytes. Throws InvalidArgument for a state with a Problem().
std::string LidarStateBytes(const LidarState& state);
/// A state from a file's bytes; `name` names it in messages. Throws ParseError naming `name`
/// and what is wrong.
LidarState ParseLidarState(const std::string& bytes, const std::string& name);
/// Reads a state file. Throws IoError where it cannot be read, ParseError as ParseLidarState.
LidarState ReadLidarState(const std::string& path);

}  // namespace lidar
}  // namespace tether
