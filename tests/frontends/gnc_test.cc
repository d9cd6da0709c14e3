// Graduated non-convexity on a simulated Manhattan world with wrong loop closures (random
// pose pairs, random relative poses, as precise as the true closures): GNC (TLS and
// Geman-McClure) rejects every wrong closure and keeps every true one, and ends where the
// solve without the wrong closures ends; least squares is ruined; the weights and options.
#include "tether/solvers/gnc.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>

#include "testing/corrupted.h"
#include "tether/core/error.h"
#include "tether/solvers/optimizer.h"

namespace tether {
namespace {

using testing::Corrupt;
using testing::Corrupted;
using testing::MaxPositionDifference;
using testing::RmsPositionDifference;

TEST(Gnc, RejectsEveryWrongLoopClosureAndKeepsTheTrueOnes) {
  const Corrupted c = Corrupt(300, 0.3, 4);
  Values clean = c.initial;
  ASSERT_TRUE(Optimize(c.clean, &clean).IsSolutionUsable());
  Values plain = c.initial;
  ASSERT_TRUE(Optimize(c.graph, &plain).IsSolutionUsable());
  // Least squares: the wrong closures bend the map by metres.
  EXPECT_GT(MaxPositionDifference(plain, clean), 1.0);
  for (GncStart start : {GncStart::kChunkedDcs, GncStart::kLeastSquares})
    for (GncKernel kernel : {GncKernel::kTruncatedLeastSquares, GncKernel::kGemanMcClure}) {
      const std::string name = std::string(kernel == GncKernel::kGemanMcClure ? "GM" : "TLS") +
                               (start == GncStart::kChunkedDcs ? " from chunked DCS" : " from least squares");
      GncOptions o;
      o.kernel = kernel;
      o.start = start;
      Values v = c.initial;
      const GncSummary g = OptimizeGnc(c.graph, &v, o);
      ASSERT_TRUE(g.usable) << name << ": " << g.message;
      // Every wrong closure rejected; of the true ones at most 2% (a true closure whose error
      // is beyond the 0.99 chi2 quantile is an outlier by TLS's own rule: measured, one of 161
      // for TLS from least squares, none otherwise).
      const std::set<std::size_t> rejected(g.rejected.begin(), g.rejected.end());
      int true_rejected = 0;
      for (std::size_t i : c.wrong) EXPECT_TRUE(rejected.count(i)) << name << ": wrong closure " << i << " kept";
      for (std::size_t i : rejected) true_rejected += c.wrong.count(i) == 0;
      EXPECT_LE(true_rejected, 0.02 * (g.loop_closures - static_cast<int>(c.wrong.size()))) << name;
      if (start == GncStart::kLeastSquares) {
        EXPECT_GT(g.stages, 1) << name;
        EXPECT_EQ(g.phi_scale, 0) << name;
      } else {
        // These closures fit as their noise states: the learned scale is measured 0.29 (the
        // closures DCS keeps are the better-fitting ones; DCS's phi 3.3), where the public
        // files' give phi 1.
        EXPECT_GT(g.phi_scale, 0.1) << name;
        EXPECT_LT(g.phi_scale, 3) << name;
        EXPECT_GT(g.start_iterations, 0) << name;
      }
      // The map is about the one without the wrong closures (measured: TLS 19 mm RMS from
      // chunked DCS, 13 mm from least squares, 0.14 m at most; GM from either the same map;
      // 48 wrong closures among 161 true ones).
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

TEST(Gnc, SmallCleanWorldsKeepTheirTrueClosures) {
  // Until DCS's scale is learned (from 10 kept closures) the chunked start takes the closures
  // near their stated noise (phi 0.3 c^2). With phi 1 there, these clean worlds lost closures for
  // good: 7 of 46 (150 poses, seed 4; map 0.21 m off) and 32 of 89 (200 poses, seed 2; 0.90 m
  // off). In the 150-pose world of seed 1 the start held out 16 true closures beyond 10 c^2;
  // judged by their plain chi2 against the map without them, 17 of 48 stayed out (0.54 m off);
  // judged with that map's uncertainty, none. Measured now: none, the least-squares optimum.
  for (const auto& [poses, seed] :
       {std::pair<int, int>{150, 4}, std::pair<int, int>{200, 2}, std::pair<int, int>{150, 1}}) {
    const Corrupted c = Corrupt(poses, 0.0, seed);
    Values clean = c.initial;
    ASSERT_TRUE(Optimize(c.clean, &clean).IsSolutionUsable());
    Values v = c.initial;
    const GncSummary g = OptimizeGnc(c.graph, &v);
    ASSERT_TRUE(g.usable) << g.message;
    EXPECT_TRUE(g.rejected.empty()) << poses << " poses: " << g.rejected.size() << " rejected";
    EXPECT_LT(MaxPositionDifference(v, clean), 1e-6) << poses << " poses";
  }
}

TEST(Gnc, ABoundSetByHandBelowOneWorks) {
  // c = 0.5 (c^2 0.25, below DCS's smallest phi of 1): every wrong closure still rejected.
  const Corrupted c = Corrupt(150, 0.2, 5);
  GncOptions o;
  o.c = 0.5;
  Values v = c.initial;
  const GncSummary g = OptimizeGnc(c.graph, &v, o);
  ASSERT_TRUE(g.usable) << g.message;
  const std::set<std::size_t> rejected(g.rejected.begin(), g.rejected.end());
  for (std::size_t i : c.wrong) EXPECT_TRUE(rejected.count(i)) << "wrong closure " << i << " kept";
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
