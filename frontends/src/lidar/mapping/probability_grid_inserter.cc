#include "tether/frontends/lidar/mapping/probability_grid_inserter.h"

#include <cmath>
#include <cstdlib>
#include <limits>

#include "tether/core/error.h"
#include "tether/core/registry.h"
#include "tether/frontends/lidar/mapping/tiled_probability_grid.h"

namespace tether {
namespace lidar {

bool GridInsertOptions::IsValid(std::string* why) const {
  const auto fail = [&](const std::string& m) {
    if (why != nullptr) *why = m;
    return false;
  };
  if (!(hit_probability > 0.5 && hit_probability < 1)) {
    return fail("hit_probability is " + FormatDouble(hit_probability) + "; it must lie in (0.5, 1) (e.g. 0.55)");
  }
  if (!(miss_probability > 0 && miss_probability < 0.5)) {
    return fail("miss_probability is " + FormatDouble(miss_probability) + "; it must lie in (0, 0.5) (e.g. 0.49)");
  }
  return true;
}

void CastRay(const ProbabilityGrid& grid, const Eigen::Vector2d& from, const Eigen::Vector2d& to,
             std::vector<ProbabilityGrid::Cell>* cells) {
  if (!from.allFinite() || !to.allFinite()) throw InvalidArgument("CastRay: an end of the ray is not finite");
  const Eigen::Vector2d u0 = (from - grid.origin()) / grid.resolution();
  const Eigen::Vector2d u1 = (to - grid.origin()) / grid.resolution();
  ProbabilityGrid::Cell cell = grid.CellOf(from);
  const ProbabilityGrid::Cell end = grid.CellOf(to);
  const Eigen::Vector2d d = u1 - u0;
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const int step_x = d.x() > 0 ? 1 : -1, step_y = d.y() > 0 ? 1 : -1;
  // Parameter t in [0, 1] along the segment at which the next x (y) cell boundary is crossed.
  double next_x = d.x() == 0 ? kInf : (d.x() > 0 ? cell.x() + 1 - u0.x() : u0.x() - cell.x()) / std::abs(d.x());
  double next_y = d.y() == 0 ? kInf : (d.y() > 0 ? cell.y() + 1 - u0.y() : u0.y() - cell.y()) / std::abs(d.y());
  const double delta_x = d.x() == 0 ? kInf : 1.0 / std::abs(d.x());
  const double delta_y = d.y() == 0 ? kInf : 1.0 / std::abs(d.y());
  // Exactly |dx| + |dy| steps reach the end cell; an axis already at the end's row or column
  // is never stepped (rounding cannot overshoot).
  while ((cell != end).any()) {
    cells->push_back(cell);
    const bool x_done = cell.x() == end.x(), y_done = cell.y() == end.y();
    if (y_done || (!x_done && next_x < next_y)) {
      cell.x() += step_x;
      next_x += delta_x;
    } else {
      cell.y() += step_y;
      next_y += delta_y;
    }
  }
}

ProbabilityGridInserter::ProbabilityGridInserter(const GridInsertOptions& options, double min_probability,
                                                 double max_probability)
    : options_(options), min_probability_(min_probability), max_probability_(max_probability) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("GridInsertOptions: " + why);
  const ProbabilityGrid prototype(1.0, Eigen::Vector2d::Zero(), min_probability, max_probability);
  hit_table_ = prototype.ComputeUpdateTable(options.hit_probability);
  miss_table_ = prototype.ComputeUpdateTable(options.miss_probability);
}

namespace {

// The one insertion, for a dense and a tiled grid: `frame` gives the cells of points (the grid
// itself where dense).
template <class Grid>
void InsertScan(Grid* grid, const ProbabilityGrid& frame, const std::vector<std::uint16_t>& hit_table,
                const std::vector<std::uint16_t>& miss_table, bool free_space, const Eigen::Vector2d& origin,
                const std::vector<Eigen::Vector2d>& hits, InsertedCells* cells) {
  if (!origin.allFinite()) throw InvalidArgument("ProbabilityGridInserter: the scan's origin is not finite");
  for (std::size_t i = 0; i < hits.size(); ++i) {
    if (!hits[i].allFinite()) {
      throw InvalidArgument("ProbabilityGridInserter: point " + std::to_string(i) + " of the scan is not finite");
    }
  }
  if (cells != nullptr) {
    cells->hits.clear();
    cells->misses.clear();
  }
  for (const Eigen::Vector2d& h : hits) {
    const ProbabilityGrid::Cell c = frame.CellOf(h);
    if (grid->ApplyUpdate(c, hit_table) && cells != nullptr) cells->hits.push_back(c);
  }
  if (free_space) {
    std::vector<ProbabilityGrid::Cell> ray;
    for (const Eigen::Vector2d& h : hits) {
      ray.clear();
      CastRay(frame, origin, h, &ray);
      for (const ProbabilityGrid::Cell& c : ray) {
        if (grid->ApplyUpdate(c, miss_table) && cells != nullptr) cells->misses.push_back(c);
      }
    }
  }
  grid->FinishUpdate();
}

}  // namespace

void ProbabilityGridInserter::CheckRange(double min_probability, double max_probability) const {
  if (min_probability != min_probability_ || max_probability != max_probability_) {
    throw InvalidArgument("ProbabilityGridInserter: the grid's probability range [" + FormatDouble(min_probability) +
                          ", " + FormatDouble(max_probability) + "] is not the inserter's [" +
                          FormatDouble(min_probability_) + ", " + FormatDouble(max_probability_) +
                          "]; build the inserter for the grid's range");
  }
}

void ProbabilityGridInserter::Insert(ProbabilityGrid* grid, const Eigen::Vector2d& origin,
                                     const std::vector<Eigen::Vector2d>& hits, InsertedCells* cells) const {
  CheckRange(grid->min_probability(), grid->max_probability());
  InsertScan(grid, *grid, hit_table_, miss_table_, options_.insert_free_space, origin, hits, cells);
}

void ProbabilityGridInserter::Insert(TiledProbabilityGrid* grid, const Eigen::Vector2d& origin,
                                     const std::vector<Eigen::Vector2d>& hits, InsertedCells* cells) const {
  CheckRange(grid->frame().min_probability(), grid->frame().max_probability());
  InsertScan(grid, grid->frame(), hit_table_, miss_table_, options_.insert_free_space, origin, hits, cells);
}

}  // namespace lidar
}  // namespace tether
