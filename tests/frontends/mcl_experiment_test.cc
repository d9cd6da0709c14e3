// The kidnapped-robot experiment (localization/mcl_experiment.h): the kidnap really happens,
// the runs are the same for a seed, the recovery methods come back where plain MCL does not,
// and the options are checked.
#include "tether/frontends/localization/mcl_experiment.h"

#include <gtest/gtest.h>

#include <cmath>

#include "tether/core/error.h"

namespace tether {
namespace localization {
namespace {

// A small maze (4 x 4 cells of 2 m) and short runs: the tests' configuration.
MclExperimentOptions Tiny() {
  MclExperimentOptions o;
  o.worlds = {lidar::LidarWorld::kMaze};
  o.maze.cells_x = 4;
  o.maze.cells_y = 4;
  o.seeds = 2;
  o.particles = {600};
  o.kidnap_step = 30;
  o.kidnap_window = 150;
  o.max_steps = 400;
  o.min_jump = 3;
  o.threads = 2;
  return o;
}

TEST(MclExperimentTest, TheTruthJumpsWhileTheOdometryGoesOn) {
  const MclExperimentOptions o = Tiny();
  const KidnapScenario s = MakeKidnapScenario(lidar::LidarWorld::kMaze, 3, o);
  ASSERT_EQ(s.scans.size(), static_cast<std::size_t>(o.kidnap_step + o.max_steps));
  ASSERT_EQ(s.truth.size(), s.scans.size());
  ASSERT_EQ(s.kidnap_step, o.kidnap_step);
  EXPECT_GT(s.route_step, o.kidnap_step);
  const std::size_t k = static_cast<std::size_t>(s.kidnap_step);
  EXPECT_GE(s.jump, o.min_jump);
  EXPECT_NEAR((s.truth[k].translation() - s.truth[k - 1].translation()).norm(), s.jump, 1e-12);
  for (std::size_t i = 1; i < s.scans.size(); ++i) {
    // The odometry moves by an ordinary step everywhere, across the jump too ...
    const SE2d odometry_step = s.scans[i - 1].odometry.Inverse() * s.scans[i].odometry;
    EXPECT_LE(odometry_step.translation().norm(), 1.5 * o.sim_step) << i;
    EXPECT_LE(std::abs(odometry_step.theta()), 1.5 * o.sim_max_turn) << i;
    // ... and so does the truth, except at the kidnap.
    if (i != k) {
      EXPECT_LE((s.truth[i].translation() - s.truth[i - 1].translation()).norm(), 1e-9 + o.sim_step) << i;
    }
    EXPECT_GT(s.scans[i].stamp, s.scans[i - 1].stamp);
  }
  // The odometry's step across the jump is the route's own step into the new place: the odometry
  // after the jump differs from the truth by the same rigid motion as the route's would.
  const SE2d across = s.scans[k - 1].odometry.Inverse() * s.scans[k].odometry;
  const SE2d truth_across = s.truth[k].Inverse() * s.truth[k + 1];
  const SE2d odometry_after = s.scans[k].odometry.Inverse() * s.scans[k + 1].odometry;
  EXPECT_LT((odometry_after.translation() - truth_across.translation()).norm(), 0.05);
  EXPECT_GT(across.translation().norm(), 0.0);
  // The map holds the walls, and the truth lies in its free space.
  int i = 0, j = 0;
  ASSERT_TRUE(s.map->CellOf(s.truth[k].translation(), &i, &j));
  EXPECT_EQ(s.map->State(i, j), CellState::kFree);
  EXPECT_GT(s.map->occupied_count(), 0u);
}

TEST(MclExperimentTest, TheSameForASeed) {
  const MclExperimentOptions o = Tiny();
  const KidnapScenario s = MakeKidnapScenario(lidar::LidarWorld::kMaze, 2, o);
  MclOptions f;
  f.method = MclMethod::kAcmcl;
  f.particles = 300;
  f.threads = 1;
  const KidnapRun a = RunKidnap(s, f, o), b = RunKidnap(s, f, o);
  EXPECT_EQ(a.steps_to_converge, b.steps_to_converge);
  EXPECT_EQ(a.steps_run, b.steps_run);
  EXPECT_EQ(a.redrawn, b.redrawn);
  EXPECT_EQ(a.near, b.near);
  EXPECT_EQ(a.near_pose, b.near_pose);
  EXPECT_GT(a.redrawn, 0);
  const KidnapScenario again = MakeKidnapScenario(lidar::LidarWorld::kMaze, 2, o);
  EXPECT_EQ(again.route_step, s.route_step);
  ASSERT_EQ(again.scans.size(), s.scans.size());
  EXPECT_EQ(again.scans.back().ranges, s.scans.back().ranges);
  EXPECT_EQ(again.scans.back().odometry.translation(), s.scans.back().odometry.translation());
}

// On the small maze the recovery methods find the robot again after the kidnap; plain MCL,
// which never re-draws a particle, does not. All of them were tracking before it.
TEST(MclExperimentTest, RecoveryMethodsComeBackWherePlainMclDoesNot) {
  MclExperimentOptions o = Tiny();
  o.methods = {MclMethod::kMcl, MclMethod::kAugmented, MclMethod::kAcmcl};
  const MclExperimentResult r = RunMclExperiment(o);
  ASSERT_EQ(r.rows.size(), 3u);
  ASSERT_EQ(r.worlds.size(), 1u);
  EXPECT_GE(r.worlds[0].jump, o.min_jump);
  EXPECT_GT(r.worlds[0].free_area, r.worlds[0].valid_area);
  for (const MclExperimentRow& row : r.rows) {
    ASSERT_EQ(row.runs.size(), 2u);
    for (const KidnapRun& run : row.runs) EXPECT_TRUE(run.tracked_before) << ToString(row.method);
  }
  const MclExperimentRow& mcl = r.rows[0];
  EXPECT_EQ(mcl.method, MclMethod::kMcl);
  EXPECT_EQ(mcl.Converged(), 0);
  EXPECT_EQ(mcl.Redrawn(), 0);
  EXPECT_TRUE(std::isnan(mcl.RecoveryRatio()));
  for (const MclExperimentRow* row : {&r.rows[1], &r.rows[2]}) {
    EXPECT_EQ(row->Converged(), 2) << ToString(row->method);
    EXPECT_GT(row->Redrawn(), 0);
    EXPECT_GT(row->RecoveryRatio(), 0);
    EXPECT_LE(row->RecoveryRatioPose(), row->RecoveryRatio());
    EXPECT_GE(row->StepsMean(), 1);
    EXPECT_LE(row->StepsMean(), o.max_steps - o.converge_hold + 1);
  }
  const std::string tables = MclExperimentTables(r);
  EXPECT_NE(tables.find("| maze, MCL | - (2/2 not converged) |"), std::string::npos) << tables;
  EXPECT_NE(tables.find("| maze, ACMCL |"), std::string::npos);
}

TEST(MclExperimentTest, OptionsAreCheckedWithReasons) {
  std::string why;
  EXPECT_TRUE(MclExperimentOptions().IsValid(&why)) << why;
  const auto refused = [](void (*change)(MclExperimentOptions*), const char* word) {
    MclExperimentOptions o;
    change(&o);
    std::string w;
    EXPECT_FALSE(o.IsValid(&w)) << word;
    EXPECT_NE(w.find(word), std::string::npos) << w;
  };
  refused([](MclExperimentOptions* o) { o->particles.clear(); }, "empty");
  refused([](MclExperimentOptions* o) { o->methods = {MclMethod::kAcmcl, MclMethod::kAcmcl}; }, "repeats");
  refused([](MclExperimentOptions* o) { o->particles = {0}; }, "particle");
  refused([](MclExperimentOptions* o) { o->seeds = 0; }, "seeds");
  refused([](MclExperimentOptions* o) { o->kidnap_step = 1; }, "kidnap_step");
  refused([](MclExperimentOptions* o) { o->max_steps = 5; }, "max_steps");
  refused([](MclExperimentOptions* o) { o->min_jump = -1; }, "min_jump");
  refused([](MclExperimentOptions* o) { o->near_radius = std::nan(""); }, "near");
  refused([](MclExperimentOptions* o) { o->maze.cells_x = 1; }, "maze");
  refused([](MclExperimentOptions* o) { o->filter.alpha_slow = 0.5; }, "filter");
  MclExperimentOptions o = Tiny();
  o.min_jump = 100;  // nowhere in a 8 m maze
  EXPECT_THROW(MakeKidnapScenario(lidar::LidarWorld::kMaze, 1, o), InvalidArgument);
  o = Tiny();
  o.seeds = 0;
  EXPECT_THROW(RunMclExperiment(o), InvalidArgument);
}

}  // namespace
}  // namespace localization
}  // namespace tether
