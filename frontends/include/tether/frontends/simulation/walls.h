#pragma once
// The walls of a simulated 2D world (the office of lidar_world.h, the maze of maze_world.h):
// segments in the world frame, the ray cast a simulated scanner measures, the distance to the
// nearest wall, and the world's map as an occupancy image (the map a localiser is given).
//
//   const OccupancyImage map = RasterizeWalls(walls, 0.05);
//   // PgmBytes(map) and MapYaml(map, "map.pgm") (occupancy_map.h) write it as map_server reads it.
#include <Eigen/Core>
#include <vector>

#include "tether/frontends/lidar/io/occupancy_map.h"

namespace tether {
namespace lidar {

/// A wall from a to b (metres, world frame).
struct WallSegment {
  Eigen::Vector2d a, b;
};

/// The distance from `origin` along the unit direction `d` to the nearest wall (infinity where
/// none is hit).
double CastRay(const std::vector<WallSegment>& walls, const Eigen::Vector2d& origin, const Eigen::Vector2d& d);

/// The distance from `p` to the nearest wall.
double DistanceToWalls(const std::vector<WallSegment>& walls, const Eigen::Vector2d& p);

/// The walls' map: `resolution` metres a pixel over the walls' bounding box, widened by
/// `padding` pixels on every side. Every pixel a wall passes through is occupied (0; each wall
/// is walked in steps of at most half a pixel), the others inside the bounding box free (254),
/// the padding unknown (kUnknownPixel, 205). A point p lies in column floor((p.x - origin.x) /
/// resolution) and row height - 1 - floor((p.y - origin.y) / resolution) (the first row the
/// top). Throws InvalidArgument for no walls, a non-finite wall, a resolution that is not
/// positive, a negative padding or an image of more than 10^8 pixels.
OccupancyImage RasterizeWalls(const std::vector<WallSegment>& walls, double resolution = 0.05, int padding = 10);

}  // namespace lidar
}  // namespace tether
