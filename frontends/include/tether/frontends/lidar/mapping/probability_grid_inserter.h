#pragma once
// Inserting a laser scan into a probability grid: the cells of the hits are updated with
// p_hit, the cells the beams cross on their way (ray casting from the sensor's origin to each
// hit) with p_miss. Within one scan a cell is updated at most once, and a cell that holds a
// hit is not also a miss (hits are applied first): the hit and miss cells are disjoint.
// M_new = clamp(odds^-1(odds(M_old) odds(p))) through the grid's lookup tables
// (tether/factors/probability_grid.h).
#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "tether/factors/probability_grid.h"

namespace tether {
namespace lidar {

class TiledProbabilityGrid;

struct GridInsertOptions {
  /// The probability of an occupied cell given one hit in it (Hess et al. 2016: 0.55).
  double hit_probability = 0.55;
  /// The probability of an occupied cell given one beam through it (0.49).
  double miss_probability = 0.49;
  /// Update the cells beams pass through (misses); off: hits only.
  bool insert_free_space = true;
  /// True where 0 < miss < 1 and 0 < hit < 1 (hit above 0.5, miss below); otherwise says why.
  bool IsValid(std::string* why) const;
};

/// The cells a segment from `from` to `to` (map frame) passes through, in order, from the cell
/// of `from` up to but not including the cell of `to` (exact grid traversal: every cell the
/// segment touches, none it does not). Appended to *cells.
void CastRay(const ProbabilityGrid& grid, const Eigen::Vector2d& from, const Eigen::Vector2d& to,
             std::vector<ProbabilityGrid::Cell>* cells);

/// The cells one insertion changed.
struct InsertedCells {
  std::vector<ProbabilityGrid::Cell> hits;    ///< each once
  std::vector<ProbabilityGrid::Cell> misses;  ///< each once, none of them a hit
};

class ProbabilityGridInserter {
 public:
  /// Tables for grids of the probability range [min_probability, max_probability]. Throws
  /// InvalidArgument for invalid options or range.
  ProbabilityGridInserter(const GridInsertOptions& options, double min_probability, double max_probability);

  /// Inserts one scan: `hits` the scan's points and `origin` the sensor's position, both in
  /// the grid's frame. Fills *cells (cleared first) where it is not null. Throws
  /// InvalidArgument where the grid's probability range is not the inserter's, or a point is
  /// not finite.
  void Insert(ProbabilityGrid* grid, const Eigen::Vector2d& origin, const std::vector<Eigen::Vector2d>& hits,
              InsertedCells* cells = nullptr) const;
  /// The same into a tiled grid (a particle's map, tiled_probability_grid.h).
  void Insert(TiledProbabilityGrid* grid, const Eigen::Vector2d& origin, const std::vector<Eigen::Vector2d>& hits,
              InsertedCells* cells = nullptr) const;

  const GridInsertOptions& options() const { return options_; }

 private:
  void CheckRange(double min_probability, double max_probability) const;

  GridInsertOptions options_;
  double min_probability_, max_probability_;
  std::vector<std::uint16_t> hit_table_, miss_table_;
};

}  // namespace lidar
}  // namespace tether
