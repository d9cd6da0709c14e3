// Factors in a solve: a graph of each of RangeBearing2, ScanMatchSE2 and the SE3 offset edges
// (EDGE_SE3_TRACKXYZ, EDGE_SE3_PRIOR through PARAMS_SE3OFFSET) solved back to its truth, and a
// start the solver refuses, naming the factor. The factors' own tests, which need no solver,
// are in tests/factors (range_bearing_test.cc, scan_match_factor_test.cc,
// se3_offset_io_test.cc).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "testing/read_text.h"
#include "tether/core/factor_graph.h"
#include "tether/core/graph_io.h"
#include "tether/core/values.h"
#include "tether/factors/between_se2.h"
#include "tether/factors/prior.h"
#include "tether/factors/probability_grid.h"
#include "tether/factors/range_bearing.h"
#include "tether/factors/scan_match_se2.h"
#include "tether/solvers/optimizer.h"

namespace tether {
namespace {

using Cell = ProbabilityGrid::Cell;

// A 6x6 information matrix in g2o's upper-triangle order: 100 for the translation, 400 for
// the rotation.
const std::string kPrior21 = " 100 0 0 0 0 0 100 0 0 0 0 100 0 0 0 400 0 0 400 0 400";

TEST(RangeBearing2Test, LandmarkOnThePoseIsNotEvaluated) {
  Values v;
  v.Insert(1, SE2d(1, 2, 0.3));
  v.Insert(2, Eigen::Vector2d(1, 2));
  const RangeBearing2 f(1, 2, 0.0, 0.0, SqrtInformation::Identity(2));
  const std::vector<const double*> p = f.GatherParams(v);
  double e[2] = {0, 0}, j0[6], j1[4];
  double* jac[2] = {j0, j1};
  EXPECT_FALSE(f.Evaluate(p.data(), e, jac));
  EXPECT_FALSE(f.Evaluate(p.data(), e, nullptr));
  // Just outside kMinRange everything is finite.
  v.Update(2, Eigen::Vector2d(1 + 1e-8, 2));
  const std::vector<const double*> q = f.GatherParams(v);
  ASSERT_TRUE(f.Evaluate(q.data(), e, jac));
  for (double x : e) EXPECT_TRUE(std::isfinite(x));
  for (double x : j0) EXPECT_TRUE(std::isfinite(x));
  for (double x : j1) EXPECT_TRUE(std::isfinite(x));
  // The solver refuses such a start naming the factor.
  FactorGraph g;
  g.Add(std::make_unique<PriorSE2>(1, SE2d(1, 2, 0.3), SqrtInformation::Identity(3)));
  g.Add(std::make_unique<RangeBearing2>(1, 2, 1.0, 0.5, SqrtInformation::Identity(2)));
  Values start;
  start.Insert(1, SE2d(1, 2, 0.3));
  start.Insert(2, Eigen::Vector2d(1, 2));
  const SolverSummary s = Optimize(g, &start);
  EXPECT_EQ(s.status, SolverStatus::kInvalidInput);
  EXPECT_NE(s.message.find("RangeBearing2"), std::string::npos) << s.message;
}

TEST(RangeBearing2Test, SmallGraphSolvesToTheTruth) {
  // Three poses on a line, four landmarks around them, exact measurements; the start is the
  // truth disturbed, the prior on pose 0 fixes the gauge.
  std::vector<SE2d> poses = {SE2d(0, 0, 0), SE2d(2, 0, 0.3), SE2d(4, 1, 0.6)};
  std::vector<Eigen::Vector2d> marks = {{1, 3}, {3, -2}, {5, 4}, {-1, -1}};
  FactorGraph g;
  g.Add(std::make_unique<PriorSE2>(0, poses[0], SqrtInformation::Identity(3)));
  for (std::size_t i = 0; i + 1 < poses.size(); ++i) {
    g.Add(std::make_unique<BetweenSE2>(i, i + 1, poses[i].Inverse() * poses[i + 1], SqrtInformation::Identity(3)));
  }
  for (std::size_t i = 0; i < poses.size(); ++i) {
    for (std::size_t j = 0; j < marks.size(); ++j) {
      const Eigen::Vector2d d = poses[i].Inverse() * marks[j];
      g.Add(
          std::make_unique<RangeBearing2>(i, 10 + j, d.norm(), std::atan2(d.y(), d.x()), SqrtInformation::Identity(2)));
    }
  }
  Values v;
  for (std::size_t i = 0; i < poses.size(); ++i)
    v.Insert(i, SE2d(poses[i].x() + 0.2, poses[i].y() - 0.1, poses[i].theta() + 0.1));
  for (std::size_t j = 0; j < marks.size(); ++j)
    v.Insert(10 + j, Eigen::Vector2d(marks[j] + Eigen::Vector2d(0.3, 0.3)));
  const SolverSummary s = Optimize(g, &v);
  EXPECT_LT(s.final_chi2, 1e-16) << s.FullReport();
  for (std::size_t j = 0; j < marks.size(); ++j) EXPECT_LT((v.At<Eigen::Vector2d>(10 + j) - marks[j]).norm(), 1e-8);
}

TEST(ScanMatchSE2, SolvedAloneItMovesTheScanOntoTheHits) {
  // A grid with a bright cross; a scan of points on it, displaced: the solve brings it back.
  auto grid = std::make_shared<ProbabilityGrid>(0.05);
  for (int i = -40; i <= 40; ++i) {
    for (int j = -40; j <= 40; ++j) grid->SetProbability(Cell(i, j), 0.2);
  }
  // Lines three cells wide, brightest in the middle: a basin wider than one cell.
  for (int i = -40; i <= 40; ++i) {
    for (int d = -1; d <= 1; ++d) {
      const double p = d == 0 ? 0.95 : 0.6;
      grid->SetProbability(Cell(i, d), std::max(p, grid->Probability(Cell(i, d))));
      grid->SetProbability(Cell(d, i), std::max(p, grid->Probability(Cell(d, i))));
    }
  }
  std::vector<Eigen::Vector2d> pts;
  for (int i = -30; i <= 30; i += 3) {
    if (i == 0) continue;
    pts.push_back(grid->CellCenter(Cell(i, 0)));
    pts.push_back(grid->CellCenter(Cell(0, i)));
  }
  // The points are at the truth when the pose is the identity; start 2 cm and 1.5 degrees off.
  ScanMatchWeights w;
  w.translation = w.rotation = 1e-3;
  FactorGraph graph;
  graph.Add<ScanMatchSE2>(0, grid, pts, SE2d(0.02, -0.02, 0.026), w);
  Values values;
  values.Insert(0, SE2d(0.02, -0.02, 0.026));
  const double before = graph.at(0).Chi2(values);
  const SolverSummary summary = Optimize(graph, &values);
  EXPECT_TRUE(summary.status == SolverStatus::kConverged) << summary.BriefReport();
  const SE2d x = values.At<SE2d>(0);
  EXPECT_LT(graph.at(0).Chi2(values), before);
  EXPECT_LT(x.translation().norm(), 0.005);
  EXPECT_LT(std::abs(x.theta()), 0.005);
}

TEST(Se3OffsetIoTest, SmallGraphSolvesToTheTruth) {
  // Three poses, a prior on the first, odometry, and four points each seen from every pose
  // through a sensor offset; the vertices start away from the truth.
  const SE3d offset(Eigen::Quaterniond(Eigen::AngleAxisd(-0.4, Eigen::Vector3d::UnitY())),
                    Eigen::Vector3d(0.2, 0, 0.5));
  std::vector<SE3d> poses;
  for (int i = 0; i < 3; ++i) {
    poses.emplace_back(Eigen::Quaterniond(Eigen::AngleAxisd(0.3 * i, Eigen::Vector3d::UnitZ())),
                       Eigen::Vector3d(i, 0.5 * i, 0.1 * i));
  }
  const std::vector<Eigen::Vector3d> points = {{2, 3, 1}, {-1, 2, 0}, {3, -2, 2}, {1, 1, -1}};
  const auto params = [](const SE3d& x) {
    double p[7];
    x.ToParams(p);
    std::string s;
    for (double v : p) s += " " + FormatDouble(v);
    return s;
  };
  std::string text = "PARAMS_SE3OFFSET 0 0 0 0 0 0 0 1\nPARAMS_SE3OFFSET 1" + params(offset) + "\n";
  for (int i = 0; i < 3; ++i) {
    const SE3d start = poses[i] * SE3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitX())),
                                       Eigen::Vector3d(0.2, -0.1, 0.1));
    text += "VERTEX_SE3:QUAT " + std::to_string(i) + params(start) + "\n";
  }
  for (int j = 0; j < 4; ++j) {
    text += "VERTEX_TRACKXYZ " + std::to_string(10 + j) + " " + FormatDouble(points[j].x() + 0.3) + " " +
            FormatDouble(points[j].y()) + " " + FormatDouble(points[j].z() - 0.2) + "\n";
  }
  text += "EDGE_SE3_PRIOR 0 0" + params(poses[0]) + kPrior21 + "\n";
  for (int i = 0; i + 1 < 3; ++i) {
    text += "EDGE_SE3:QUAT " + std::to_string(i) + " " + std::to_string(i + 1) +
            params(poses[i].Inverse() * poses[i + 1]) + kPrior21 + "\n";
  }
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 4; ++j) {
      const Eigen::Vector3d z = (poses[i] * offset).Inverse() * points[j];
      text += "EDGE_SE3_TRACKXYZ " + std::to_string(i) + " " + std::to_string(10 + j) + " 1 " + FormatDouble(z.x()) +
              " " + FormatDouble(z.y()) + " " + FormatDouble(z.z()) + " 10 0 0 10 0 10\n";
    }
  }
  GraphFile g = testing::ReadText(text, "o.g2o");
  ASSERT_EQ(g.graph.size(), 15u);
  const SolverSummary s = Optimize(g.graph, &g.values);
  EXPECT_LT(s.final_chi2, 1e-14) << s.FullReport();
  for (int j = 0; j < 4; ++j) EXPECT_LT((g.values.At<Eigen::Vector3d>(10 + j) - points[j]).norm(), 1e-7);
  for (int i = 0; i < 3; ++i) EXPECT_LT((g.values.At<SE3d>(i).translation() - poses[i].translation()).norm(), 1e-7);
}

}  // namespace
}  // namespace tether
