#pragma once
// `tether simulate lidar -o LOG --truth TRUE.tum`: a run through the simulated office world
// (tether/frontends/simulation/lidar_world.h), or a maze with `--world maze` (maze_world.h),
// written as a CARMEN log, with the robot's true trajectory as TUM text; `--map-out MAP.yaml`
// adds the world's map (MAP.yaml + MAP.pgm, map_server's format); `--preset lds` degrades the
// scans as a low-cost scanner would give them (tether/frontends/lidar/io/degrade_log.h).
// docs/lidar.md, "A simulated world".
#include <iosfwd>
#include <optional>
#include <string>

#include "tether/frontends/simulation/lidar_world.h"
#include "tether/tools/commands.h"

namespace tether {

/// The options of `tether simulate` that only the lidar world takes (the output, the seed and
/// the world's name are SimulateCommand's).
struct SimulateLidarCommand {
  std::string truth;  ///< the true trajectory, TUM text (optional)
  std::optional<int> scans;
  std::optional<int> beams;
  bool no_odometry = false;
  std::string preset;  ///< "" or a degrade preset (lds)
  lidar::LidarWorld world = lidar::LidarWorld::kOffice;
  bool world_given = false;  ///< --world was given
  std::string map_out;       ///< the world's map: this YAML and the PGM beside it (.yaml -> .pgm)
  double map_resolution = 0.05;
  bool map_resolution_given = false;

  /// True where any of them was given.
  bool Given() const {
    return !truth.empty() || scans || beams || no_odometry || !preset.empty() || world_given || !map_out.empty() ||
           map_resolution_given;
  }
};

/// Exit codes as commands.h: 0 written, 2 bad usage (also lidar options given for another
/// world), 4 an output that cannot be written (nothing is written).
int RunSimulateLidar(const SimulateCommand& sim, const SimulateLidarCommand& cmd, std::ostream& out, std::ostream& err);

}  // namespace tether
