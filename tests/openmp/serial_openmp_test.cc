// SerialOpenMp: OpenMP parallel regions get one thread while CHOLMOD works, and the runtime's
// setting is put back afterwards, also when several solvers overlap on different threads.
#include "serial_openmp.h"

#include <omp.h>

#include <memory>
#include <thread>

#include "gtest/gtest.h"
#include "tether/core/graph_io.h"
#include "tether/frontends/simulation/simulate.h"
#include "tether/solvers/initialize.h"
#include "tether/solvers/optimizer.h"

namespace tether {
namespace {

// The size of the team a parallel region asking for `want` threads gets.
int TeamSize(int want) {
  int size = 0;
#pragma omp parallel num_threads(want)
  {
#pragma omp single
    size = omp_get_num_threads();
  }
  return size;
}

class SerialOpenMpTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(internal::OpenMpRuntimeLoaded()) << "this test links an OpenMP runtime; the lookup must find it";
    omp_set_dynamic(0);
    omp_set_max_active_levels(3);
  }
};

TEST_F(SerialOpenMpTest, RegionsGetOneThreadInsideAndTheirTeamAfter) {
  EXPECT_EQ(TeamSize(4), 4);
  {
    internal::SerialOpenMp serial;
    EXPECT_EQ(omp_get_max_active_levels(), 0);
    EXPECT_EQ(TeamSize(4), 1);
  }
  EXPECT_EQ(omp_get_max_active_levels(), 3);
  EXPECT_EQ(TeamSize(4), 4);
}

TEST_F(SerialOpenMpTest, NestedGuardsRestoreAtTheOutermostEnd) {
  {
    internal::SerialOpenMp outer;
    {
      internal::SerialOpenMp inner;
      EXPECT_EQ(omp_get_max_active_levels(), 0);
    }
    EXPECT_EQ(omp_get_max_active_levels(), 0) << "the outer guard still lives";
    EXPECT_EQ(TeamSize(4), 1);
  }
  EXPECT_EQ(omp_get_max_active_levels(), 3);
}

// The setting is the calling thread's: a guard on another thread (a solver running there)
// leaves this thread's regions their full team, and puts its own thread's value back.
TEST_F(SerialOpenMpTest, AGuardOnAnotherThreadLeavesThisThreadAlone) {
  int inside = -1, after = -1, team_inside = -1;
  std::thread t([&] {
    omp_set_max_active_levels(2);
    {
      internal::SerialOpenMp serial;
      inside = omp_get_max_active_levels();
      team_inside = TeamSize(4);
    }
    after = omp_get_max_active_levels();
  });
  t.join();
  EXPECT_EQ(inside, 0);
  EXPECT_EQ(team_inside, 1);
  EXPECT_EQ(after, 2);
  EXPECT_EQ(omp_get_max_active_levels(), 3);
  EXPECT_EQ(TeamSize(4), 4);
}

// The CHOLMOD paths (chordal initialisation, analysis, factorisation, solve; Ceres) leave the
// runtime as they found it.
TEST_F(SerialOpenMpTest, ChordalAndCholmodSolveLeaveTheSettingAlone) {
  SimulateOptions so;
  so.world = SimWorld::kSphere;
  so.poses = 200;
  so.seed = 3;
  SimulatedGraph sim = Simulate(so);
  Values values = sim.initial;
  const FactorGraph& graph = sim.graph;
  ASSERT_NO_THROW(Initialize(graph, &values, InitMethod::kChordal));
  EXPECT_EQ(omp_get_max_active_levels(), 3);
  SolverOptions options;
  options.linear_solver = LinearSolverType::kCholmod;
  const SolverSummary s = Optimize(graph, &values, options);
  EXPECT_EQ(s.status, SolverStatus::kConverged) << s.message;
  EXPECT_EQ(omp_get_max_active_levels(), 3);
  EXPECT_EQ(TeamSize(4), 4);
  // The Ceres adapter (CHOLMOD inside Ceres) too, and its callback runs while the guard lives.
  Values again = sim.initial;
  options.algorithm = Algorithm::kCeres;
  int levels_in_callback = -1;
  options.callback = [&](const IterationSummary&) { levels_in_callback = omp_get_max_active_levels(); };
  const SolverSummary c = Optimize(graph, &again, options);
  EXPECT_EQ(c.status, SolverStatus::kConverged) << c.message;
  EXPECT_EQ(levels_in_callback, 0);
  EXPECT_EQ(omp_get_max_active_levels(), 3);
}

}  // namespace
}  // namespace tether
