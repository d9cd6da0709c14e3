#pragma once
// A simulated 2D LiDAR world with known truth: an office of wall segments (rooms off a loop of
// corridors, doors, clutter boxes), a robot driving through it and back round the loop (so a
// SLAM front-end meets its loop closures), a ray-cast laser scanner and drifting odometry.
// Everything is deterministic for a seed (tether/frontends/simulation/random_stream.h).
//
//   tether::lidar::LidarSimOptions o;  // 3000 scans at 10 Hz, 360 beams over 360 degrees, 20 m
//   o.seed = 3;
//   const tether::lidar::SimulatedLidar sim = tether::lidar::SimulateLidar(o);
//   // sim.log: a LidarLog as the readers give it (WriteCarmenLog writes it);
//   // sim.truth: the robot's true pose at each scan's stamp (WriteTum writes it).
//
// The world (40 m x 30 m): a corridor 2 m wide runs round a rectangle (its centre line from
// (7, 7) to (33, 23)); thirteen rooms open off it through 1 m doors: four along the bottom
// (y 0 to 6), four along the top (y 24 to 30), two on the left (x 0 to 6), one on the right
// (x 34 to 40) and two inside the loop. Each room holds one or two boxes (0.4 m to 0.8 m) in
// corners away from its door, placed by the seed.
//
// The path: from the corridor's bottom left corner, laps of the corridor (clockwise or
// anticlockwise by the seed), entering rooms on the way (each door passed is taken with
// probability 0.4: in through the door, to the room's centre, to a random point of the room's
// middle and back out), until the scans run out. The robot moves up to `step` metres and turns
// up to `max_turn` radians between scans, slowing to turn on the spot where it must turn more.
//
// The maze (world = LidarWorld::kMaze, maze_world.h): MazeWorld(seed, maze), the robot from
// cell 0's centre along the cells' centre lines on a MazeTour (to the nearest unvisited cell
// again and again, a new tour once all are visited), with the same motion, scanner and odometry.
//
// Odometry: the true motion between scans (in the robot's frame: forward, sideways, turn) with
// Gaussian noise of standard deviation translation_noise x distance (forward and sideways) and
// rotation_noise x |turn| + rotation_per_metre x distance (turn), composed from the first true
// pose: it drifts. All three 0: the odometry is the truth.
#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "tether/core/enum_names.h"
#include "tether/frontends/lidar/io/lidar_log.h"
#include "tether/frontends/simulation/maze_world.h"
#include "tether/frontends/simulation/walls.h"

namespace tether {
namespace lidar {

/// The world the robot drives through.
enum class LidarWorld {
  kOffice,  ///< OfficeWorld (below), the path above
  kMaze,    ///< MazeWorld (maze_world.h), driven by a MazeTour from cell 0
};
inline constexpr EnumName<LidarWorld> kLidarWorldNames[] = {{LidarWorld::kOffice, "office"},
                                                            {LidarWorld::kMaze, "maze"}};
constexpr const auto& EnumNames(LidarWorld) { return kLidarWorldNames; }

struct LidarSimOptions {
  LidarWorld world = LidarWorld::kOffice;   ///< the office or the maze
  MazeOptions maze;                         ///< the maze's size (world kMaze)
  int scans = 3000;                         ///< scans (at `rate`)
  double rate = 10;                         ///< scans per second
  double step = 0.1;                        ///< metres between scans at full speed
  double max_turn = 0.1;                    ///< radians between scans at most
  int beams = 360;                          ///< beams per scan
  double fov = 2 * 3.14159265358979323846;  ///< radians; 2 pi: a full turn (no beam twice)
  double max_range = 20;                    ///< metres: farther walls give no return (the maximum range)
  double range_noise = 0.01;                ///< metres: Gaussian noise on each range
  double translation_noise = 0.03;          ///< odometry: metres of noise per metre travelled
  double rotation_noise = 0.03;             ///< odometry: radians of noise per radian turned
  double rotation_per_metre = 0.01;         ///< odometry: radians of noise per metre travelled
  bool odometry = true;                     ///< false: the scans carry no odometry (OdometryOrigin::kNone)
  double start_time = 1000;                 ///< the first scan's stamp (seconds)
  std::uint64_t seed = 1;                   ///< the office's boxes or the maze, the path, the range and odometry noise

  /// False (and why) for fewer than 2 scans or beams, a non-positive rate, step, turn, field of
  /// view (or one above 2 pi) or range, a negative noise, a maze that is not valid (world kMaze).
  bool IsValid(std::string* why) const;
};

struct SimulatedLidar {
  std::vector<WallSegment> walls;
  /// The scans (stamps start_time + k / rate, the laser at the robot's origin), each with its
  /// odometry (OdometryOrigin::kScanLine) and the same poses as the odometry messages; without
  /// odometry, none.
  LidarLog log;
  /// The robot's true pose at each scan's stamp, in the world frame.
  std::vector<StampedPose2> truth;
  double distance = 0;    ///< metres travelled
  int rooms_visited = 0;  ///< the office's rooms entered
  int laps = 0;           ///< the office's corridor laps begun
  int tours = 0;          ///< the maze's tours begun (MazeTour)
  int cells_visited = 0;  ///< the maze's distinct cells made waypoints
};

/// The world's walls for a seed (the boxes move with it; the rooms and corridors do not).
std::vector<WallSegment> OfficeWorld(std::uint64_t seed);

/// Simulates the run. Throws InvalidArgument where the options are not valid.
SimulatedLidar SimulateLidar(const LidarSimOptions& options);

}  // namespace lidar
}  // namespace tether
