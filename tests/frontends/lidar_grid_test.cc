// The LiDAR front-end's grids: ray casting, inserting scans (hit and miss cells, once per scan,
// hits win, the odds update), and submaps (two active, overlapping; finished ones frozen).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <set>

#include "tether/core/error.h"
#include "tether/frontends/lidar/mapping/probability_grid_inserter.h"
#include "tether/frontends/lidar/mapping/submap_2d.h"

namespace tether {
namespace lidar {
namespace {

using Cell = ProbabilityGrid::Cell;
using CellSet = std::set<std::pair<int, int>>;

CellSet ToSet(const std::vector<Cell>& cells) {
  CellSet s;
  for (const Cell& c : cells) s.insert({c.x(), c.y()});
  return s;
}

TEST(CastRay, AxisAlignedAndDiagonal) {
  const ProbabilityGrid g(0.05);
  std::vector<Cell> cells;
  CastRay(g, Eigen::Vector2d(0.025, 0.025), Eigen::Vector2d(0.525, 0.025), &cells);
  ASSERT_EQ(cells.size(), 10u);
  for (int i = 0; i < 10; ++i) EXPECT_TRUE((cells[i] == Cell(i, 0)).all()) << i;
  cells.clear();
  CastRay(g, Eigen::Vector2d(0.02, 0.02), Eigen::Vector2d(-0.13, 0.021), &cells);  // leftwards
  ASSERT_EQ(cells.size(), 3u);
  EXPECT_TRUE((cells[2] == Cell(-2, 0)).all());
  cells.clear();
  CastRay(g, Eigen::Vector2d(0.01, 0.01), Eigen::Vector2d(0.01, 0.02), &cells);  // same cell
  EXPECT_TRUE(cells.empty());
  cells.clear();
  // A shallow diagonal: every step moves to a 4-neighbour, ending next to the hit's cell.
  CastRay(g, Eigen::Vector2d(0.01, 0.01), Eigen::Vector2d(0.93, 0.31), &cells);
  ASSERT_EQ(cells.size(), 18u + 6u);
  for (std::size_t i = 1; i < cells.size(); ++i) EXPECT_EQ((cells[i] - cells[i - 1]).abs().sum(), 1);
  EXPECT_EQ((cells.back() - Cell(18, 6)).abs().sum(), 1);
  EXPECT_THROW(CastRay(g, Eigen::Vector2d(0, 0), Eigen::Vector2d(std::nan(""), 0), &cells), InvalidArgument);
}

// True where the segment a-b passes through the open interior of the cell's box (slab test).
bool SegmentCrossesCell(const ProbabilityGrid& g, const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Cell& c) {
  const Eigen::Vector2d lo = g.origin() + g.resolution() * c.cast<double>().matrix();
  const Eigen::Vector2d hi = lo + Eigen::Vector2d::Constant(g.resolution());
  double t0 = 0, t1 = 1;
  for (int k = 0; k < 2; ++k) {
    const double d = b[k] - a[k];
    if (std::abs(d) < 1e-15) {
      if (a[k] < lo[k] || a[k] > hi[k]) return false;
      continue;
    }
    double ta = (lo[k] - a[k]) / d, tb = (hi[k] - a[k]) / d;
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  return t1 >= t0 - 1e-9;
}

TEST(CastRay, ExactlyTheCellsTheSegmentCrosses) {
  const ProbabilityGrid g(0.05, Eigen::Vector2d(0.013, -0.007));
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-2, 2);
  for (int trial = 0; trial < 300; ++trial) {
    const Eigen::Vector2d a(u(rng), u(rng)), b(u(rng), u(rng));
    std::vector<Cell> cells;
    CastRay(g, a, b, &cells);
    const CellSet cast = ToSet(cells);
    EXPECT_EQ(cast.size(), cells.size()) << "a cell twice";
    // Dense samples of the segment (the end's cell excluded) all lie in cast cells ...
    const Cell end = g.CellOf(b);
    for (int i = 0; i <= 20000; ++i) {
      const Cell c = g.CellOf(a + (b - a) * (i / 20000.0));
      if ((c == end).all()) continue;
      EXPECT_EQ(cast.count({c.x(), c.y()}), 1u) << trial;
    }
    // ... and every cast cell touches the segment.
    for (const Cell& c : cells) EXPECT_TRUE(SegmentCrossesCell(g, a, b, c)) << trial;
    EXPECT_EQ(cast.count({end.x(), end.y()}), 0u);
  }
}

TEST(ProbabilityGridInserter, HitsAndDisjointMissesOncePerScan) {
  ProbabilityGrid g(0.1);
  const ProbabilityGridInserter inserter({}, g.min_probability(), g.max_probability());
  // Three beams from the origin: two ending in the same cell (one hit, updated once), and one
  // passing through the cell of a hit on its way further out (the hit wins).
  const Eigen::Vector2d origin(0.05, 0.05);
  const std::vector<Eigen::Vector2d> hits = {Eigen::Vector2d(0.55, 0.05), Eigen::Vector2d(0.58, 0.07),
                                             Eigen::Vector2d(0.35, 0.05), Eigen::Vector2d(0.05, 0.85)};
  InsertedCells cells;
  inserter.Insert(&g, origin, hits, &cells);
  const CellSet h = ToSet(cells.hits), m = ToSet(cells.misses);
  EXPECT_EQ(h, (CellSet{{5, 0}, {3, 0}, {0, 8}}));
  EXPECT_EQ(h.size(), cells.hits.size());
  EXPECT_EQ(m.size(), cells.misses.size());
  EXPECT_EQ(m, (CellSet{{0, 0}, {1, 0}, {2, 0}, {4, 0}, {0, 1}, {0, 2}, {0, 3}, {0, 4}, {0, 5}, {0, 6}, {0, 7}}));
  for (const auto& c : h) EXPECT_NEAR(g.Probability(Cell(c.first, c.second)), 0.55, 2e-5);
  for (const auto& c : m) EXPECT_NEAR(g.Probability(Cell(c.first, c.second)), 0.49, 2e-5);
  EXPECT_FALSE(g.IsKnown(Cell(6, 0)));
  EXPECT_EQ(g.pending_updates(), 0u);  // marks cleared
  // The same scan again: every cell's odds multiply once more.
  inserter.Insert(&g, origin, hits, &cells);
  const double oh = 0.55 / 0.45, om = 0.49 / 0.51;
  EXPECT_NEAR(g.Probability(Cell(3, 0)), oh * oh / (1 + oh * oh), 5e-5);
  EXPECT_NEAR(g.Probability(Cell(0, 0)), om * om / (1 + om * om), 5e-5);
  // Hits only.
  GridInsertOptions no_free;
  no_free.insert_free_space = false;
  ProbabilityGrid g2(0.1);
  ProbabilityGridInserter(no_free, g2.min_probability(), g2.max_probability()).Insert(&g2, origin, hits, &cells);
  EXPECT_TRUE(cells.misses.empty());
  EXPECT_FALSE(g2.IsKnown(Cell(0, 0)));
}

TEST(ProbabilityGridInserter, BadInputIsAClearError) {
  ProbabilityGrid g(0.1);
  GridInsertOptions o;
  o.hit_probability = 0.4;
  EXPECT_THROW(ProbabilityGridInserter(o, 0.12, 0.97), InvalidArgument);
  o = GridInsertOptions();
  o.miss_probability = 0.5;
  std::string why;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("miss_probability"), std::string::npos);
  const ProbabilityGridInserter other({}, 0.1, 0.9);
  try {
    other.Insert(&g, Eigen::Vector2d::Zero(), {Eigen::Vector2d(1, 0)});
    FAIL() << "no error";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("probability range"), std::string::npos) << e.what();
  }
  const ProbabilityGridInserter ok({}, 0.12, 0.97);
  EXPECT_THROW(ok.Insert(&g, Eigen::Vector2d::Zero(), {Eigen::Vector2d(std::nan(""), 0)}), InvalidArgument);
  EXPECT_THROW(ok.Insert(&g, Eigen::Vector2d(INFINITY, 0), {Eigen::Vector2d(1, 0)}), InvalidArgument);
}

std::vector<Eigen::Vector2d> Arc(double radius, const Eigen::Vector2d& centre) {
  std::vector<Eigen::Vector2d> pts;
  for (int i = 0; i < 36; ++i) pts.push_back(centre + radius * Eigen::Vector2d(std::cos(i * 0.17), std::sin(i * 0.17)));
  return pts;
}

TEST(ActiveSubmaps2D, TwoOverlapAndFinishedOnesAreFrozen) {
  SubmapOptions o;
  o.scans_per_submap = 4;
  ActiveSubmaps2D maps(o);
  EXPECT_EQ(maps.matching_submap(), nullptr);
  std::vector<std::size_t> active_sizes;
  for (int i = 0; i < 11; ++i) {
    const SE2d pose(0.1 * i, 0, 0);
    maps.InsertScan(pose, pose.translation(), Arc(2.0, pose.translation()));
    active_sizes.push_back(maps.active().size());
    // After the first half submap, the matching submap holds at least half a submap.
    if (i >= 1) {
      EXPECT_GE(maps.matching_submap()->num_scans(), 2) << i;
    }
    for (const auto& s : maps.active()) EXPECT_FALSE(s->finished());
  }
  // Submaps start at scans 0, 2, 4, 6, 8, 10; each holds 4 scans.
  ASSERT_EQ(maps.submaps().size(), 6u);
  for (int k = 0; k < 6; ++k) EXPECT_DOUBLE_EQ(maps.submaps()[k]->local_pose().x(), 0.2 * k) << k;
  for (int k = 0; k < 4; ++k) {
    EXPECT_TRUE(maps.submaps()[k]->finished()) << k;
    EXPECT_EQ(maps.submaps()[k]->num_scans(), 4) << k;
  }
  EXPECT_EQ(maps.submaps()[4]->num_scans(), 3);
  EXPECT_EQ(maps.submaps()[5]->num_scans(), 1);
  EXPECT_EQ(active_sizes, (std::vector<std::size_t>{1, 1, 2, 1, 2, 1, 2, 1, 2, 1, 2}));

  // A finished submap is frozen: further scans leave its grid as it was, and inserting into
  // it directly is an error.
  const auto first = maps.submaps()[0];
  const ProbabilityGrid before = *first->grid();
  for (int i = 0; i < 4; ++i) maps.InsertScan(SE2d(), Eigen::Vector2d::Zero(), Arc(1.0, Eigen::Vector2d::Zero()));
  EXPECT_EQ(first->num_scans(), 4);
  const Cell c = first->grid()->CellOf(Eigen::Vector2d(1.0, 0.0));
  EXPECT_EQ(first->grid()->Value(c), before.Value(c));
  EXPECT_NE(maps.submaps().back()->grid()->Value(c), ProbabilityGrid::kUnknownValue);
  const ProbabilityGridInserter inserter(o.insert, o.min_probability, o.max_probability);
  try {
    maps.submaps()[0]->InsertScan(inserter, Eigen::Vector2d::Zero(), Arc(1.0, Eigen::Vector2d::Zero()));
    FAIL() << "no error";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("finished"), std::string::npos) << e.what();
  }
}

// Scans a metre apart (a log recorded with a coarse motion filter): a submap is finished by the
// distance travelled over its scans, not only by their number.
TEST(ActiveSubmaps2D, ASubmapIsFinishedByTheDistanceTravelled) {
  SubmapOptions o;
  o.max_submap_travel = 10;
  ActiveSubmaps2D maps(o);
  for (int i = 0; i < 40; ++i) {
    const SE2d pose(1.0 * i, 0, 0);
    maps.InsertScan(pose, pose.translation(), Arc(2.0, pose.translation()));
  }
  // Each finished submap spans 10 m (11 scans); the next one starts with the scan after the one
  // that took the last 5 m along.
  int finished = 0;
  for (std::size_t k = 0; k < maps.submaps().size(); ++k) {
    const auto& s = maps.submaps()[k];
    EXPECT_DOUBLE_EQ(s->local_pose().x(), 6.0 * static_cast<double>(k)) << k;
    if (!s->finished()) continue;
    ++finished;
    EXPECT_EQ(s->num_scans(), 11) << k;
    EXPECT_DOUBLE_EQ(s->travel(), 10.0) << k;
  }
  EXPECT_EQ(finished, 5);
  // By scans only, the same scans stay in one submap and the one started at half of it.
  o.max_submap_travel = 0;
  ActiveSubmaps2D by_scans(o);
  for (int i = 0; i < 40; ++i) {
    const SE2d pose(1.0 * i, 0, 0);
    by_scans.InsertScan(pose, pose.translation(), Arc(2.0, pose.translation()));
  }
  ASSERT_EQ(by_scans.submaps().size(), 1u);
  EXPECT_FALSE(by_scans.submaps()[0]->finished());
  EXPECT_DOUBLE_EQ(by_scans.submaps()[0]->travel(), 39.0);
  o.max_submap_travel = -1;
  EXPECT_THROW(ActiveSubmaps2D bad(o), InvalidArgument);
  o.max_submap_travel = std::nan("");
  EXPECT_THROW(ActiveSubmaps2D bad(o), InvalidArgument);
}

TEST(ActiveSubmaps2D, OneScanPerSubmapAndBadOptions) {
  SubmapOptions o;
  o.scans_per_submap = 1;
  ActiveSubmaps2D maps(o);
  for (int i = 0; i < 3; ++i) maps.InsertScan(SE2d(), Eigen::Vector2d::Zero(), Arc(1.0, Eigen::Vector2d::Zero()));
  EXPECT_EQ(maps.submaps().size(), 3u);
  for (const auto& s : maps.submaps()) EXPECT_TRUE(s->finished());
  EXPECT_EQ(maps.matching_submap(), maps.submaps().back());
  o.scans_per_submap = 0;
  EXPECT_THROW(ActiveSubmaps2D bad(o), InvalidArgument);
  o = SubmapOptions();
  o.resolution = -1;
  EXPECT_THROW(ActiveSubmaps2D bad(o), InvalidArgument);
  o = SubmapOptions();
  o.max_probability = 1;
  EXPECT_THROW(ActiveSubmaps2D bad(o), InvalidArgument);
}

}  // namespace
}  // namespace lidar
}  // namespace tether
