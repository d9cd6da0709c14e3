// The tiled grid of a particle's map (frontends/lidar/mapping/tiled_probability_grid.h): it reads
// as the dense grid does after the same scans, and copies share tiles until one writes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <set>
#include <vector>

#include "tether/frontends/lidar/mapping/probability_grid_inserter.h"
#include "tether/frontends/lidar/mapping/tiled_probability_grid.h"

namespace tether {
namespace lidar {
namespace {

// A ring of walls seen from `origin`: points on a circle of radius r with some gaps.
std::vector<Eigen::Vector2d> Scan(const Eigen::Vector2d& origin, double r, std::mt19937* rng) {
  std::normal_distribution<double> noise(0, 0.02);
  std::vector<Eigen::Vector2d> points;
  for (int i = 0; i < 360; i += 2) {
    if (i % 40 < 4) continue;
    const double a = i * M_PI / 180;
    points.push_back(origin + (r + noise(*rng)) * Eigen::Vector2d(std::cos(a), std::sin(a)));
  }
  return points;
}

TEST(TiledProbabilityGridTest, ReadsAsTheDenseGridAfterTheSameScans) {
  const ProbabilityGridInserter inserter(GridInsertOptions(), ProbabilityGrid::kDefaultMinProbability,
                                         ProbabilityGrid::kDefaultMaxProbability);
  ProbabilityGrid dense(0.05, Eigen::Vector2d(-0.3, 0.7));
  TiledProbabilityGrid tiled(0.05, Eigen::Vector2d(-0.3, 0.7));
  std::mt19937 rng(1);
  // Scans around the origin, so that cells and tiles on both sides of zero are written.
  for (int k = 0; k < 12; ++k) {
    const Eigen::Vector2d origin(0.4 * k - 2.0, 0.25 * k - 1.5);
    const std::vector<Eigen::Vector2d> points = Scan(origin, 3.0 + 0.3 * k, &rng);
    inserter.Insert(&dense, origin, points);
    inserter.Insert(&tiled, origin, points);
  }
  int known = 0;
  for (int y = dense.min_cell().y() - 3; y < dense.min_cell().y() + dense.size().y() + 3; ++y) {
    for (int x = dense.min_cell().x() - 3; x < dense.min_cell().x() + dense.size().x() + 3; ++x) {
      const ProbabilityGrid::Cell c(x, y);
      ASSERT_EQ(tiled.Value(c), dense.Value(c)) << x << ", " << y;
      known += dense.IsKnown(c) ? 1 : 0;
    }
  }
  EXPECT_GT(known, 10000);
  // A window and the whole grid read the same again.
  const ProbabilityGrid::Cell lo(-70, -50), hi(40, 90);
  const ProbabilityGrid window = tiled.Window(lo, hi);
  for (int y = lo.y(); y <= hi.y(); ++y) {
    for (int x = lo.x(); x <= hi.x(); ++x) EXPECT_EQ(window.Value({x, y}), dense.Value({x, y}));
  }
  EXPECT_EQ(window.Value({lo.x() - 1, lo.y()}), ProbabilityGrid::kUnknownValue);  // outside: not copied
  const ProbabilityGrid whole = tiled.ToGrid();
  ProbabilityGrid::Cell a, b, c, d;
  ASSERT_TRUE(whole.KnownBounds(&a, &b));
  ASSERT_TRUE(dense.KnownBounds(&c, &d));
  EXPECT_TRUE((a == c).all() && (b == d).all());
  EXPECT_EQ(whole.values(), [&] {
    ProbabilityGrid copy = dense;
    copy.ShrinkToKnown();
    return copy.values();
  }());
}

// A particle's change is invisible to its siblings: a copy shares every tile, and a scan it
// inserts copies only the tiles the scan touches.
TEST(TiledProbabilityGridTest, CopiesShareTilesUntilTheyWrite) {
  const ProbabilityGridInserter inserter(GridInsertOptions(), ProbabilityGrid::kDefaultMinProbability,
                                         ProbabilityGrid::kDefaultMaxProbability);
  TiledProbabilityGrid parent(0.05);
  std::mt19937 rng(2);
  for (int k = 0; k < 10; ++k) {
    const Eigen::Vector2d origin(2.0 * k, 0);
    inserter.Insert(&parent, origin, Scan(origin, 4.0, &rng));
  }
  const std::size_t tiles = parent.tile_count();
  EXPECT_GT(tiles, 20u);
  EXPECT_EQ(parent.unshared_tile_count(), tiles);
  TiledProbabilityGrid child = parent, sibling = parent;
  EXPECT_EQ(parent.unshared_tile_count(), 0u);
  // The child sees a new wall near its end of the map.
  const Eigen::Vector2d origin(18.0, 0.5);
  const std::vector<Eigen::Vector2d> wall = {{19.0, 0.0}, {19.0, 0.5}, {19.0, 1.0}};
  const ProbabilityGrid::Cell cell = parent.CellOf(wall[1]);
  const std::uint16_t before = parent.Value(cell);
  inserter.Insert(&child, origin, wall);
  EXPECT_NE(child.Value(cell), before);
  EXPECT_EQ(parent.Value(cell), before);
  EXPECT_EQ(sibling.Value(cell), before);
  // Only the touched tiles were copied: the rest are still the same objects in all three.
  std::vector<const void*> p, c;
  parent.TileAddresses(&p);
  child.TileAddresses(&c);
  std::set<const void*> shared(p.begin(), p.end());
  std::size_t copied = 0;
  for (const void* t : c) copied += shared.count(t) == 0 ? 1 : 0;
  EXPECT_GE(copied, 1u);
  EXPECT_LE(copied, 4u);
  EXPECT_EQ(child.unshared_tile_count(), copied);
}

TEST(TiledProbabilityGridTest, NegativeCellsAndEmptyGrid) {
  TiledProbabilityGrid grid(0.1);
  EXPECT_EQ(grid.Value({-1, -1}), ProbabilityGrid::kUnknownValue);
  EXPECT_EQ(grid.ToGrid().size().x(), 0);
  const ProbabilityGrid frame(0.1);
  const std::vector<std::uint16_t> table = frame.ComputeUpdateTable(0.7);
  // Cells -64 and -65 lie in different tiles, -1 and 0 too: each keeps its own value.
  for (const int x : {-65, -64, -1, 0, 63, 64}) ASSERT_TRUE(grid.ApplyUpdate({x, -x}, table));
  EXPECT_FALSE(grid.ApplyUpdate({-1, 1}, table));  // once per insertion
  grid.FinishUpdate();
  for (const int x : {-65, -64, -1, 0, 63, 64}) EXPECT_NEAR(grid.Probability({x, -x}, 0.5), 0.7, 1e-3);
  EXPECT_EQ(grid.Value({-2, 2}), ProbabilityGrid::kUnknownValue);
  EXPECT_EQ(grid.tile_count(), 6u);
}

}  // namespace
}  // namespace lidar
}  // namespace tether
