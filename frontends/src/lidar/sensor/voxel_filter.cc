#include "tether/frontends/lidar/sensor/voxel_filter.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <unordered_map>

#include "tether/core/error.h"

namespace tether {
namespace lidar {

namespace {

struct CellHash {
  std::size_t operator()(const std::pair<std::int64_t, std::int64_t>& c) const {
    // Unsigned: the products wrap instead of overflowing.
    return std::hash<std::uint64_t>()(static_cast<std::uint64_t>(c.first) * 73856093ULL) ^
           std::hash<std::uint64_t>()(static_cast<std::uint64_t>(c.second) * 19349663ULL);
  }
};

}  // namespace

std::vector<Eigen::Vector2d> VoxelFilter(const std::vector<Eigen::Vector2d>& points, double edge) {
  if (!(edge > 0) || !std::isfinite(edge)) {
    throw InvalidArgument("VoxelFilter: the cell edge must be positive and finite, got " + std::to_string(edge));
  }
  struct Cell {
    Eigen::Vector2d sum = Eigen::Vector2d::Zero();
    int count = 0;
  };
  std::unordered_map<std::pair<std::int64_t, std::int64_t>, std::size_t, CellHash> index;
  std::vector<Cell> cells;
  for (const Eigen::Vector2d& p : points) {
    if (!p.allFinite()) continue;
    // Clamped before the cast (beyond int64 it would be undefined); such points share a cell.
    constexpr double kFar = 4e18;
    const std::pair<std::int64_t, std::int64_t> key(
        static_cast<std::int64_t>(std::clamp(std::floor(p.x() / edge), -kFar, kFar)),
        static_cast<std::int64_t>(std::clamp(std::floor(p.y() / edge), -kFar, kFar)));
    const auto it = index.emplace(key, cells.size());
    if (it.second) cells.emplace_back();
    Cell& c = cells[it.first->second];
    c.sum += p;
    ++c.count;
  }
  std::vector<Eigen::Vector2d> out;
  out.reserve(cells.size());
  for (const Cell& c : cells) out.push_back(c.sum / c.count);
  return out;
}

}  // namespace lidar
}  // namespace tether
