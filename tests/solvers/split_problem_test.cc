// A problem split between processes (LinearSolver::Partition): the variables' graph a solver
// partitions, and the shares of the factors whose sum is the whole problem. Checked here in one
// process (two shares built side by side); tests/distributed runs the split solve under mpirun.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <string>
#include <vector>

#include "problem.h"
#include "tether/factors/between_se2.h"
#include "tether/factors/pose_point.h"
#include "tether/factors/prior.h"

namespace tether {
namespace {

// Poses 0..3 in a loop (a closure 3-0), a point 4 seen from 1 and 2, a prior on 0; key 0 fixed
// where asked.
struct Small {
  FactorGraph graph;
  Values values;
  Small() {
    for (int i = 0; i < 4; ++i) values.Insert(i, SE2d(i * 1.0, 0.1 * i, 0.05 * i));
    values.Insert(4, Eigen::Vector2d(1.5, 2.0));
    const SqrtInformation n3 = SqrtInformation::Isotropic(3, 0.1), n2 = SqrtInformation::Isotropic(2, 0.2);
    graph.Add<PriorSE2>(0, SE2d(0, 0, 0), n3);
    for (int i = 0; i < 3; ++i) graph.Add<BetweenSE2>(i, i + 1, SE2d(1.02, 0.01, 0.04), n3);
    graph.Add<BetweenSE2>(3, 0, SE2d(-2.9, -0.2, -0.1), n3);
    graph.Add<PosePoint2>(1, 4, Eigen::Vector2d(0.4, 1.9), n2);
    graph.Add<PosePoint2>(2, 4, Eigen::Vector2d(-0.6, 1.8), n2);
  }
};

TEST(SplitProblem, VariablesInTheProblemsOrderWithTheirGraph) {
  Small s;
  const internal::VariableGraph g = internal::Problem::Variables(s.graph, s.values, {0});
  // Key 0 is fixed: the free variables are 1, 2, 3 (poses) and 4 (a point), as indices 0..3.
  EXPECT_EQ(g.block_sizes, (std::vector<int>{3, 3, 3, 2}));
  auto neighbours = [&g](int v) {
    return std::vector<int>(g.adjacency.begin() + g.xadj[v], g.adjacency.begin() + g.xadj[v + 1]);
  };
  EXPECT_EQ(neighbours(0), (std::vector<int>{1, 3}));  // 1: the odometry to 2, the point
  EXPECT_EQ(neighbours(1), (std::vector<int>{0, 2, 3}));
  EXPECT_EQ(neighbours(2), (std::vector<int>{1}));  // 3: 2 (its link to 0 has no second free variable)
  EXPECT_EQ(neighbours(3), (std::vector<int>{0, 1}));
  // The first free variable of each factor: the prior on fixed 0 has none; 0-1 starts at 1.
  EXPECT_EQ(g.first_free, (std::vector<int>{-1, 0, 0, 1, 2, 0, 1}));
  // The Problem numbers its columns the same way.
  internal::Problem p(s.graph, &s.values, {0});
  ASSERT_EQ(p.num_free(), 4);
  EXPECT_EQ(p.free_key(0), 1u);
  EXPECT_EQ(p.free_key(3), 4u);
}

// chi2, g and H (dense, symmetric) of a Problem at the values.
struct Linearised {
  double chi2 = 0;
  Eigen::VectorXd g;
  Eigen::MatrixXd h;
};

Linearised Linearise(const FactorGraph& graph, Values* values, const std::vector<char>* mask) {
  internal::Problem p(graph, values, {}, 1, mask);
  internal::Csc h;
  std::vector<int> diag;
  p.BuildNormalStructure(&h, &diag);
  Linearised l;
  l.chi2 = p.Linearize();
  l.g = Eigen::VectorXd::Zero(p.tangent_dim());
  p.AssembleNormal(&h, l.g.data());
  l.h = Eigen::MatrixXd::Zero(h.cols, h.cols);
  for (int c = 0; c < h.cols; ++c) {
    for (int k = h.colptr[c]; k < h.colptr[c + 1]; ++k) {
      const int r = h.rowind[k];
      if (r > c) continue;  // the lower part of a diagonal block is not meaningful
      l.h(r, c) = l.h(c, r) = h.values[k];
    }
  }
  return l;
}

TEST(SplitProblem, TwoSharesAddUpToTheWhole) {
  Small s;
  const std::vector<char> first = {1, 0, 1, 0, 1, 1, 0}, second = {0, 1, 0, 1, 0, 0, 1};
  const Linearised whole = Linearise(s.graph, &s.values, nullptr);
  const Linearised a = Linearise(s.graph, &s.values, &first);
  const Linearised b = Linearise(s.graph, &s.values, &second);
  ASSERT_EQ(a.g.size(), whole.g.size());  // every variable in each share's columns
  EXPECT_GT(a.chi2, 0);
  EXPECT_GT(b.chi2, 0);
  EXPECT_NEAR(a.chi2 + b.chi2, whole.chi2, 1e-12 * whole.chi2);
  EXPECT_LT((a.g + b.g - whole.g).norm(), 1e-12 * whole.g.norm());
  EXPECT_LT((a.h + b.h - whole.h).norm(), 1e-12 * whole.h.norm());
  EXPECT_GT(a.h.norm(), 0);
  EXPECT_GT(b.h.norm(), 0);
}

TEST(SplitProblem, MessagesNameTheFactorByItsPlaceInTheGraph) {
  Small s;
  s.values.Update(2, SE2d(std::nan(""), 0, 0));
  const std::vector<char> last_two = {0, 0, 0, 0, 0, 1, 1};
  internal::Problem p(s.graph, &s.values, {}, 1, &last_two);
  EXPECT_FALSE(std::isfinite(p.Linearize()));
  // Factor 6 of the graph (the second of this share) is the first of it that sees pose 2.
  EXPECT_NE(p.DescribeNonFinite().find("factor 6 "), std::string::npos) << p.DescribeNonFinite();
}

}  // namespace
}  // namespace tether
