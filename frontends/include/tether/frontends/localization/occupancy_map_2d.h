#pragma once
// The map a robot localises in: a grid of free, occupied and unknown cells (read from a
// map_server PGM + YAML, as `tether lidar` writes them), with what Monte Carlo localisation
// looks up in it: each cell's distance to the nearest occupied cell (an exact Euclidean
// distance transform), the free cells to draw particles from, and the costmap of where the
// robot's centre may be.
//
//   auto map = std::make_shared<const OccupancyMap2D>(OccupancyMap2D::Read("map.yaml"));
//   int i, j;
//   if (map->CellOf({x, y}, &i, &j) && map->State(i, j) == CellState::kFree) ...
//
// Cells: column i from the left (x), row j from the bottom (y); cell (i, j) covers
// [origin.x + i r, origin.x + (i + 1) r) x [origin.y + j r, ...) for resolution r. The
// image's first row is the map's top, so row j is image row height - 1 - j.
#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "tether/core/enum_names.h"
#include "tether/frontends/lidar/io/occupancy_map.h"

namespace tether {
namespace localization {

enum class CellState : std::uint8_t { kFree, kOccupied, kUnknown };

/// The cells' layout: size, resolution, origin (the lower-left corner of cell (0, 0)).
struct GridGeometry {
  int width = 0, height = 0;
  double resolution = 0, inverse_resolution = 0;
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();

  /// The cell holding point p; false (i, j unchanged) where it lies outside the grid.
  bool CellOf(const Eigen::Vector2d& p, int* i, int* j) const {
    const double fx = (p.x() - origin.x()) * inverse_resolution;
    const double fy = (p.y() - origin.y()) * inverse_resolution;
    if (!(fx >= 0 && fy >= 0 && fx < width && fy < height)) return false;
    *i = static_cast<int>(fx);
    *j = static_cast<int>(fy);
    return true;
  }
  Eigen::Vector2d CellCentre(int i, int j) const { return origin + resolution * Eigen::Vector2d(i + 0.5, j + 0.5); }
  std::size_t Index(int i, int j) const { return static_cast<std::size_t>(j) * static_cast<std::size_t>(width) + i; }
};

class OccupancyMap2D {
 public:
  /// The map of an image: a pixel is occupied, free or unknown by the thresholds (see
  /// lidar::MapFile). Throws InvalidArgument for an empty image, a pixel count that does not
  /// match the size, or a non-positive resolution.
  OccupancyMap2D(const lidar::OccupancyImage& image, double occupied_thresh = 0.65, double free_thresh = 0.196,
                 bool negate = false);
  /// Reads a map_server YAML and its image (lidar::ReadMapYaml; its errors).
  static OccupancyMap2D Read(const std::string& yaml_path);

  const GridGeometry& geometry() const { return geometry_; }
  int width() const { return geometry_.width; }
  int height() const { return geometry_.height; }
  double resolution() const { return geometry_.resolution; }
  const Eigen::Vector2d& origin() const { return geometry_.origin; }
  bool CellOf(const Eigen::Vector2d& p, int* i, int* j) const { return geometry_.CellOf(p, i, j); }
  Eigen::Vector2d CellCentre(int i, int j) const { return geometry_.CellCentre(i, j); }
  std::size_t Index(int i, int j) const { return geometry_.Index(i, j); }
  CellState State(int i, int j) const { return state_[Index(i, j)]; }
  /// Metres from the centre of cell (i, j) to the centre of the nearest occupied cell
  /// (infinity in a map without an occupied cell).
  float Distance(int i, int j) const { return distance_[Index(i, j)]; }
  const std::vector<float>& distances() const { return distance_; }
  /// The same distances as whole squared cells (the transform is exact on the cell lattice);
  /// the largest uint32 where there is no occupied cell.
  const std::vector<std::uint32_t>& squared_cell_distances() const { return squared_cells_; }
  /// The indices (j * width + i) of the free cells.
  const std::vector<std::uint32_t>& free_cells() const { return free_cells_; }
  std::size_t occupied_count() const { return occupied_count_; }

 private:
  GridGeometry geometry_;
  std::vector<CellState> state_;
  std::vector<float> distance_;
  std::vector<std::uint32_t> squared_cells_;
  std::vector<std::uint32_t> free_cells_;
  std::size_t occupied_count_ = 0;
};

/// Squared Euclidean distance transform (in cells squared) of a width x height grid where
/// `seed[k]` marks the cells whose distance is 0: the exact squared distance from each cell's
/// centre to the nearest seed cell's centre (a large number where there is no seed). Two passes
/// of the lower envelope of parabolas, one along the columns and one along the rows: O(cells).
std::vector<float> SquaredDistanceTransform(int width, int height, const std::vector<bool>& seed);

/// Where the robot's centre may be: a free cell at least `robot_radius` from every occupied
/// cell (the obstacles inflated by the robot) — unknown and occupied cells and the inflated
/// band are invalid.
class Costmap2D {
 public:
  /// Throws InvalidArgument for a negative or non-finite radius.
  Costmap2D(const OccupancyMap2D& map, double robot_radius);

  /// True where p lies in a valid cell.
  bool Valid(const Eigen::Vector2d& p) const {
    int i, j;
    return geometry_.CellOf(p, &i, &j) && valid_[geometry_.Index(i, j)];
  }
  /// True where the straight motion from a to b stays in valid cells, checked at a and b and in
  /// between at steps no longer than half a cell.
  bool PathValid(const Eigen::Vector2d& a, const Eigen::Vector2d& b) const;
  /// The indices of the valid cells.
  const std::vector<std::uint32_t>& valid_cells() const { return valid_cells_; }
  double robot_radius() const { return robot_radius_; }

 private:
  GridGeometry geometry_;
  double robot_radius_;
  std::vector<bool> valid_;
  std::vector<std::uint32_t> valid_cells_;
};

}  // namespace localization
}  // namespace tether
