#pragma once
// An occupancy grid stored as tiles of 64 x 64 cells that copies of the grid share until one
// of them writes: the map of each particle of a Rao-Blackwellised particle filter (a particle
// resampled from another starts with its parent's map at the cost of copying the tile
// pointers, and a scan it inserts copies only the tiles the scan touches). The cells hold the
// same 15-bit values as ProbabilityGrid (tether/factors/probability_grid.h) and are updated
// by the same odds tables as ProbabilityGridInserter: a grid built by inserting the same scans
// reads, cell by cell, as the ProbabilityGrid would.
//
// Scans go in through ProbabilityGridInserter::Insert. The scan matchers read a dense
// ProbabilityGrid: Window() copies a box of cells into one.
//
// Threads: grids that share tiles may be read and written on different threads at once, each
// grid by one thread: a tile is written in place only where its grid alone holds it.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <memory>
#include <unordered_map>
#include <vector>

#include "tether/factors/probability_grid.h"

namespace tether {
namespace lidar {

class TiledProbabilityGrid {
 public:
  using Cell = ProbabilityGrid::Cell;
  static constexpr int kTileBits = 6;
  static constexpr int kTileSide = 1 << kTileBits;  ///< cells

  /// Throws InvalidArgument as ProbabilityGrid's constructor.
  explicit TiledProbabilityGrid(double resolution, const Eigen::Vector2d& origin = Eigen::Vector2d::Zero(),
                                double min_probability = ProbabilityGrid::kDefaultMinProbability,
                                double max_probability = ProbabilityGrid::kDefaultMaxProbability);

  /// A grid with no cells: the frame (resolution, origin), the probability range and the value
  /// coding, shared with the dense grids Window() makes.
  const ProbabilityGrid& frame() const { return frame_; }
  double resolution() const { return frame_.resolution(); }
  const Eigen::Vector2d& origin() const { return frame_.origin(); }
  Cell CellOf(const Eigen::Vector2d& p) const { return frame_.CellOf(p); }

  /// The raw 15-bit value (ProbabilityGrid::kUnknownValue where never written).
  std::uint16_t Value(const Cell& c) const;
  double Probability(const Cell& c, double unknown) const {
    const std::uint16_t v = Value(c);
    return v == ProbabilityGrid::kUnknownValue ? unknown : frame_.ValueToProbability(v);
  }

  /// As ProbabilityGrid's (what ProbabilityGridInserter::Insert calls): applies `table` to c
  /// unless c was updated since the last FinishUpdate; a tile shared with a copy is copied
  /// first.
  bool ApplyUpdate(const Cell& c, const std::vector<std::uint16_t>& table);
  void FinishUpdate();

  /// The cells lo .. hi (inclusive corners) as a dense ProbabilityGrid of the same frame and
  /// probability range (unknown cells stay unknown).
  ProbabilityGrid Window(const Cell& lo, const Cell& hi) const;
  /// Every known cell as a dense grid (empty where nothing is known).
  ProbabilityGrid ToGrid() const;

  /// Tiles this grid holds, and the ones it holds alone (not shared with a copy).
  std::size_t tile_count() const { return tiles_.size(); }
  std::size_t unshared_tile_count() const;
  /// The tiles' addresses (to count the distinct tiles of many grids).
  void TileAddresses(std::vector<const void*>* out) const;
  static constexpr std::size_t kTileBytes = sizeof(std::uint16_t) * kTileSide * kTileSide;

 private:
  using Tile = std::array<std::uint16_t, kTileSide * kTileSide>;
  static std::int64_t Key(int tx, int ty) {
    return static_cast<std::int64_t>((static_cast<std::uint64_t>(static_cast<std::uint32_t>(tx)) << 32) |
                                     static_cast<std::uint32_t>(ty));
  }
  static int TileOf(int c) { return c >= 0 ? c >> kTileBits : -((-(c + 1)) >> kTileBits) - 1; }  // floor
  static int InTile(int c) { return c & (kTileSide - 1); }

  ProbabilityGrid frame_;  // holds no cells
  std::unordered_map<std::int64_t, std::shared_ptr<Tile>> tiles_;
  std::vector<std::uint16_t*> updated_;  // cells marked since the last FinishUpdate
};

}  // namespace lidar
}  // namespace tether
