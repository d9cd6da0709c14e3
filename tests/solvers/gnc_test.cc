// Graduated non-convexity on a simulated Manhattan world with wrong loop closures (random
// pose pairs, random relative poses, as precise as the true closures): GNC (TLS and
// Geman-McClure) rejects every wrong closure and keeps every true one, and ends where the
// solve without the wrong closures ends; least squares is ruined; the weights and options.
#include "tether/solvers/gnc.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <set>

#include "testing/simulated.h"
#include "tether/core/error.h"
#include "tether/factors/between_se2.h"
#include "tether/solvers/optimizer.h"

namespace tether {
namespace {

using testing::SimulateWorld;

struct Corrupted {
  FactorGraph clean;            // the simulated world, loop closures marked
  FactorGraph graph;            // with the wrong closures appended
  std::set<std::size_t> wrong;  // their indices in graph
  Values initial;
};

Corrupted Corrupt(int poses, double fraction, std::uint64_t seed) {
  const SimulatedGraph sim = SimulateWorld(SimWorld::kManhattan, poses, seed);
  Corrupted c;
  c.initial = sim.initial;
  c.clean = sim.graph;
  const SqrtInformation* closure_noise = nullptr;
  int true_closures = 0;
  for (std::size_t i = 0; i < c.clean.size(); ++i) {
    Factor& f = c.clean.at(i);
    const Key a = f.keys()[0], b = f.keys().back();
    if (f.keys().size() == 2 && (a > b ? a - b : b - a) != 1) {
      f.set_loop_closure(true);
      closure_noise = &f.noise();
      ++true_closures;
    }
  }
  EXPECT_GT(true_closures, 5);
  c.graph = c.clean;
  std::mt19937_64 rng(seed * 7 + 1);
  std::uniform_int_distribution<int> pose(0, poses - 1);
  std::uniform_real_distribution<double> xy(-10, 10), angle(-M_PI, M_PI);
  const int wrong = static_cast<int>(std::lround(fraction * true_closures));
  for (int k = 0; k < wrong; ++k) {
    int a = pose(rng), b = pose(rng);
    while (std::abs(a - b) <= 1) b = pose(rng);
    c.graph.Add<BetweenSE2>(Key(a), Key(b), SE2d(xy(rng), xy(rng), angle(rng)), *closure_noise);
    c.graph.at(c.graph.size() - 1).set_loop_closure(true);
    c.wrong.insert(c.graph.size() - 1);
  }
  return c;
}

double MaxPositionDifference(const Values& a, const Values& b) {
  double d = 0;
  for (Key k : a.keys()) d = std::max(d, (a.At<SE2d>(k).translation() - b.At<SE2d>(k).translation()).norm());
  return d;
}

// Root mean square of the position differences (the same gauge: no alignment needed).
double RmsPositionDifference(const Values& a, const Values& b) {
  double d = 0;
  for (Key k : a.keys()) d += (a.At<SE2d>(k).translation() - b.At<SE2d>(k).translation()).squaredNorm();
  return std::sqrt(d / static_cast<double>(a.size()));
}

TEST(Gnc, RejectsEveryWrongLoopClosureAndKeepsTheTrueOnes) {
  const Corrupted c = Corrupt(300, 0.3, 4);
  Values clean = c.initial;
  ASSERT_TRUE(Optimize(c.clean, &clean).IsSolutionUsable());
  Values plain = c.initial;
  ASSERT_TRUE(Optimize(c.graph, &plain).IsSolutionUsable());
  // Least squares: the wrong closures bend the map by metres.
  EXPECT_GT(MaxPositionDifference(plain, clean), 1.0);
  for (GncKernel kernel : {GncKernel::kTruncatedLeastSquares, GncKernel::kGemanMcClure}) {
    const char* name = kernel == GncKernel::kGemanMcClure ? "GM" : "TLS";
    GncOptions o;
    o.kernel = kernel;
    Values v = c.initial;
    const GncSummary g = OptimizeGnc(c.graph, &v, o);
    ASSERT_TRUE(g.usable) << name << ": " << g.message;
    // Every wrong closure rejected; of the true ones at most 2% (a true closure whose error
    // is beyond the 0.99 chi2 quantile is an outlier by TLS's own rule: measured, one of 161
    // for TLS, none for GM).
    const std::set<std::size_t> rejected(g.rejected.begin(), g.rejected.end());
    int true_rejected = 0;
    for (std::size_t i : c.wrong) EXPECT_TRUE(rejected.count(i)) << name << ": wrong closure " << i << " kept";
    for (std::size_t i : rejected) true_rejected += c.wrong.count(i) == 0;
    EXPECT_LE(true_rejected, 0.02 * (g.loop_closures - static_cast<int>(c.wrong.size()))) << name;
    EXPECT_GT(g.stages, 1) << name;
    // The map is about the one without the wrong closures (measured: TLS 13 mm RMS, GM 16 mm,
    // 77 mm at most; 48 wrong closures among 161 true ones).
    EXPECT_LT(RmsPositionDifference(v, clean), 0.03) << name;
    EXPECT_LT(MaxPositionDifference(v, clean), 0.15) << name;
    for (std::size_t i = 0; i < c.graph.size(); ++i) {
      EXPECT_GE(g.weights[i], 0) << name << " " << i;
      EXPECT_LE(g.weights[i], 1) << name << " " << i;
      if (!c.graph.at(i).loop_closure()) {
        EXPECT_EQ(g.weights[i], 1) << name << ": odometry " << i;
      }
    }
  }
}

TEST(Gnc, WithoutWrongClosuresNothingIsRejectedAndTheOptimumStays) {
  // Geman-McClure (the default) on a clean 200-pose world: every closure kept, and the
  // estimate (least squares over the kept closures) is the least-squares optimum. Not every
  // clean world goes so: on the 150-pose world of seed 2 GM gives up 2 of 39 true closures,
  // and TLS 2 of 132 here (docs/solvers.md, "Graduated non-convexity").
  const Corrupted c = Corrupt(200, 0.0, 3);
  Values clean = c.initial;
  ASSERT_TRUE(Optimize(c.clean, &clean).IsSolutionUsable());
  Values v = c.initial;
  const GncSummary g = OptimizeGnc(c.graph, &v);
  ASSERT_TRUE(g.usable) << g.message;
  EXPECT_TRUE(g.rejected.empty()) << g.rejected.size() << " rejected";
  EXPECT_LT(MaxPositionDifference(v, clean), 1e-6);
}

TEST(Gnc, InvalidOptionsThrow) {
  const Corrupted c = Corrupt(50, 0.0, 1);
  Values v = c.initial;
  GncOptions o;
  o.mu_factor = 1;
  EXPECT_THROW(OptimizeGnc(c.graph, &v, o), InvalidArgument);
  o = GncOptions();
  o.c = -1;
  EXPECT_THROW(OptimizeGnc(c.graph, &v, o), InvalidArgument);
  EXPECT_THROW(OptimizeGnc(c.graph, nullptr), InvalidArgument);
}

}  // namespace
}  // namespace tether
