#include "tether/frontends/lidar/mapping/tiled_probability_grid.h"

#include <algorithm>
#include <atomic>
#include <limits>

namespace tether {
namespace lidar {

TiledProbabilityGrid::TiledProbabilityGrid(double resolution, const Eigen::Vector2d& origin, double min_probability,
                                           double max_probability)
    : frame_(resolution, origin, min_probability, max_probability) {}

std::uint16_t TiledProbabilityGrid::Value(const Cell& c) const {
  const auto it = tiles_.find(Key(TileOf(c.x()), TileOf(c.y())));
  if (it == tiles_.end()) return ProbabilityGrid::kUnknownValue;
  return static_cast<std::uint16_t>((*it->second)[static_cast<std::size_t>(InTile(c.y()) * kTileSide + InTile(c.x()))] &
                                    ProbabilityGrid::kMaxValue);
}

bool TiledProbabilityGrid::ApplyUpdate(const Cell& c, const std::vector<std::uint16_t>& table) {
  std::shared_ptr<Tile>& tile = tiles_[Key(TileOf(c.x()), TileOf(c.y()))];
  if (tile == nullptr) {
    tile = std::make_shared<Tile>();
    tile->fill(ProbabilityGrid::kUnknownValue);
  } else if (tile.use_count() > 1) {
    tile = std::make_shared<Tile>(*tile);  // shared with a copy: this grid's own from now on
  } else {
    // This grid alone holds the tile. Another grid (a particle updated on another thread) may
    // have dropped it just now, after reading it: its release of the count happens before this.
    std::atomic_thread_fence(std::memory_order_acquire);
  }
  std::uint16_t& v = (*tile)[static_cast<std::size_t>(InTile(c.y()) * kTileSide + InTile(c.x()))];
  if (v & ProbabilityGrid::kUpdateMarker) return false;
  v = table[v];
  updated_.push_back(&v);
  return true;
}

void TiledProbabilityGrid::FinishUpdate() {
  for (std::uint16_t* v : updated_) *v &= ProbabilityGrid::kMaxValue;
  updated_.clear();
}

ProbabilityGrid TiledProbabilityGrid::Window(const Cell& lo, const Cell& hi) const {
  ProbabilityGrid out(frame_.resolution(), frame_.origin(), frame_.min_probability(), frame_.max_probability());
  if ((hi < lo).any()) return out;
  const Cell size = hi - lo + Cell(1, 1);
  std::vector<std::uint16_t> values(static_cast<std::size_t>(size.x()) * static_cast<std::size_t>(size.y()),
                                    ProbabilityGrid::kUnknownValue);
  // Tile by tile: each known tile's part of the box, row by row.
  for (int ty = TileOf(lo.y()); ty <= TileOf(hi.y()); ++ty) {
    for (int tx = TileOf(lo.x()); tx <= TileOf(hi.x()); ++tx) {
      const auto it = tiles_.find(Key(tx, ty));
      if (it == tiles_.end()) continue;
      const Tile& tile = *it->second;
      const int x0 = std::max(lo.x(), tx * kTileSide), x1 = std::min(hi.x(), tx * kTileSide + kTileSide - 1);
      const int y0 = std::max(lo.y(), ty * kTileSide), y1 = std::min(hi.y(), ty * kTileSide + kTileSide - 1);
      for (int y = y0; y <= y1; ++y) {
        const std::uint16_t* from = tile.data() + InTile(y) * kTileSide + InTile(x0);
        std::uint16_t* to = values.data() + static_cast<std::size_t>(y - lo.y()) * static_cast<std::size_t>(size.x()) +
                            static_cast<std::size_t>(x0 - lo.x());
        for (int x = 0; x <= x1 - x0; ++x) to[x] = static_cast<std::uint16_t>(from[x] & ProbabilityGrid::kMaxValue);
      }
    }
  }
  out.Restore(lo, size, std::move(values));
  return out;
}

ProbabilityGrid TiledProbabilityGrid::ToGrid() const {
  if (tiles_.empty()) {
    return ProbabilityGrid(frame_.resolution(), frame_.origin(), frame_.min_probability(), frame_.max_probability());
  }
  int tx0 = std::numeric_limits<int>::max(), ty0 = tx0, tx1 = std::numeric_limits<int>::min(), ty1 = tx1;
  for (const auto& [key, tile] : tiles_) {
    const int tx = static_cast<int>(static_cast<std::uint64_t>(key) >> 32);
    const int ty = static_cast<int>(static_cast<std::uint32_t>(key));
    tx0 = std::min(tx0, tx);
    tx1 = std::max(tx1, tx);
    ty0 = std::min(ty0, ty);
    ty1 = std::max(ty1, ty);
  }
  ProbabilityGrid grid = Window(Cell(tx0 * kTileSide, ty0 * kTileSide),
                                Cell(tx1 * kTileSide + kTileSide - 1, ty1 * kTileSide + kTileSide - 1));
  grid.ShrinkToKnown();
  return grid;
}

std::size_t TiledProbabilityGrid::unshared_tile_count() const {
  std::size_t n = 0;
  for (const auto& [key, tile] : tiles_) n += tile.use_count() == 1 ? 1 : 0;
  return n;
}

void TiledProbabilityGrid::TileAddresses(std::vector<const void*>* out) const {
  for (const auto& [key, tile] : tiles_) out->push_back(tile.get());
}

}  // namespace lidar
}  // namespace tether
