#pragma once
// The voxel filter: keeps one point per occupied square cell of a grid, so dense parts of a scan
// (walls next to the robot) do not outweigh sparse ones.
#include <Eigen/Core>
#include <vector>

namespace tether {
namespace lidar {

/// Returns, for every cell of edge `edge` (metres, > 0; cells aligned on the origin) that holds
/// at least one point, the centroid of its points, in the order the cells are first met.
/// Throws InvalidArgument where edge is not positive and finite.
std::vector<Eigen::Vector2d> VoxelFilter(const std::vector<Eigen::Vector2d>& points, double edge);

}  // namespace lidar
}  // namespace tether
