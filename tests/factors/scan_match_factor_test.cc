// ScanMatchSE2: its error against the definition, its Jacobians against central differences,
// its noise model (the weights), bad input, and that g2o files refuse it with a clear error.
// Solved alone: tests/solvers/factor_solves_test.cc.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <random>
#include <sstream>

#include "testing/jacobian_check.h"
#include "tether/core/error.h"
#include "tether/core/factor_graph.h"
#include "tether/core/graph_io.h"
#include "tether/core/values.h"
#include "tether/factors/builtin.h"
#include "tether/factors/grid_interpolation.h"
#include "tether/factors/scan_match_se2.h"

namespace tether {
namespace {

using Cell = ProbabilityGrid::Cell;

std::shared_ptr<ProbabilityGrid> SmoothRandomGrid(unsigned seed) {
  auto g = std::make_shared<ProbabilityGrid>(0.05, Eigen::Vector2d(-1.0, -1.0));
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.12, 0.97);
  for (int y = 0; y < 40; ++y)
    for (int x = 0; x < 40; ++x) g->SetProbability(Cell(x, y), u(rng));
  return g;
}

std::vector<Eigen::Vector2d> RandomPoints(std::mt19937& rng, int n) {
  std::uniform_real_distribution<double> u(-0.6, 0.6);
  std::vector<Eigen::Vector2d> pts;
  for (int i = 0; i < n; ++i) pts.emplace_back(u(rng), u(rng));
  return pts;
}

TEST(ScanMatchSE2, ErrorIsOneMinusSmoothProbabilityThenRegularisers) {
  const auto grid = SmoothRandomGrid(1);
  std::mt19937 rng(2);
  const std::vector<Eigen::Vector2d> pts = RandomPoints(rng, 7);
  const SE2d guess(0.05, -0.02, 0.3), x(0.1, 0.03, 0.25 + 2 * 3.14159265358979);
  ScanMatchWeights w;
  w.translation = 10;
  w.rotation = 40;
  const ScanMatchSE2 f(4, grid, pts, guess, w);
  ASSERT_EQ(f.residual_dim(), 10);
  ASSERT_EQ(f.dim(), 10);
  EXPECT_NO_THROW(f.CheckShape());
  double params[3] = {x.x(), x.y(), 0.25 + 2 * 3.14159265358979};
  const double* p[1] = {params};
  std::vector<double> e(10);
  ASSERT_TRUE(f.Evaluate(p, e.data(), nullptr));
  for (int k = 0; k < 7; ++k) EXPECT_NEAR(e[k], 1 - InterpolateProbability(*grid, x * pts[k], nullptr, 0.5), 1e-12);
  // A point where no cell is known reads unknown_probability (0.5 by default).
  const ScanMatchSE2 far(4, grid, {Eigen::Vector2d(100, 100)}, guess);
  ASSERT_TRUE(far.Evaluate(p, e.data(), nullptr));
  EXPECT_DOUBLE_EQ(e[0], 0.5);
  EXPECT_NEAR(e[7], 0.05, 1e-12);
  EXPECT_NEAR(e[8], 0.05, 1e-12);
  EXPECT_NEAR(e[9], -0.05, 1e-9);  // wrapped
  // Whitening: occupied_space / sqrt(N) on the points, translation and rotation weights after.
  const Eigen::MatrixXd info = f.noise().Information();
  EXPECT_NEAR(info(0, 0), 1.0 / 7, 1e-12);
  EXPECT_NEAR(info(7, 7), 100, 1e-9);
  EXPECT_NEAR(info(9, 9), 1600, 1e-9);
  EXPECT_NEAR(info(0, 1), 0, 1e-15);
  EXPECT_EQ(f.type_name(), "ScanMatchSE2");
  const std::unique_ptr<Factor> c = f.Clone();
  EXPECT_EQ(static_cast<const ScanMatchSE2&>(*c).grid(), grid);  // shares the grid
  EXPECT_EQ(f.weights().rotation, 40);
  EXPECT_EQ(ScanMatchWeights().translation, 1);  // the defaults
  EXPECT_EQ(ScanMatchWeights().rotation, 1);
}

TEST(ScanMatchSE2, JacobianMatchesNumeric) {
  const auto grid = SmoothRandomGrid(3);
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-1, 1);
  double largest = 0;
  for (int i = 0; i < 50; ++i) {
    ScanMatchWeights w;
    w.occupied_space = 1 + std::abs(u(rng));
    w.translation = 0.5 + std::abs(u(rng));
    w.rotation = 0.5 + std::abs(u(rng));
    const int n = 1 + i % 30;
    const SE2d guess(0.1 * u(rng), 0.1 * u(rng), 3.1 * u(rng));
    ScanMatchSE2 f(9, grid, RandomPoints(rng, n), guess, w);
    Values v;
    v.Insert(9, SE2d(0.2 * u(rng), 0.2 * u(rng), 3.1 * u(rng)));
    largest = std::max(largest, testing::CheckJacobians(f, v, 1e-5, {n + 2}));
  }
  EXPECT_LT(largest, 1e-5);
}

TEST(ScanMatchSE2, BadInputIsAClearError) {
  const auto grid = SmoothRandomGrid(5);
  const std::vector<Eigen::Vector2d> pts = {Eigen::Vector2d(1, 0)};
  EXPECT_THROW(ScanMatchSE2(0, nullptr, pts, SE2d()), InvalidArgument);
  EXPECT_THROW(ScanMatchSE2(0, grid, {}, SE2d()), InvalidArgument);
  EXPECT_THROW(ScanMatchSE2(0, grid, {Eigen::Vector2d(std::nan(""), 0)}, SE2d()), InvalidArgument);
  EXPECT_THROW(ScanMatchSE2(0, grid, pts, SE2d(std::nan(""), 0, 0)), InvalidArgument);
  ScanMatchWeights w;
  w.translation = 0;
  try {
    ScanMatchSE2(0, grid, pts, SE2d(), w);
    FAIL() << "no error";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("translation weight"), std::string::npos) << e.what();
  }
  w = ScanMatchWeights();
  w.occupied_space = std::nan("");
  EXPECT_FALSE(w.IsValid(nullptr));
  w = ScanMatchWeights();
  w.unknown_probability = -0.1;
  std::string why;
  EXPECT_FALSE(w.IsValid(&why));
  EXPECT_NE(why.find("unknown_probability"), std::string::npos) << why;
  // A pose that is not finite cannot be evaluated.
  const ScanMatchSE2 f(0, grid, pts, SE2d());
  double params[3] = {std::nan(""), 0, 0};
  const double* p[1] = {params};
  double e[4];
  EXPECT_FALSE(f.Evaluate(p, e, nullptr));
}

TEST(ScanMatchSE2, RegisteredWithoutAFileFormSoWritingIsAnError) {
  const Registry& r = DefaultRegistry();
  const FactorType* t = r.FindByName("ScanMatchSE2");
  ASSERT_NE(t, nullptr);
  EXPECT_TRUE(t->tag.empty());
  EXPECT_EQ(t->variable_types, std::vector<VarType>{VarType::kSE2});
  FactorGraph graph;
  graph.Add<ScanMatchSE2>(0, SmoothRandomGrid(6), std::vector<Eigen::Vector2d>{Eigen::Vector2d(0.2, 0)}, SE2d());
  Values values;
  values.Insert(0, SE2d());
  std::ostringstream out;
  try {
    WriteG2o(out, values, graph, r);
    FAIL() << "no error";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("ScanMatchSE2"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("no g2o tag"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace tether
