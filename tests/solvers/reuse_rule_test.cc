// The reuse rule (ReuseWhileCheaper): reusing an earlier factorisation is tried, and iterated,
// only while it can cost less than factorising afresh, by the linear solver's operation counts.
#include <gtest/gtest.h>

#include "linear_system.h"

namespace tether {
namespace internal {
namespace {

struct Rule {
  bool reuse = true;
  int iterations = 8;
};

Rule Apply(double f, double s, double m, Rule r = {}) {
  ReuseWhileCheaper(f, s, m, &r.reuse, &r.iterations);
  return r;
}

TEST(ReuseRule, IteratesWhileAConvergedReuseIsCheaper) {
  // (2 + k) s + (1 + k) m < f + s  <=>  k < (f - s - m) / (s + m) = 8.5 / 1.5 = 5.67: 5.
  const Rule r = Apply(10, 1, 0.5);
  EXPECT_TRUE(r.reuse);
  EXPECT_EQ(r.iterations, 5);
  // A converged reuse after 5 iterations is cheaper than a factorisation; after 6 it is not.
  EXPECT_LT((2 + 5) * 1 + (1 + 5) * 0.5, 10 + 1);
  EXPECT_GE((2 + 6) * 1 + (1 + 6) * 0.5, 10 + 1);
}

TEST(ReuseRule, NoTryWhereNotEvenOneIterationPays) {
  const Rule r = Apply(3.2, 1, 0.64);  // ais2klinik's block Cholesky: (3.2 - 1.64) / 1.64 < 1
  EXPECT_FALSE(r.reuse);
  EXPECT_EQ(r.iterations, 0);
}

TEST(ReuseRule, TheGivenMaximumStays) {
  const Rule r = Apply(65, 1, 0.17);  // sphere2500 with CHOLMOD: a cap of 54
  EXPECT_TRUE(r.reuse);
  EXPECT_EQ(r.iterations, 8);
  const Rule off = Apply(65, 1, 0.17, Rule{false, 0});  // switched off by the caller: stays off
  EXPECT_FALSE(off.reuse);
  EXPECT_EQ(off.iterations, 0);
}

TEST(ReuseRule, UnknownCountsLeaveItAsGiven) {
  for (const auto& [f, s] : {std::pair<double, double>{0, 1}, {1, 0}, {0, 0}}) {
    const Rule r = Apply(f, s, 1);
    EXPECT_TRUE(r.reuse);
    EXPECT_EQ(r.iterations, 8);
  }
}

}  // namespace
}  // namespace internal
}  // namespace tether

#include <cmath>
#include <memory>

#include "tether/factors/between_se2.h"
#include "tether/solvers/optimizer.h"

namespace tether {
namespace {

// A loop of poses (a ring: the block Cholesky's factor has about one block below the diagonal
// per column, so a factorisation costs about twice a solve): no iteration can pay, and every
// step factorises, with the reuse allowed as by default.
TEST(ReuseRule, ASparseFactorFactorisesEveryStep) {
  const int n = 300;
  FactorGraph graph;
  Values start;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * M_PI * i / n, next = 2 * M_PI * (i + 1) / n;
    const SE2d xi(10 * std::cos(a), 10 * std::sin(a), a + M_PI / 2);
    const SE2d xj(10 * std::cos(next), 10 * std::sin(next), next + M_PI / 2);
    // Measurements off by a little (the ring does not close exactly), a start off by more.
    const SE2d z = xi.Inverse() * xj * SE2d(0.01 * std::sin(3.0 * i), 0.01 * std::cos(5.0 * i), 0.002 * std::sin(i));
    graph.Add(std::make_unique<BetweenSE2>(i, (i + 1) % n, z, SqrtInformation::Isotropic(3, 0.1)));
    start.Insert(i, SE2d(10 * std::cos(a) + 0.5 * std::sin(7.0 * i), 10 * std::sin(a) + 0.5 * std::cos(3.0 * i),
                         a + M_PI / 2 + 0.2 * std::sin(11.0 * i)));
  }
  graph.Fix(0);
  SolverOptions o;
  Values v = start;
  const SolverSummary s = Optimize(graph, &v, o);
  ASSERT_EQ(s.status, SolverStatus::kConverged) << s.message;
  EXPECT_GE(s.iterations, 4) << "a run long enough for the later, small steps to reuse where allowed";
  EXPECT_EQ(s.factorizations, s.iterations);
  for (const IterationSummary& it : s.log) EXPECT_FALSE(it.reused_factorization);
}

}  // namespace
}  // namespace tether
