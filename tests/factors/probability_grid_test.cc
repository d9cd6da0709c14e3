// ProbabilityGrid: geometry, quantisation, the odds update tables, once-per-scan marks, growth;
// the bicubic interpolation M_smooth: values at the samples, linear reproduction, gradients.
#include "tether/factors/probability_grid.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <random>

#include "tether/core/error.h"
#include "tether/factors/grid_interpolation.h"

namespace tether {
namespace {

using Cell = ProbabilityGrid::Cell;

TEST(ProbabilityGrid, CellsAndCentres) {
  const ProbabilityGrid g(0.05, Eigen::Vector2d(1.0, -2.0));
  EXPECT_TRUE((g.CellOf(Eigen::Vector2d(1.0, -2.0)) == Cell(0, 0)).all());
  EXPECT_TRUE((g.CellOf(Eigen::Vector2d(0.99, -2.01)) == Cell(-1, -1)).all());
  EXPECT_TRUE((g.CellOf(Eigen::Vector2d(1.26, -1.9)) == Cell(5, 2)).all());
  EXPECT_TRUE(g.CellCenter(Cell(5, 2)).isApprox(Eigen::Vector2d(1.275, -1.875)));
  EXPECT_TRUE((g.CellOf(g.CellCenter(Cell(-7, 11))) == Cell(-7, 11)).all());
}

TEST(ProbabilityGrid, UnknownReadsAsMinimumAndQuantisationIsFine) {
  ProbabilityGrid g(0.1);
  EXPECT_FALSE(g.IsKnown(Cell(3, 4)));
  EXPECT_DOUBLE_EQ(g.Probability(Cell(3, 4)), 0.12);
  Cell lo, hi;
  EXPECT_FALSE(g.KnownBounds(&lo, &hi));
  for (double p : {0.12, 0.3, 0.5, 0.55, 0.97}) {
    g.SetProbability(Cell(1, 1), p);
    EXPECT_NEAR(g.Probability(Cell(1, 1)), p, 2e-5);
  }
  g.SetProbability(Cell(1, 1), 0.01);  // clamped
  EXPECT_DOUBLE_EQ(g.Probability(Cell(1, 1)), 0.12);
  g.SetProbability(Cell(1, 1), 0.999);
  EXPECT_DOUBLE_EQ(g.Probability(Cell(1, 1)), 0.97);
  EXPECT_TRUE(g.KnownBounds(&lo, &hi));
  EXPECT_TRUE((lo == Cell(1, 1)).all() && (hi == Cell(1, 1)).all());
  EXPECT_THROW(g.SetProbability(Cell(0, 0), std::nan("")), InvalidArgument);
}

TEST(ProbabilityGrid, CellsOfAPoseAreTheCellsOfEachTransformedPoint) {
  const ProbabilityGrid g(0.05, Eigen::Vector2d(0.3, -0.7));
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-30, 30), a(-4, 4);
  std::vector<Eigen::Vector2d> points;
  for (int i = 0; i < 200; ++i) points.emplace_back(u(rng), u(rng));
  std::vector<Cell> cells;
  for (int trial = 0; trial < 20; ++trial) {
    const SE2d pose(u(rng), u(rng), a(rng));
    g.CellsOf(pose, points, &cells);
    ASSERT_EQ(cells.size(), points.size());
    for (std::size_t i = 0; i < points.size(); ++i) ASSERT_TRUE((cells[i] == g.CellOf(pose * points[i])).all()) << i;
  }
}

// Cropping the stored box to the known cells changes no cell's value, and the box becomes the
// known bounds; a box index reads the same values as the cells.
TEST(ProbabilityGrid, ShrinkToKnownKeepsEveryValueInTheKnownBounds) {
  ProbabilityGrid g(0.05);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> p(0.12, 0.97);
  std::uniform_int_distribution<int> c(-40, 90);
  for (int i = 0; i < 400; ++i) g.SetProbability(Cell(c(rng), c(rng) / 2), p(rng));
  g.SetProbability(Cell(300, -5), 0.8);  // grows the box by doubling, far past what is known
  const Cell old_size = g.size();
  std::vector<std::uint16_t> before;
  for (int y = -80; y < 120; ++y) {
    for (int x = -80; x < 400; ++x) before.push_back(g.Value(Cell(x, y)));
  }
  Cell lo, hi;
  ASSERT_TRUE(g.KnownBounds(&lo, &hi));
  g.ShrinkToKnown();
  EXPECT_TRUE((g.min_cell() == lo).all());
  EXPECT_TRUE((g.size() == hi - lo + 1).all());
  EXPECT_LT(g.size().prod(), old_size.prod());
  std::size_t k = 0;
  for (int y = -80; y < 120; ++y) {
    for (int x = -80; x < 400; ++x) ASSERT_EQ(g.Value(Cell(x, y)), before[k++]) << x << ", " << y;
  }
  // The box of cells lo .. lo + (2, 3) lies inside; one reaching past hi does not.
  const int at = g.BoxIndex(lo, lo + Cell(2, 3));
  ASSERT_GE(at, 0);
  EXPECT_EQ(g.ValueAt(at + 3 * g.stride() + 2), g.Value(lo + Cell(2, 3)));
  EXPECT_EQ(g.BoxIndex(lo, hi + Cell(1, 0)), -1);
  EXPECT_EQ(g.BoxIndex(lo - Cell(0, 1), hi), -1);
  // Writing after the shrink grows the box again.
  g.SetProbability(hi + Cell(5, 5), 0.9);
  EXPECT_NEAR(g.Probability(hi + Cell(5, 5)), 0.9, 2e-5);
  EXPECT_EQ(g.Value(Cell(300, -5)), before[static_cast<std::size_t>((-5 + 80) * 480 + 300 + 80)]);
}

TEST(ProbabilityGrid, ShrinkToKnownOfAnEmptyGridAndWhileUpdating) {
  ProbabilityGrid empty(0.1);
  empty.ShrinkToKnown();
  EXPECT_EQ(empty.size().prod(), 0);
  EXPECT_FALSE(empty.IsKnown(Cell(0, 0)));
  ProbabilityGrid g(0.1);
  const std::vector<std::uint16_t> hit = g.ComputeUpdateTable(0.55);
  g.ApplyUpdate(Cell(2, 2), hit);
  try {
    g.ShrinkToKnown();
    ADD_FAILURE() << "no error while an update is pending";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("FinishUpdate"), std::string::npos) << e.what();
  }
  g.FinishUpdate();
  g.ShrinkToKnown();
  EXPECT_TRUE((g.size() == Cell(1, 1)).all());
  EXPECT_NEAR(g.Probability(Cell(2, 2)), 0.55, 2e-5);
}

TEST(ProbabilityGrid, UpdateTableIsTheOddsProductClamped) {
  ProbabilityGrid g(0.05);
  const std::vector<std::uint16_t> hit = g.ComputeUpdateTable(0.55), miss = g.ComputeUpdateTable(0.49);
  // An unknown cell takes p itself.
  EXPECT_TRUE(g.ApplyUpdate(Cell(0, 0), hit));
  EXPECT_TRUE(g.ApplyUpdate(Cell(1, 0), miss));
  g.FinishUpdate();
  EXPECT_NEAR(g.Probability(Cell(0, 0)), 0.55, 2e-5);
  EXPECT_NEAR(g.Probability(Cell(1, 0)), 0.49, 2e-5);
  // Then odds multiply: odds(0.55)^2 and odds(0.49)^2.
  g.ApplyUpdate(Cell(0, 0), hit);
  g.ApplyUpdate(Cell(1, 0), miss);
  g.FinishUpdate();
  const double o_hit = 0.55 / 0.45, o_miss = 0.49 / 0.51;
  EXPECT_NEAR(g.Probability(Cell(0, 0)), o_hit * o_hit / (1 + o_hit * o_hit), 5e-5);
  EXPECT_NEAR(g.Probability(Cell(1, 0)), o_miss * o_miss / (1 + o_miss * o_miss), 5e-5);
  // Many hits reach the upper clamp, many misses the lower one, and stay there.
  for (int i = 0; i < 200; ++i) {
    g.ApplyUpdate(Cell(0, 0), hit);
    g.ApplyUpdate(Cell(1, 0), miss);
    g.FinishUpdate();
  }
  EXPECT_DOUBLE_EQ(g.Probability(Cell(0, 0)), 0.97);
  EXPECT_DOUBLE_EQ(g.Probability(Cell(1, 0)), 0.12);
  // Every table entry agrees with the formula, to the quantisation step.
  for (int v = 1; v <= ProbabilityGrid::kMaxValue; v += 97) {
    const double p = g.ValueToProbability(static_cast<std::uint16_t>(v));
    const double want = std::min(0.97, std::max(0.12, ProbabilityFromOdds(Odds(p) * o_hit)));
    const auto got = static_cast<std::uint16_t>(hit[v] & ProbabilityGrid::kMaxValue);
    EXPECT_NEAR(g.ValueToProbability(got), want, 2e-5) << v;
    EXPECT_NE(hit[v] & ProbabilityGrid::kUpdateMarker, 0);
  }
  EXPECT_THROW(g.ComputeUpdateTable(1.0), InvalidArgument);
  EXPECT_THROW(g.ComputeUpdateTable(0.0), InvalidArgument);
}

TEST(ProbabilityGrid, ACellIsUpdatedOncePerScanEvenAcrossGrowth) {
  ProbabilityGrid g(0.05);
  const auto hit = g.ComputeUpdateTable(0.55), miss = g.ComputeUpdateTable(0.49);
  EXPECT_TRUE(g.ApplyUpdate(Cell(0, 0), hit));
  EXPECT_FALSE(g.ApplyUpdate(Cell(0, 0), miss));  // hits first: the hit wins
  EXPECT_FALSE(g.ApplyUpdate(Cell(0, 0), hit));
  // Growing the box (far away, both sides) keeps the marks on the right cells.
  EXPECT_TRUE(g.ApplyUpdate(Cell(-500, 300), hit));
  EXPECT_TRUE(g.ApplyUpdate(Cell(400, -200), miss));
  EXPECT_FALSE(g.ApplyUpdate(Cell(0, 0), hit));
  EXPECT_FALSE(g.ApplyUpdate(Cell(-500, 300), miss));
  EXPECT_EQ(g.pending_updates(), 3u);
  g.FinishUpdate();
  EXPECT_EQ(g.pending_updates(), 0u);
  EXPECT_NEAR(g.Probability(Cell(0, 0)), 0.55, 2e-5);
  EXPECT_NEAR(g.Probability(Cell(-500, 300)), 0.55, 2e-5);
  EXPECT_NEAR(g.Probability(Cell(400, -200)), 0.49, 2e-5);
  EXPECT_LE(g.min_cell().x(), -500);
  EXPECT_GE(g.min_cell().x() + g.size().x() - 1, 400);
  Cell lo, hi;
  ASSERT_TRUE(g.KnownBounds(&lo, &hi));
  EXPECT_TRUE((lo == Cell(-500, -200)).all());
  EXPECT_TRUE((hi == Cell(400, 300)).all());
  EXPECT_TRUE(g.ApplyUpdate(Cell(0, 0), hit));  // marks cleared
}

// The lookup table against computing the odds product per update (what a grid of doubles
// would do): the same values, and the time of each (printed; RESULTS has the figures).
TEST(ProbabilityGrid, TableUpdateEqualsTheFormulaAndItsTimeIsReported) {
  ProbabilityGrid g(0.05);
  const auto hit = g.ComputeUpdateTable(0.55);
  std::vector<std::uint16_t> cells(1 << 20);
  std::mt19937 rng(9);
  for (auto& c : cells) c = static_cast<std::uint16_t>(1 + rng() % ProbabilityGrid::kMaxValue);
  std::vector<std::uint16_t> by_table = cells, by_formula = cells;
  std::vector<double> as_double(cells.size());
  for (std::size_t i = 0; i < cells.size(); ++i) as_double[i] = g.ValueToProbability(cells[i]);
  const double odds = Odds(0.55);
  const auto t0 = std::chrono::steady_clock::now();
  for (auto& c : by_table) c = static_cast<std::uint16_t>(hit[c] & ProbabilityGrid::kMaxValue);
  const auto t1 = std::chrono::steady_clock::now();
  for (auto& c : by_formula) c = g.ProbabilityToValue(ProbabilityFromOdds(Odds(g.ValueToProbability(c)) * odds));
  const auto t2 = std::chrono::steady_clock::now();
  for (double& p : as_double) p = std::min(0.97, std::max(0.12, ProbabilityFromOdds(Odds(p) * odds)));
  const auto t3 = std::chrono::steady_clock::now();
  EXPECT_EQ(by_table, by_formula);
  for (std::size_t i = 0; i < cells.size(); i += 1000)
    EXPECT_NEAR(g.ValueToProbability(by_table[i]), as_double[i], 2e-5);
  const auto ns = [&](auto a, auto b) {
    return std::chrono::duration<double, std::nano>(b - a).count() / cells.size();
  };
  std::cout << "per cell update: table " << ns(t0, t1) << " ns, formula on 15-bit values " << ns(t1, t2)
            << " ns, formula on doubles " << ns(t2, t3) << " ns (2 bytes a cell against 8)\n";
}

TEST(ProbabilityGrid, BadConstructionIsAClearError) {
  EXPECT_THROW(ProbabilityGrid(0), InvalidArgument);
  EXPECT_THROW(ProbabilityGrid(-0.05), InvalidArgument);
  EXPECT_THROW(ProbabilityGrid(0.05, Eigen::Vector2d(std::nan(""), 0)), InvalidArgument);
  EXPECT_THROW(ProbabilityGrid(0.05, Eigen::Vector2d::Zero(), 0.6, 0.4), InvalidArgument);
  EXPECT_THROW(ProbabilityGrid(0.05, Eigen::Vector2d::Zero(), 0.0, 0.9), InvalidArgument);
  try {
    ProbabilityGrid g(0.05);
    g.SetProbability(Cell(0, 0), 0.5);
    g.SetProbability(Cell(100000000, 0), 0.5);
    FAIL() << "no error";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("far outside"), std::string::npos) << e.what();
  }
}

ProbabilityGrid RandomGrid(std::mt19937& rng, double resolution) {
  ProbabilityGrid g(resolution, Eigen::Vector2d(0.3, -0.2));
  std::uniform_real_distribution<double> u(0.12, 0.97);
  for (int y = -2; y < 14; ++y)
    for (int x = -2; x < 14; ++x) g.SetProbability(Cell(x, y), u(rng));
  return g;
}

TEST(GridInterpolation, PassesThroughTheSamples) {
  std::mt19937 rng(1);
  const ProbabilityGrid g = RandomGrid(rng, 0.05);
  for (int y = 0; y < 12; ++y)
    for (int x = 0; x < 12; ++x)
      EXPECT_NEAR(InterpolateProbability(g, g.CellCenter(Cell(x, y))), g.Probability(Cell(x, y)), 1e-12);
  // Far from any known cell: the minimum probability, with a zero gradient.
  Eigen::Vector2d grad;
  EXPECT_DOUBLE_EQ(InterpolateProbability(g, Eigen::Vector2d(50, 50), &grad), 0.12);
  EXPECT_EQ(grad, Eigen::Vector2d::Zero());
  // Or the value given for unknown cells, which changes nothing where every sample is known.
  EXPECT_DOUBLE_EQ(InterpolateProbability(g, Eigen::Vector2d(50, 50), &grad, 0.5), 0.5);
  EXPECT_DOUBLE_EQ(g.Probability(Cell(1000, 0), 0.5), 0.5);
  const Eigen::Vector2d inside = g.CellCenter(Cell(5, 5)) + Eigen::Vector2d(0.01, 0.02);
  EXPECT_DOUBLE_EQ(InterpolateProbability(g, inside, nullptr, 0.5), InterpolateProbability(g, inside));
  // Next to the known block, the unknown neighbours pull the value towards what they read as.
  const Eigen::Vector2d edge = g.CellCenter(Cell(-2, 5)) - Eigen::Vector2d(0.02, 0);
  EXPECT_GT(InterpolateProbability(g, edge, nullptr, 0.9), InterpolateProbability(g, edge, nullptr, 0.12));
}

TEST(GridInterpolation, ReproducesALinearFunction) {
  ProbabilityGrid g(0.1);
  const auto f = [](const Eigen::Vector2d& p) { return 0.5 + 0.02 * p.x() - 0.015 * p.y(); };
  for (int y = -5; y < 15; ++y)
    for (int x = -5; x < 15; ++x) g.SetProbability(Cell(x, y), f(g.CellCenter(Cell(x, y))));
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> u(0.1, 0.9);
  for (int i = 0; i < 100; ++i) {
    const Eigen::Vector2d p(u(rng), u(rng));
    Eigen::Vector2d grad;
    EXPECT_NEAR(InterpolateProbability(g, p, &grad), f(p), 1e-4);  // quantisation: 2.6e-5 per sample
    EXPECT_NEAR(grad.x(), 0.02, 2e-3);
    EXPECT_NEAR(grad.y(), -0.015, 2e-3);
  }
}

TEST(GridInterpolation, GradientMatchesCentralDifferences) {
  std::mt19937 rng(3);
  const ProbabilityGrid g = RandomGrid(rng, 0.05);
  std::uniform_real_distribution<double> u(0.35, 0.8);
  double max_gradient = 0;
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector2d p(u(rng), u(rng) - 0.5);
    Eigen::Vector2d grad;
    InterpolateProbability(g, p, &grad);
    const double h = 1e-7;
    for (int a = 0; a < 2; ++a) {
      const Eigen::Vector2d e = Eigen::Vector2d::Unit(a) * h;
      const double numeric = (InterpolateProbability(g, p + e) - InterpolateProbability(g, p - e)) / (2 * h);
      EXPECT_NEAR(grad[a], numeric, 1e-5 * (1 + std::abs(numeric))) << p.transpose();
      max_gradient = std::max(max_gradient, std::abs(grad[a]));
    }
  }
  EXPECT_GT(max_gradient, 1.0);  // the random grid is not flat: the check compared real slopes
}

TEST(GridInterpolation, ContinuousAcrossCellBoundaries) {
  std::mt19937 rng(4);
  const ProbabilityGrid g = RandomGrid(rng, 0.05);
  // Cell centres are the interpolation's knots: approach one from both sides.
  const Eigen::Vector2d knot = g.CellCenter(Cell(5, 6));
  for (int a = 0; a < 2; ++a) {
    const Eigen::Vector2d e = Eigen::Vector2d::Unit(a) * 1e-9;
    Eigen::Vector2d gl, gr;
    const double l = InterpolateProbability(g, knot - e, &gl), r = InterpolateProbability(g, knot + e, &gr);
    EXPECT_NEAR(l, r, 1e-7);
    EXPECT_NEAR(gl[a], gr[a], 1e-5);
  }
}

}  // namespace
}  // namespace tether
