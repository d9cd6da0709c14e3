// SolveInChunks (tether/solvers/chunked_solve.h): the graph grown in pose-id order, each chunk
// solved from the last one's estimate. Without losses it ends at the batch optimum; the chunk
// count and the before_solve hook; landmarks enter with their poses; options.
#include "tether/solvers/chunked_solve.h"

#include <gtest/gtest.h>

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
    Values v = sim.initial;
    ChunkedSolveOptions o;
    o.chunks = 8;
    const ChunkedSolveSummary c = SolveInChunks(sim.graph, &v, o);
    ASSERT_TRUE(c.usable) << c.message;
    EXPECT_EQ(c.chunks, 8);
    EXPECT_EQ(v.size(), sim.initial.size());
    EXPECT_NEAR(sim.graph.Chi2(v), b.final_chi2, 1e-6 * b.final_chi2) << static_cast<int>(world);
    EXPECT_GT(c.iterations, c.chunks);
  }
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
  ASSERT_EQ(c.chunks, 4);
  ASSERT_EQ(chunk_ids, (std::vector<int>{0, 1, 2, 3}));
  EXPECT_EQ(solved[0], 0u);
  for (int i = 1; i < 4; ++i) {
    EXPECT_EQ(solved[i], sizes[i - 1]) << i;  // the factors of the last solve come first
    EXPECT_GT(sizes[i], sizes[i - 1]) << i;
    EXPECT_GT(present[i], present[i - 1]) << i;
  }
  EXPECT_EQ(sizes[3], sim.graph.size());
  EXPECT_EQ(present[3], sim.initial.size());
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

TEST(ChunkedSolve, InvalidOptionsThrow) {
  const SimulatedGraph sim = SimulateWorld(SimWorld::kManhattan, 60, 1);
  Values v = sim.initial;
  ChunkedSolveOptions o;
  o.chunks = 0;
  EXPECT_THROW(SolveInChunks(sim.graph, &v, o), InvalidArgument);
  o = ChunkedSolveOptions();
  o.min_chunk_poses = 0;
  EXPECT_THROW(SolveInChunks(sim.graph, &v, o), InvalidArgument);
  EXPECT_THROW(SolveInChunks(sim.graph, nullptr), InvalidArgument);
}

}  // namespace
}  // namespace tether
