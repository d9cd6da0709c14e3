// SolveInChunks (tether/solvers/chunked_solve.h): the graph grown in pose-id order, each chunk
// solved from the last one's estimate. Without losses it ends at the batch optimum, with and
// without a window; the window holds the older poses; the chunk count and the before_solve
// hook; landmarks enter with their poses; options.
#include "tether/solvers/chunked_solve.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "testing/simulated.h"
#include "tether/core/error.h"
#include "tether/solvers/optimizer.h"

namespace tether {
namespace {

using testing::SimulateWorld;

TEST(ChunkedSolve, EndsAtTheBatchOptimum) {
  for (SimWorld world : {SimWorld::kManhattan, SimWorld::kSphere, SimWorld::kLandmarks}) {
    const SimulatedGraph sim = SimulateWorld(world, 400, 5, 40);
    Values batch = sim.initial;
    const SolverSummary b = Optimize(sim.graph, &batch);
    ASSERT_TRUE(b.IsSolutionUsable()) << b.message;
    // Without a window (8 solves), and with windows of 1 and 3 chunks (8 and one more of the
    // whole graph).
    for (int free_chunks : {0, 1, 3}) {
      Values v = sim.initial;
      ChunkedSolveOptions o;
      o.chunks = 8;
      o.free_chunks = free_chunks;
      const ChunkedSolveSummary c = SolveInChunks(sim.graph, &v, o);
      ASSERT_TRUE(c.usable) << c.message;
      EXPECT_EQ(c.chunks, free_chunks == 0 ? 8 : 9);
      EXPECT_EQ(v.size(), sim.initial.size());
      EXPECT_NEAR(sim.graph.Chi2(v), b.final_chi2, 1e-6 * b.final_chi2)
          << static_cast<int>(world) << ", window " << free_chunks;
      EXPECT_GT(c.iterations, c.chunks);
    }
  }
}

TEST(ChunkedSolve, TheWindowHoldsTheOlderPosesUntilTheWholeGraphIsSolved) {
  // Each hook call sees the estimate the previous solve left: with a window of one chunk, the
  // solve of chunk c moves its own poses and leaves every pose of chunks 0..c-1 exactly where
  // it was; the whole graph's solve (after the hook's sixth call) then moves them. Without a
  // window they move at every chunk.
  const SimulatedGraph sim = SimulateWorld(SimWorld::kManhattan, 300, 6);
  for (int free_chunks : {1, 0}) {
    ChunkedSolveOptions o;
    o.chunks = 5;
    o.free_chunks = free_chunks;
    std::vector<Values> seen;
    o.before_solve = [&](int, std::size_t, FactorGraph*, const Values& estimate) { seen.push_back(estimate); };
    Values v = sim.initial;
    const ChunkedSolveSummary c = SolveInChunks(sim.graph, &v, o);
    ASSERT_TRUE(c.usable) << c.message;
    ASSERT_EQ(seen.size(), free_chunks == 1 ? 6u : 5u);
    seen.push_back(v);
    // Poses 0..59 are chunk 0, 60..119 chunk 1, ...
    auto moved = [&](std::size_t call, Key first, Key end) {
      double most = 0;
      for (Key k = first; k < end; ++k) {
        const double *a = seen[call].Params(k), *b = seen[call + 1].Params(k);  // x, y, theta
        most = std::max(most, std::hypot(b[0] - a[0], b[1] - a[1]));
      }
      return most;
    };
    for (std::size_t call = 1; call < 5; ++call) {  // the solve of chunk `call`
      const Key older_end = static_cast<Key>(60 * call);
      if (free_chunks == 1) {
        EXPECT_EQ(moved(call, 0, older_end), 0) << "chunk " << call;
      } else {
        EXPECT_GT(moved(call, 0, older_end), 1e-6) << "chunk " << call;
      }
      EXPECT_GT(moved(call, older_end, older_end + 60), 1e-6) << "chunk " << call << ": its own poses";
    }
    if (free_chunks == 1) {
      EXPECT_GT(moved(5, 0, 180), 1e-6) << "the whole graph's solve";
    }
  }
}

TEST(ChunkedSolve, APoseTheGraphFixesStaysWhereItIsGiven) {
  // Pose 150 fixed by the graph (and so the gauge): it enters at its given value, not where
  // its odometry from pose 149 would put it, is held by every solve, window or not, and the
  // end is the batch optimum with it fixed.
  const SimulatedGraph sim = SimulateWorld(SimWorld::kManhattan, 300, 9);
  FactorGraph graph = sim.graph;
  graph.Fix(150);
  Values batch = sim.initial;
  const SolverSummary b = Optimize(graph, &batch);
  ASSERT_TRUE(b.IsSolutionUsable()) << b.message;
  for (int free_chunks : {0, 1}) {
    Values v = sim.initial;
    ChunkedSolveOptions o;
    o.chunks = 5;
    o.free_chunks = free_chunks;
    const ChunkedSolveSummary c = SolveInChunks(graph, &v, o);
    ASSERT_TRUE(c.usable) << c.message;
    for (int i = 0; i < 3; ++i) EXPECT_EQ(v.Params(150)[i], sim.initial.Params(150)[i]) << "window " << free_chunks;
    EXPECT_NEAR(graph.Chi2(v), b.final_chi2, 1e-6 * b.final_chi2) << "window " << free_chunks;
  }
}

TEST(ChunkedSolve, InterimSolvesStopEarlierAndTheLastReachesTheOptimum) {
  // The solves before the last stop at interim_function_tolerance: fewer iterations in all,
  // and the last solve (solver's own tolerance) still ends at the batch optimum.
  const SimulatedGraph sim = SimulateWorld(SimWorld::kManhattan, 600, 7, 60);
  Values batch = sim.initial;
  const SolverSummary b = Optimize(sim.graph, &batch);
  ASSERT_TRUE(b.IsSolutionUsable()) << b.message;
  ChunkedSolveOptions tight, loose;
  tight.chunks = loose.chunks = 8;
  tight.interim_function_tolerance = 0;
  loose.interim_function_tolerance = 1e-3;
  Values vt = sim.initial, vl = sim.initial;
  const ChunkedSolveSummary ct = SolveInChunks(sim.graph, &vt, tight);
  const ChunkedSolveSummary cl = SolveInChunks(sim.graph, &vl, loose);
  ASSERT_TRUE(ct.usable && cl.usable) << ct.message << cl.message;
  EXPECT_LT(cl.iterations, ct.iterations);
  EXPECT_NEAR(sim.graph.Chi2(vt), b.final_chi2, 1e-6 * b.final_chi2);
  EXPECT_NEAR(sim.graph.Chi2(vl), b.final_chi2, 1e-6 * b.final_chi2);
  // The default: ten chunks, a window of one, 1e-5 before the last.
  const ChunkedSolveOptions d;
  EXPECT_EQ(d.chunks, 10);
  EXPECT_EQ(d.free_chunks, 1);
  EXPECT_EQ(d.interim_function_tolerance, 1e-5);
}

TEST(ChunkedSolve, ChunkCountAndHook) {
  const SimulatedGraph sim = SimulateWorld(SimWorld::kManhattan, 230, 2);
  ChunkedSolveOptions o;
  o.chunks = 20;
  o.min_chunk_poses = 50;  // 230 poses: at most 4 chunks of 50 or more
  std::vector<int> chunk_ids;
  std::vector<std::size_t> solved, sizes, present;
  o.before_solve = [&](int chunk, std::size_t s, FactorGraph* sub, const Values& estimate) {
    chunk_ids.push_back(chunk);
    solved.push_back(s);
    sizes.push_back(sub->size());
    present.push_back(estimate.size());
  };
  Values v = sim.initial;
  const ChunkedSolveSummary c = SolveInChunks(sim.graph, &v, o);
  ASSERT_TRUE(c.usable) << c.message;
  // Four chunks, then the whole graph's solve (the default window), with the hook before each.
  ASSERT_EQ(c.chunks, 5);
  ASSERT_EQ(chunk_ids, (std::vector<int>{0, 1, 2, 3, 4}));
  EXPECT_EQ(solved[0], 0u);
  for (int i = 1; i < 5; ++i) {
    EXPECT_EQ(solved[i], sizes[i - 1]) << i;  // the factors of the last solve come first
    if (i < 4) {
      EXPECT_GT(sizes[i], sizes[i - 1]) << i;
      EXPECT_GT(present[i], present[i - 1]) << i;
    }
  }
  EXPECT_EQ(sizes[3], sim.graph.size());
  EXPECT_EQ(present[3], sim.initial.size());
  EXPECT_EQ(sizes[4], sizes[3]);  // nothing new for the whole graph's solve
  EXPECT_EQ(present[4], present[3]);
  EXPECT_EQ(present[0], 230u / 4);  // the first chunk's poses
}

TEST(ChunkedSolve, OneChunkIsOneSolve) {
  const SimulatedGraph sim = SimulateWorld(SimWorld::kManhattan, 120, 3);
  Values batch = sim.initial, v = sim.initial;
  ChunkedSolveOptions o;
  o.chunks = 1;
  const SolverSummary b = Optimize(sim.graph, &batch, o.solver);
  const ChunkedSolveSummary c = SolveInChunks(sim.graph, &v, o);
  ASSERT_TRUE(c.usable);
  EXPECT_EQ(c.chunks, 1);
  EXPECT_EQ(c.iterations, b.iterations);
  EXPECT_NEAR(sim.graph.Chi2(v), b.final_chi2, 1e-9 * b.final_chi2);
}

TEST(ChunkedSolve, AHookThatRemovesFactorsKeepsTheCountRight) {
  // The hook removes every loop closure after the first solve: `solved` at the next call is
  // what was solved, and the result is the odometry-only optimum (the start itself).
  const SimulatedGraph sim = SimulateWorld(SimWorld::kManhattan, 200, 4);
  ChunkedSolveOptions o;
  o.chunks = 4;
  std::vector<std::size_t> solved, sizes_after;
  o.before_solve = [&](int, std::size_t s, FactorGraph* sub, const Values&) {
    solved.push_back(s);
    std::vector<FactorId> closures;
    for (std::size_t i = 0; i < sub->size(); ++i) {
      const Factor& f = sub->at(i);
      const Key a = f.keys()[0], b = f.keys().back();
      if (f.keys().size() == 2 && (a > b ? a - b : b - a) != 1) closures.push_back(sub->id(i));
    }
    for (FactorId id : closures) sub->Remove(id);
    sizes_after.push_back(sub->size());
  };
  Values v = sim.initial;
  const ChunkedSolveSummary c = SolveInChunks(sim.graph, &v, o);
  ASSERT_TRUE(c.usable) << c.message;
  ASSERT_EQ(solved.size(), 5u);  // four chunks and the whole graph
  for (std::size_t i = 1; i < 5; ++i) EXPECT_EQ(solved[i], sizes_after[i - 1]) << i;
  EXPECT_EQ(sizes_after.back(), 199u);  // the odometry chain
  EXPECT_NEAR(c.last.final_chi2, 0, 1e-12);
}

// A prior on a 2D point: a graph with no pose at all.
class PointPrior2 : public TypedFactor<PointPrior2, 2, Eigen::Vector2d> {
 public:
  static constexpr const char* kTypeName = "TestPointPrior2";
  PointPrior2(Key k, const Eigen::Vector2d& z) : TypedFactor({k}, SqrtInformation::Identity(2)), z_(z) {}
  bool Evaluate(const double* const* p, double* e, double* const* j) const override {
    e[0] = p[0][0] - z_[0];
    e[1] = p[0][1] - z_[1];
    if (j != nullptr && j[0] != nullptr) j[0][0] = 1, j[0][1] = 0, j[0][2] = 0, j[0][3] = 1;
    return true;
  }

 private:
  Eigen::Vector2d z_;
};

TEST(ChunkedSolve, AGraphWithoutPosesIsSolvedWholeAndAMissingValueIsReported) {
  FactorGraph g;
  g.Add<PointPrior2>(1, Eigen::Vector2d(3, 4));
  g.Add<PointPrior2>(2, Eigen::Vector2d(-1, 2));
  Values v;
  v.Insert(1, Eigen::Vector2d(0, 0));
  v.Insert(2, Eigen::Vector2d(0, 0));
  const ChunkedSolveSummary c = SolveInChunks(g, &v);
  ASSERT_TRUE(c.usable) << c.message;
  EXPECT_EQ(c.chunks, 1);
  EXPECT_NEAR((v.At<Eigen::Vector2d>(1) - Eigen::Vector2d(3, 4)).norm(), 0, 1e-9);
  g.Add<PointPrior2>(7, Eigen::Vector2d(0, 0));  // no value for 7
  const ChunkedSolveSummary missing = SolveInChunks(g, &v);
  EXPECT_FALSE(missing.usable);
  EXPECT_NE(missing.message.find("variable 7"), std::string::npos) << missing.message;
}

TEST(ChunkedSolve, InvalidOptionsThrow) {
  const SimulatedGraph sim = SimulateWorld(SimWorld::kManhattan, 60, 1);
  Values v = sim.initial;
  ChunkedSolveOptions o;
  o.chunks = 0;
  EXPECT_THROW(SolveInChunks(sim.graph, &v, o), InvalidArgument);
  o = ChunkedSolveOptions();
  o.min_chunk_poses = 0;
  EXPECT_THROW(SolveInChunks(sim.graph, &v, o), InvalidArgument);
  for (double bad : {-1e-5, 1.0, std::nan("")}) {
    o = ChunkedSolveOptions();
    o.interim_function_tolerance = bad;
    EXPECT_THROW(SolveInChunks(sim.graph, &v, o), InvalidArgument) << bad;
  }
  o = ChunkedSolveOptions();
  o.free_chunks = -1;
  EXPECT_THROW(SolveInChunks(sim.graph, &v, o), InvalidArgument);
  EXPECT_THROW(SolveInChunks(sim.graph, nullptr), InvalidArgument);
}

}  // namespace
}  // namespace tether
