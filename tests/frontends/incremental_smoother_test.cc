// The incremental smoother against batch Optimize on simulated Manhattan worlds fed pose by
// pose (with loop closures added and removed at random), the removal of a loop closure,
// determinism, invalid updates, and Marginal against Marginals.
#include "tether/solvers/incremental_smoother.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <random>
#include <stdexcept>
#include <vector>

#include "testing/simulated.h"
#include "tether/core/error.h"
#include "tether/core/robust_kernels.h"
#include "tether/factors/between_se2.h"
#include "tether/factors/between_se3.h"
#include "tether/solvers/covariance.h"
#include "tether/solvers/initialize.h"
#include "tether/solvers/optimizer.h"

namespace tether {
namespace {

using testing::SimulateWorld;

// The factors of `graph` grouped by the step that completes them: the largest key they use.
std::vector<std::vector<std::size_t>> FactorsByStep(const FactorGraph& graph) {
  std::vector<std::vector<std::size_t>> by_step;
  for (std::size_t i = 0; i < graph.size(); ++i) {
    const std::vector<Key>& keys = graph.at(i).keys();
    const Key last = *std::max_element(keys.begin(), keys.end());
    if (by_step.size() <= last) by_step.resize(last + 1);
    by_step[last].push_back(i);
  }
  return by_step;
}

bool IsOdometry(const Factor& f) {
  const Key a = f.keys()[0], b = f.keys()[1];
  return std::max(a, b) - std::min(a, b) == 1;
}

// Feeds `sim` pose by pose into `smoother`; at each step each loop closure added before is
// removed with probability `p_remove`. The graph the smoother ends with is in *final.
// `after`, where given, is called after each update with its step and summary.
void Replay(const SimulatedGraph& sim, int poses, double p_remove, std::uint64_t seed, IncrementalSmoother* smoother,
            FactorGraph* final, const std::function<void(int, const SmootherUpdate&)>& after = {}) {
  std::mt19937_64 rng(seed);
  const auto by_step = FactorsByStep(sim.graph);
  std::vector<std::pair<FactorId, std::size_t>> closures;  // smoother handle, index in sim.graph
  std::vector<bool> kept(sim.graph.size(), false);
  for (int i = 0; i < poses; ++i) {
    FactorGraph f;
    Values v;
    const Key k = static_cast<Key>(i);
    // The previous estimate composed with the odometry: as a front-end would guess.
    if (i == 0) {
      v.InsertParams(k, sim.initial.TypeOf(k), sim.initial.Params(k));
    } else {
      const Factor& odo = sim.graph.at(by_step[i].front());
      std::vector<double> p(static_cast<std::size_t>(AmbientDim(sim.initial.TypeOf(k))), 0.0);  // SE2 or SE3
      const std::size_t known = odo.keys()[0] == k ? 1 : 0;
      ASSERT_TRUE(odo.Predict(known, smoother->Estimate().Params(odo.keys()[known]), 1 - known, p.data()));
      v.InsertParams(k, sim.initial.TypeOf(k), p.data());
    }
    for (std::size_t j : by_step[i]) f.Add(sim.graph.at(j).Clone());
    std::vector<FactorId> remove;
    std::vector<std::pair<FactorId, std::size_t>> still;
    for (const auto& c : closures) {
      if (std::uniform_real_distribution<double>(0, 1)(rng) < p_remove) {
        remove.push_back(c.first);
        kept[c.second] = false;
      } else {
        still.push_back(c);
      }
    }
    closures = still;
    const SmootherUpdate u = smoother->Update(std::move(f), std::move(v), remove);
    ASSERT_EQ(u.new_factor_ids.size(), by_step[i].size());
    ASSERT_EQ(u.factors_removed, static_cast<int>(remove.size()));
    for (std::size_t n = 0; n < by_step[i].size(); ++n) {
      const std::size_t j = by_step[i][n];
      kept[j] = true;
      if (!IsOdometry(sim.graph.at(j))) closures.push_back({u.new_factor_ids[n], j});
    }
    if (after) after(i, u);
  }
  if (final) {
    *final = FactorGraph();
    for (std::size_t j = 0; j < sim.graph.size(); ++j) {
      if (kept[j]) final->Add(sim.graph.at(j).Clone());
    }
  }
}

// Batch Optimize of `graph` from the chordal start, to convergence.
Values BatchOptimum(const FactorGraph& graph, const Values& initial, double* chi2) {
  Values v = initial;
  Initialize(graph, &v, InitMethod::kChordal);
  const SolverSummary s = Optimize(graph, &v, SmootherOptions().finish);
  EXPECT_TRUE(s.IsSolutionUsable()) << s.FullReport();
  *chi2 = s.final_chi2;
  return v;
}

bool BitIdentical(const Values& a, const Values& b) {
  if (a.keys() != b.keys()) return false;
  for (Key k : a.keys()) {
    if (a.TypeOf(k) != b.TypeOf(k)) return false;
    const int n = AmbientDim(a.TypeOf(k));
    if (std::memcmp(a.Params(k), b.Params(k), sizeof(double) * static_cast<std::size_t>(n)) != 0) return false;
  }
  return true;
}

double MaxDifference(const Values& a, const Values& b) {
  double d = 0;
  for (Key k : a.keys()) {
    for (int j = 0; j < AmbientDim(a.TypeOf(k)); ++j) d = std::max(d, std::abs(a.Params(k)[j] - b.Params(k)[j]));
  }
  return d;
}

TEST(IncrementalSmoother, EqualsBatchAfterFinishOnRandomAddsAndRemovals) {
  for (std::uint64_t seed : {1, 2, 3}) {
    const int poses = 150;
    const SimulatedGraph sim = SimulateWorld(SimWorld::kManhattan, poses, seed);
    IncrementalSmoother smoother;
    FactorGraph final;
    Replay(sim, poses, 0.05, seed, &smoother, &final);
    ASSERT_EQ(smoother.graph().size(), final.size());
    EXPECT_LT(final.size(), sim.graph.size()) << "some loop closures should have been removed";
    smoother.Finish();
    ASSERT_TRUE(smoother.finish_summary().IsSolutionUsable()) << smoother.finish_summary().FullReport();
    double batch_chi2 = 0;
    BatchOptimum(final, sim.initial, &batch_chi2);
    const double online = final.Chi2(smoother.Estimate());
    EXPECT_NEAR(online, batch_chi2, 1e-9 * batch_chi2) << "seed " << seed;
    EXPECT_DOUBLE_EQ(online, smoother.finish_summary().final_chi2);
  }
}

TEST(IncrementalSmoother, EveryUpdateIsCloseToTheOptimumSoFar) {
  const int poses = 120;
  const SimulatedGraph sim = SimulateWorld(SimWorld::kManhattan, poses, 7);
  IncrementalSmoother smoother;
  Replay(sim, poses, 0.0, 7, &smoother, nullptr);
  Values v = smoother.Estimate();
  const SolverSummary s = Optimize(smoother.graph(), &v, SmootherOptions().finish);
  EXPECT_NEAR(smoother.graph().Chi2(smoother.Estimate()), s.final_chi2, 1e-3 * s.final_chi2);
}

TEST(IncrementalSmoother, RobustLoopClosuresFinishAtTheBatchRobustOptimum) {
  // Huber on every loop closure, and two wrong closures among them: the smoother weights each
  // factor by sqrt(rho') at its linearisation point (as Optimize does at every iteration), so
  // its estimate is near the optimum of the robust cost, and Finish() reaches the optimum that
  // batch Optimize reaches.
  const int poses = 120;
  SimulatedGraph sim = SimulateWorld(SimWorld::kManhattan, poses, 11);
  const SqrtInformation& precise = sim.graph.at(0).noise();
  sim.graph.Add<BetweenSE2>(Key(10), Key(90), SE2d(3, -2, 1), precise);
  sim.graph.Add<BetweenSE2>(Key(30), Key(110), SE2d(-4, 1, 2), precise);
  int robust = 0;
  for (std::size_t i = 0; i < sim.graph.size(); ++i) {
    if (IsOdometry(sim.graph.at(i))) continue;
    sim.graph.at(i).set_loss(MakeLoss("huber:1"));
    ++robust;
  }
  ASSERT_GT(robust, 10);
  IncrementalSmoother smoother;
  FactorGraph final;
  Replay(sim, poses, 0.0, 11, &smoother, &final);
  const double before_finish = final.Cost(smoother.Estimate());
  smoother.Finish();
  const SolverSummary& f = smoother.finish_summary();
  ASSERT_TRUE(f.IsSolutionUsable()) << f.FullReport();
  Values batch = sim.initial;
  Initialize(final, &batch, InitMethod::kChordal);
  SolverOptions o = SmootherOptions().finish;
  const SolverSummary s = Optimize(final, &batch, o);
  ASSERT_TRUE(s.IsSolutionUsable()) << s.FullReport();
  const double online = final.Cost(smoother.Estimate());
  EXPECT_NEAR(online, s.final_cost, 1e-9 * s.final_cost);
  EXPECT_LT(s.final_cost, 0.5 * s.final_chi2) << "the wrong closures should cost far less than their chi2";
  EXPECT_DOUBLE_EQ(online, f.final_cost);
  // Before Finish the estimate is already at the robust optimum to the 1e-3 the issue asks of
  // every update (measured 9.4e-5; an estimate that ignored the losses costs 11.5 times more).
  EXPECT_LT(before_finish, (1 + 1e-3) * s.final_cost) << "before Finish " << before_finish;
}

TEST(IncrementalSmoother, RemovingALoopClosureRestoresThePreviousOptimum) {
  const int poses = 100;
  const SimulatedGraph sim = SimulateWorld(SimWorld::kManhattan, poses, 4);
  ASSERT_GT(sim.loop_closures, 0);
  IncrementalSmoother smoother;
  Replay(sim, poses, 0.0, 4, &smoother, nullptr);
  const Values before = smoother.Finish();
  const double chi2_before = smoother.finish_summary().final_chi2;

  // A second copy of the first loop closure: it pulls the optimum (and chi2) away.
  FactorGraph closure;
  std::size_t j = 0;
  while (IsOdometry(sim.graph.at(j))) ++j;
  closure.Add(sim.graph.at(j).Clone());
  const SmootherUpdate added = smoother.Update(std::move(closure));
  ASSERT_EQ(added.new_factor_ids.size(), 1u);
  smoother.Finish();
  EXPECT_GT(smoother.finish_summary().final_chi2, chi2_before);

  const SmootherUpdate removed = smoother.Update({}, {}, {added.new_factor_ids[0]});
  EXPECT_EQ(removed.factors_removed, 1);
  EXPECT_EQ(removed.variables_removed, 0);
  const Values& after = smoother.Finish();
  EXPECT_NEAR(smoother.finish_summary().final_chi2, chi2_before, 1e-9 * chi2_before);
  // The values to 1e-9 relative to the world's extent. Not 1e-9 absolute: at the optimum a
  // Gauss-Newton step of 1e-8 changes chi2 by less than its rounding, so Levenberg-Marquardt
  // cannot tell such values apart (measured: 3e-9 here, with coordinates up to ~10 m).
  double extent = 0;
  for (Key k : before.keys()) extent = std::max(extent, before.At<SE2d>(k).translation().cwiseAbs().maxCoeff());
  EXPECT_GT(extent, 1.0);
  EXPECT_LT(MaxDifference(before, after), 1e-9 * extent);
}

TEST(IncrementalSmoother, Deterministic) {
  const int poses = 120;
  const SimulatedGraph sim = SimulateWorld(SimWorld::kManhattan, poses, 5);
  IncrementalSmoother a, b;
  Replay(sim, poses, 0.05, 5, &a, nullptr);
  Replay(sim, poses, 0.05, 5, &b, nullptr);
  EXPECT_TRUE(BitIdentical(a.Estimate(), b.Estimate()));
  EXPECT_TRUE(BitIdentical(a.Finish(), b.Finish()));
}

TEST(IncrementalSmoother, InvalidUpdatesChangeNothing) {
  const int poses = 30;
  const SimulatedGraph sim = SimulateWorld(SimWorld::kManhattan, poses, 6);
  IncrementalSmoother smoother;
  Replay(sim, 20, 0.0, 6, &smoother, nullptr);
  const Values estimate = smoother.Estimate();
  const std::size_t factors = smoother.graph().size();
  const FactorId last = smoother.graph().id(factors - 1);
  auto unchanged = [&] {
    EXPECT_TRUE(BitIdentical(estimate, smoother.Estimate()));
    ASSERT_EQ(smoother.graph().size(), factors);
    EXPECT_EQ(smoother.graph().id(factors - 1), last);
  };
  const auto by_step = FactorsByStep(sim.graph);
  const Factor& odometry_19_20 = sim.graph.at(by_step[20].front());

  {  // a new value whose key exists, alongside a valid factor and a valid removal
    FactorGraph f;
    f.Add(odometry_19_20.Clone());
    Values v;
    v.InsertParams(20, sim.initial.TypeOf(20), sim.initial.Params(20));
    v.InsertParams(19, sim.initial.TypeOf(19), sim.initial.Params(19));
    EXPECT_THROW(smoother.Update(std::move(f), std::move(v), {last}), InvalidArgument);
    unchanged();
  }
  {  // a factor whose key has no value
    FactorGraph f;
    f.Add(odometry_19_20.Clone());
    EXPECT_THROW(smoother.Update(std::move(f), {}, {last}), InvalidArgument);
    unchanged();
  }
  {  // a value of another type than the factor takes
    FactorGraph f;
    f.Add(odometry_19_20.Clone());
    Values v;
    v.Insert(20, Eigen::Vector2d(1, 2));
    EXPECT_THROW(smoother.Update(std::move(f), std::move(v)), InvalidArgument);
    unchanged();
  }
  {  // an unknown handle, and a handle listed twice
    Values v;
    v.InsertParams(20, sim.initial.TypeOf(20), sim.initial.Params(20));
    EXPECT_THROW(smoother.Update({}, v, {last + 1000}), InvalidArgument);
    unchanged();
    EXPECT_THROW(smoother.Update({}, v, {last, last}), InvalidArgument);
    unchanged();
  }
  {  // fixing a variable that has no value
    FactorGraph f;
    f.Fix(99);
    EXPECT_THROW(smoother.Update(std::move(f)), InvalidArgument);
    unchanged();
  }
  {  // a new factor that throws when evaluated (a user's factor raising), beside a valid one
    struct Raising : public BetweenSE2 {
      using BetweenSE2::BetweenSE2;
      bool Evaluate(const double* const*, double*, double* const*) const override {
        throw std::runtime_error("raised by the factor");
      }
      std::unique_ptr<Factor> Clone() const override { return std::make_unique<Raising>(*this); }
    };
    FactorGraph f;
    f.Add(odometry_19_20.Clone());
    f.Add(std::make_unique<Raising>(19, 20, SE2d(1, 0, 0), SqrtInformation::Identity(3)));
    Values v;
    v.InsertParams(20, sim.initial.TypeOf(20), sim.initial.Params(20));
    EXPECT_THROW(smoother.Update(std::move(f), std::move(v), {last}), std::runtime_error);
    unchanged();
    EXPECT_FALSE(smoother.Estimate().Has(20));
  }
  {  // a factor connecting a variable to itself
    FactorGraph f;
    f.Add(std::make_unique<BetweenSE2>(19, 19, SE2d(), SqrtInformation::Identity(3)));
    EXPECT_THROW(smoother.Update(std::move(f)), InvalidArgument);
    unchanged();
  }
  // The smoother still works after the refused updates.
  FactorGraph f;
  f.Add(odometry_19_20.Clone());
  Values v;
  v.InsertParams(20, sim.initial.TypeOf(20), sim.initial.Params(20));
  const SmootherUpdate u = smoother.Update(std::move(f), std::move(v));
  EXPECT_EQ(u.factors_added, 1);
  EXPECT_EQ(u.variables_added, 1);
  EXPECT_TRUE(u.solved);
  EXPECT_EQ(u.new_factor_ids.front(), last + 1);
}

TEST(IncrementalSmoother, RemovingTheLastFactorOfAVariableErasesIt) {
  const SimulatedGraph sim = SimulateWorld(SimWorld::kManhattan, 10, 8);
  IncrementalSmoother smoother;
  Replay(sim, 10, 0.0, 8, &smoother, nullptr);
  const auto by_step = FactorsByStep(sim.graph);
  ASSERT_EQ(by_step[9].size(), 1u) << "pose 9 should have its odometry edge only";
  const FactorId odometry = smoother.graph().id(smoother.graph().size() - 1);
  const SmootherUpdate u = smoother.Update({}, {}, {odometry});
  EXPECT_EQ(u.variables_removed, 1);
  EXPECT_FALSE(smoother.Estimate().Has(9));
  EXPECT_EQ(smoother.Estimate().size(), 9u);
}

TEST(IncrementalSmoother, MarginalIsMarginalsOfTheGraphAndEstimate) {
  const int poses = 60;
  const SimulatedGraph sim = SimulateWorld(SimWorld::kManhattan, poses, 9);
  SmootherOptions o;
  o.marginal_from_factor = false;  // the newest pose's too (the test below has the other way)
  IncrementalSmoother smoother(o);
  Replay(sim, poses, 0.0, 9, &smoother, nullptr);
  const Marginals m(smoother.graph(), smoother.Estimate());
  for (Key k : {Key(1), Key(30), Key(59)}) {
    const Eigen::MatrixXd a = smoother.Marginal(k);
    const Eigen::MatrixXd b = m.Marginal(k);
    ASSERT_EQ(a.rows(), 3);
    EXPECT_EQ(a, b) << "key " << k;
  }
  EXPECT_THROW(smoother.Marginal(0), InvalidArgument);  // the gauge
  EXPECT_THROW(smoother.Marginal(1000), InvalidArgument);
}

// The newest pose's marginal from the kept factor is the covariance at the linearisation point:
// with the linearisation point held at the given values (thresholds never reached, no
// refinement), it equals Marginals of the graph at those values, not at the estimate; after
// Finish() (the factor to be rebuilt) it is Marginals at the estimate again.
TEST(IncrementalSmoother, TheNewestPosesMarginalComesFromTheKeptFactor) {
  const int poses = 60;
  const SimulatedGraph sim = SimulateWorld(SimWorld::kManhattan, poses, 16);
  SmootherOptions o;
  o.relinearize_threshold = o.relinearize_sigmas = 1e6;
  o.refine_new_values = false;
  IncrementalSmoother smoother(o);
  const auto by_step = FactorsByStep(sim.graph);
  Values given;
  for (int i = 0; i < poses; ++i) {
    const Key k = static_cast<Key>(i);
    FactorGraph f;
    Values v;
    v.InsertParams(k, sim.initial.TypeOf(k), sim.initial.Params(k));
    given.InsertParams(k, sim.initial.TypeOf(k), sim.initial.Params(k));
    for (std::size_t j : by_step[k]) f.Add(sim.graph.at(j).Clone());
    smoother.Update(std::move(f), std::move(v));
    if (i < 5) continue;
    const Eigen::MatrixXd fast = smoother.Marginal(k);
    const Eigen::MatrixXd at_theta = Marginals(smoother.graph(), given).Marginal(k);
    EXPECT_LT((fast - at_theta).norm(), 1e-9 * at_theta.norm()) << "pose " << i;
  }
  // The estimate has moved well away from the given values, and so has its covariance.
  const Key last = static_cast<Key>(poses - 1);
  const Eigen::MatrixXd at_estimate = Marginals(smoother.graph(), smoother.Estimate()).Marginal(last);
  EXPECT_GT((smoother.Marginal(last) - at_estimate).norm(), 1e-3 * at_estimate.norm());
  smoother.Finish();
  EXPECT_EQ(smoother.Marginal(last), Marginals(smoother.graph(), smoother.Estimate()).Marginal(last));
}

TEST(IncrementalSmoother, APoseAfterABatchStartOrFinishRefactorsOnlyTheLastColumns) {
  // A front-end that starts with a whole map in one update, or calls Finish() now and then:
  // the next pose at the end of the trajectory must not refactor the whole factor (the full
  // refactor orders the newest variable last).
  const int poses = 300;
  const SimulatedGraph sim = SimulateWorld(SimWorld::kManhattan, poses, 12);
  IncrementalSmoother smoother;
  FactorGraph all;
  for (std::size_t i = 0; i < sim.graph.size(); ++i) all.Add(sim.graph.at(i).Clone());
  Values initial = sim.initial;
  const SmootherUpdate first = smoother.Update(std::move(all), std::move(initial));
  EXPECT_TRUE(first.structure_rebuilt);
  EXPECT_GE(first.affected_columns, poses);
  auto one_more_pose = [&](Key next) {
    FactorGraph f;
    Values v;
    const SE2d odometry(1, 0, 0.1);
    v.Insert(next, smoother.Estimate().At<SE2d>(next - 1) * odometry);
    f.Add<BetweenSE2>(next - 1, next, odometry, SqrtInformation::Identity(3));
    return smoother.Update(std::move(f), std::move(v));
  };
  // Let the start settle (its re-linearisations), then one pose.
  for (int i = 0; i < 20 && smoother.Update().relinearized > 0; ++i) {
  }
  SmootherUpdate u = one_more_pose(poses);
  EXPECT_FALSE(u.structure_rebuilt);
  EXPECT_EQ(u.relinearized, 0);
  EXPECT_LE(u.affected_columns, 4) << "after a batch start";
  smoother.Finish();
  u = one_more_pose(poses + 1);
  EXPECT_TRUE(u.structure_rebuilt) << "Finish() re-linearises everything, so the next update refactors all";
  u = one_more_pose(poses + 2);
  EXPECT_FALSE(u.structure_rebuilt);
  EXPECT_LE(u.affected_columns, 4) << "after Finish()";
}

TEST(IncrementalSmoother, ANewPoseWithZeroErrorMovesNothingElse) {
  const int poses = 80;
  const SimulatedGraph sim = SimulateWorld(SimWorld::kManhattan, poses, 10);
  SmootherOptions o;
  o.compute_chi2 = true;
  IncrementalSmoother smoother(o);
  Replay(sim, poses, 0.0, 10, &smoother, nullptr);
  // Empty updates carry out the re-linearisations still due, until none is.
  int settled = 0;
  while (settled < 20 && smoother.Update().relinearized > 0) ++settled;
  ASSERT_LT(settled, 20);
  // One more pose placed where its odometry edge puts it: the optimum of the others stays.
  FactorGraph f;
  Values v;
  SE2d odometry(1, 0, 0.5);
  const Key last = poses - 1, next = poses;
  v.Insert(next, smoother.Estimate().At<SE2d>(last) * odometry);
  f.Add<BetweenSE2>(last, next, odometry, SqrtInformation::Identity(3));
  const double chi2 = smoother.graph().Chi2(smoother.Estimate());
  const Values before = smoother.Estimate();
  const SmootherUpdate u = smoother.Update(std::move(f), std::move(v));
  EXPECT_TRUE(u.solved);
  EXPECT_FALSE(u.structure_rebuilt);
  EXPECT_NEAR(u.chi2_before, chi2, 1e-9 * chi2);
  EXPECT_LE(u.chi2_after, u.chi2_before * (1 + 1e-9));
  // Only the last columns are refactored, and no estimate moves by more than rounding: the
  // back substitution stops where the steps do not change (wildfire_threshold 1e-9).
  EXPECT_EQ(u.relinearized, 0);
  EXPECT_LT(u.affected_columns, poses / 4);
  Values old = smoother.Estimate();
  old.Erase(next);
  EXPECT_LT(MaxDifference(before, old), 1e-8);
  // A closure with an error is solved, and lowers chi2 from the new values' start.
  FactorGraph closure;
  closure.Add<BetweenSE2>(Key(0), next, SE2d(0, 0, 0), SqrtInformation::Identity(3));
  const SmootherUpdate c = smoother.Update(std::move(closure));
  EXPECT_TRUE(c.solved);
  EXPECT_LT(c.chi2_after, c.chi2_before);
  // Without compute_chi2 the fields say "not computed".
  IncrementalSmoother quiet;
  Values w;
  w.Insert(Key(0), SE2d(0, 0, 0));
  w.Insert(Key(1), SE2d(1, 0, 0));
  FactorGraph g;
  g.Add<BetweenSE2>(Key(0), Key(1), SE2d(1, 0, 0), SqrtInformation::Identity(3));
  const SmootherUpdate q = quiet.Update(std::move(g), std::move(w));
  EXPECT_TRUE(std::isnan(q.chi2_before));
  EXPECT_TRUE(std::isnan(q.chi2_after));
}

TEST(IncrementalSmoother, AFailedSolveKeepsTheChangesAndRemovingTheCauseRecovers) {
  const SimulatedGraph sim = SimulateWorld(SimWorld::kManhattan, 40, 11);
  IncrementalSmoother smoother;
  Replay(sim, 40, 0.0, 11, &smoother, nullptr);
  const Values before = smoother.Estimate();
  // A new pose whose initial guess is not finite: chi2 cannot be evaluated.
  FactorGraph f;
  Values v;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  v.Insert(Key(40), SE2d(nan, 0, 0));
  f.Add<BetweenSE2>(Key(39), Key(40), SE2d(1, 0, 0), SqrtInformation::Identity(3));
  const SmootherUpdate bad = smoother.Update(std::move(f), std::move(v));
  EXPECT_TRUE(bad.solved);
  EXPECT_TRUE(bad.fell_back);
  EXPECT_EQ(bad.status, SolverStatus::kInvalidInput) << bad.message;
  EXPECT_EQ(bad.factors_added, 1);
  EXPECT_TRUE(smoother.Estimate().Has(40));
  for (Key k : before.keys()) {
    EXPECT_EQ(0, std::memcmp(before.Params(k), smoother.Estimate().Params(k), 3 * sizeof(double))) << k;
  }
  // Taking the factor out again erases the pose, and the next solve succeeds.
  const SmootherUpdate fixed = smoother.Update({}, {}, {bad.new_factor_ids[0]});
  EXPECT_EQ(fixed.variables_removed, 1);
  EXPECT_FALSE(smoother.Estimate().Has(40));
  EXPECT_TRUE(fixed.solved);
  EXPECT_EQ(fixed.status, SolverStatus::kConverged) << fixed.message;
}

// Restart: the graph and values replace everything, the values are taken as given (not refined),
// the handles start over, and an invalid restart changes nothing.
TEST(IncrementalSmoother, RestartStartsOverFromTheGivenGraphAndValues) {
  const int poses = 30;
  const SimulatedGraph sim = SimulateWorld(SimWorld::kManhattan, poses, 15);
  IncrementalSmoother smoother;
  Replay(sim, poses, 0.0, 15, &smoother, nullptr);
  const Values before = smoother.Estimate();
  FactorGraph graph;
  for (std::size_t i = 0; i < sim.graph.size(); ++i) graph.Add(sim.graph.at(i).Clone());
  // An invalid restart (a factor on a key without a value) leaves the smoother as it was.
  FactorGraph bad = graph;
  bad.Add<BetweenSE2>(Key(0), Key(999), SE2d(1, 0, 0), SqrtInformation::Isotropic(3, 1));
  EXPECT_THROW(smoother.Restart(std::move(bad), before), InvalidArgument);
  EXPECT_TRUE(BitIdentical(smoother.Estimate(), before));
  // From the optimum, restarting moves nothing (no refinement of the "new" values) and hands
  // out one handle per factor.
  double chi2 = 0;
  const Values optimum = BatchOptimum(sim.graph, sim.initial, &chi2);
  const SmootherUpdate u = smoother.Restart(graph, optimum);
  EXPECT_EQ(u.new_factor_ids.size(), sim.graph.size());
  EXPECT_EQ(smoother.graph().size(), sim.graph.size());
  EXPECT_LT(MaxDifference(smoother.Estimate(), optimum), 1e-7);
  EXPECT_NEAR(smoother.graph().Chi2(smoother.Estimate()), chi2, 1e-9 * chi2);
  // The new handles work.
  const SmootherUpdate removed = smoother.Update({}, {}, {u.new_factor_ids.back()});
  EXPECT_EQ(removed.factors_removed, 1);
}

TEST(IncrementalSmoother, AnEmptySmoother) {
  IncrementalSmoother smoother;
  const SmootherUpdate u = smoother.Update();
  EXPECT_FALSE(u.solved);
  EXPECT_EQ(u.factors_added + u.variables_added, 0);
  EXPECT_TRUE(smoother.Finish().empty());
  EXPECT_EQ(smoother.finish_summary().status, SolverStatus::kConverged);
  // A variable without factors is held where it was given.
  Values v;
  v.Insert(Key(0), SE2d(1, 2, 0.5));
  smoother.Update({}, std::move(v));
  EXPECT_EQ(smoother.Estimate().At<SE2d>(0).translation(), Eigen::Vector2d(1, 2));
  EXPECT_THROW(smoother.Marginal(0), InvalidArgument);
}

TEST(IncrementalSmoother, InvalidOptionsThrow) {
  SmootherOptions o;
  o.update.max_iterations = -1;
  std::string why;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("update"), std::string::npos);
  EXPECT_THROW(IncrementalSmoother{o}, InvalidArgument);
  EXPECT_TRUE(SmootherOptions().IsValid(nullptr));
  // Each setting names itself; NaN is refused like a negative value.
  const struct {
    const char* name;
    double SmootherOptions::*field;
    double bad;
  } fields[] = {{"relinearize_threshold", &SmootherOptions::relinearize_threshold, -0.1},
                {"relinearize_sigmas", &SmootherOptions::relinearize_sigmas, std::nan("")},
                {"iterate_ratio", &SmootherOptions::iterate_ratio, 0.5},
                {"iterate_fraction", &SmootherOptions::iterate_fraction, 1.5},
                {"iterate_share", &SmootherOptions::iterate_share, -0.1},
                {"wildfire_threshold", &SmootherOptions::wildfire_threshold, -1},
                {"local_tolerance", &SmootherOptions::local_tolerance, -1e-3},
                {"local_batch_gap", &SmootherOptions::local_batch_gap, std::nan("")},
                {"local_batch_share", &SmootherOptions::local_batch_share, 1.5},
                {"local_batch_correction", &SmootherOptions::local_batch_correction, -1}};
  for (const auto& f : fields) {
    SmootherOptions bad;
    bad.*f.field = f.bad;
    EXPECT_FALSE(bad.IsValid(&why)) << f.name;
    EXPECT_NE(why.find(f.name), std::string::npos) << why;
  }
  SmootherOptions rounds;
  rounds.rounds_per_update = 0;
  EXPECT_FALSE(rounds.IsValid(&why));
  EXPECT_NE(why.find("rounds_per_update"), std::string::npos) << why;
  // The local mode's integer settings too.
  SmootherOptions hops;
  hops.local_hops = -1;
  EXPECT_FALSE(hops.IsValid(&why));
  EXPECT_NE(why.find("local_hops"), std::string::npos) << why;
  SmootherOptions region;
  region.local_max_region = 0;
  EXPECT_FALSE(region.IsValid(&why));
  EXPECT_NE(why.find("local_max_region"), std::string::npos) << why;
}

// A ring of n unit steps whose odometry turns `drift` rad too far at every step, closed by
// one loop closure at the last pose. Returns the relative chi2 gap of the estimate after the
// closing update to the optimum of the ring, and that update's summary in *closing.
double RingGap(const SmootherOptions& o, int n, double drift, SmootherUpdate* closing) {
  const double turn = 2 * M_PI / n;
  IncrementalSmoother smoother(o);
  for (int i = 0; i < n; ++i) {
    FactorGraph f;
    Values v;
    const Key k = static_cast<Key>(i);
    if (i == 0) {
      v.Insert(k, SE2d(0, 0, 0));
    } else {
      const SE2d odometry(1, 0, turn + drift);
      v.Insert(k, smoother.Estimate().At<SE2d>(k - 1) * odometry);
      f.Add<BetweenSE2>(k - 1, k, odometry, SqrtInformation::Identity(3));
    }
    if (i == n - 1) f.Add<BetweenSE2>(k, Key(0), SE2d(1, 0, turn), SqrtInformation::Identity(3));
    *closing = smoother.Update(std::move(f), std::move(v), {});
    EXPECT_TRUE(closing->solved || i == 0) << closing->message;
  }
  Values optimum = smoother.Estimate();
  const SolverSummary s = Optimize(smoother.graph(), &optimum, o.finish);
  EXPECT_TRUE(s.IsSolutionUsable()) << s.FullReport();
  EXPECT_GT(s.final_chi2, 0);
  return (smoother.graph().Chi2(smoother.Estimate()) - s.final_chi2) / s.final_chi2;
}

// The same ring with the default options and with one changed.
struct RingRuns {
  double gap_default = 0, gap_changed = 0;
  SmootherUpdate default_update, changed_update;
};
RingRuns DefaultAndChanged(int n, double drift, const std::function<void(SmootherOptions*)>& change) {
  RingRuns r;
  SmootherOptions changed;
  change(&changed);
  r.gap_default = RingGap(SmootherOptions(), n, drift, &r.default_update);
  r.gap_changed = RingGap(changed, n, drift, &r.changed_update);
  return r;
}

TEST(IncrementalSmoother, AfterALoopClosureStepsNearTheThresholdsAreReLinearisedToo) {
  // Measured: a relative gap of 5.8e-6 with the default iterate_fraction (0.5), 1.1e-4 when
  // only the steps beyond the thresholds are re-linearised (1).
  // A ring of 120 poses closing with 0.24 rad of drift: most poses move by a little less than
  // the re-linearisation threshold.
  ASSERT_EQ(SmootherOptions().iterate_fraction, 0.5);
  const RingRuns r = DefaultAndChanged(120, 0.002, [](SmootherOptions* o) { o->iterate_fraction = 1; });
  EXPECT_LT(r.gap_default, 2e-5);
  EXPECT_GT(r.gap_changed, 5e-5);
  EXPECT_GT(r.default_update.relinearized, r.changed_update.relinearized);
}

TEST(IncrementalSmoother, ZeroThresholdsReLineariseEveryStep) {
  // relinearize_threshold 0: every variable whose step is not zero is re-linearised, and the
  // update iterates (Gauss-Newton) up to rounds_per_update: the estimate after an update with
  // a loop closure is then the optimum of the graph so far to far below the default's gap.
  const int poses = 60;
  const SimulatedGraph sim = SimulateWorld(SimWorld::kManhattan, poses, 14);
  SmootherOptions o;
  o.relinearize_threshold = 0;
  o.relinearize_sigmas = 0;
  o.rounds_per_update = 20;
  ASSERT_TRUE(o.IsValid(nullptr));
  IncrementalSmoother smoother(o);
  FactorGraph final;
  Replay(sim, poses, 0.0, 14, &smoother, &final);
  Values batch = smoother.Estimate();
  const SolverSummary s = Optimize(final, &batch);
  ASSERT_EQ(s.status, SolverStatus::kConverged) << s.message;
  const double online = final.Chi2(smoother.Estimate());
  EXPECT_NEAR(online, s.final_chi2, 1e-8 * s.final_chi2);
}

TEST(IncrementalSmoother, WhenMuchOfTheMapMovesTheUpdateSolvesAgain) {
  // A ring of 30 poses closing with 15 mrad of drift: no step is 5 times too large, but most
  // poses move beyond the thresholds. Measured: with iterate_share 1 (the rule off) one round
  // and a relative gap of 0.047 (0.15 with the given values of new variables), far beyond the
  // issue's 1e-3; with the default 0.2 two rounds and 3.7e-4.
  ASSERT_EQ(SmootherOptions().iterate_share, 0.2);
  const RingRuns r = DefaultAndChanged(30, 0.0005, [](SmootherOptions* o) { o->iterate_share = 1; });
  EXPECT_LT(r.gap_default, 1e-3);
  EXPECT_GT(r.gap_changed, 1e-2);
  EXPECT_EQ(r.changed_update.iterations, 1);
  EXPECT_GT(r.default_update.iterations, 1);
}

// Three poses on a line, then a fourth given 0.3 m and 0.2 rad off where its odometry and a
// loop closure to the second pose (which agree) put it. Returns that update.
SmootherUpdate AddAFourthPoseGuessedOff(const SmootherOptions& o, Values* estimate, double* gap, bool fix = false) {
  IncrementalSmoother smoother(o);
  for (int i = 0; i < 3; ++i) {
    FactorGraph f;
    Values v;
    v.Insert(Key(i), SE2d(i, 0, 0));
    if (i > 0) f.Add<BetweenSE2>(Key(i - 1), Key(i), SE2d(1, 0, 0), SqrtInformation::Identity(3));
    smoother.Update(std::move(f), std::move(v), {});
  }
  FactorGraph f;
  Values v;
  v.Insert(Key(3), SE2d(3.3, 0.1, 0.2));
  f.Add<BetweenSE2>(Key(2), Key(3), SE2d(1, 0, 0), SqrtInformation::Identity(3));
  f.Add<BetweenSE2>(Key(1), Key(3), SE2d(2, 0, 0), SqrtInformation::Identity(3));
  if (fix) f.Fix(Key(3));
  const SmootherUpdate u = smoother.Update(std::move(f), std::move(v), {});
  *estimate = smoother.Estimate();
  Values optimum = smoother.Estimate();
  const SolverSummary s = Optimize(smoother.graph(), &optimum, o.finish);
  EXPECT_TRUE(s.IsSolutionUsable()) << s.FullReport();
  *gap = smoother.graph().Chi2(smoother.Estimate()) - s.final_chi2;
  return u;
}

TEST(IncrementalSmoother, ANewVariableStartsWhereItsNewFactorsPutIt) {
  // Refined, the fourth pose starts at (3, 0, 0), where both its factors hold: one round,
  // the map unchanged. Given as it is, its first step (0.3 m, 0.2 rad: 10 times the
  // threshold) calls for a second round. Both end at the optimum (chi2 0).
  SmootherOptions refined;
  ASSERT_TRUE(refined.refine_new_values);
  SmootherOptions given;
  given.refine_new_values = false;
  Values a, b;
  double gap_a = 0, gap_b = 0;
  const SmootherUpdate ua = AddAFourthPoseGuessedOff(refined, &a, &gap_a);
  const SmootherUpdate ub = AddAFourthPoseGuessedOff(given, &b, &gap_b);
  EXPECT_EQ(ua.iterations, 1);
  EXPECT_GE(ub.iterations, 2);
  EXPECT_LT(gap_a, 1e-12);
  EXPECT_LT(gap_b, 1e-12);
  EXPECT_LT((a.At<SE2d>(3).translation() - Eigen::Vector2d(3, 0)).norm(), 1e-9);
  EXPECT_NEAR(a.At<SE2d>(3).theta(), 0, 1e-9);
  for (Key k = 0; k < 3; ++k) {
    EXPECT_LT((a.At<SE2d>(k).translation() - Eigen::Vector2d(static_cast<double>(k), 0)).norm(), 1e-9) << k;
  }
}

TEST(IncrementalSmoother, AFixedNewVariableKeepsItsGivenValue) {
  // Held fixed in the update that adds it, the fourth pose stays where it was given (the
  // refinement leaves fixed variables alone), and the map bends to it instead.
  Values v;
  double gap = 0;
  AddAFourthPoseGuessedOff(SmootherOptions(), &v, &gap, /*fix=*/true);
  EXPECT_EQ(v.At<SE2d>(3).translation(), Eigen::Vector2d(3.3, 0.1));
  EXPECT_EQ(v.At<SE2d>(3).theta(), 0.2);
}

TEST(IncrementalSmoother, TheAutomaticGaugeIsNotRefined) {
  // Nothing fixed, no prior: the smoother holds the lowest pose where it is given, as Optimize
  // does. Pose 0 arrives with two factors (0-1 and a closure 0-2 that disagrees with the
  // chain): refined, it would move to x = 0.1 and be held there, shifting the whole map.
  FactorGraph f;
  Values v;
  for (int i = 0; i < 3; ++i) v.Insert(Key(i), SE2d(i, 0, 0));
  f.Add<BetweenSE2>(Key(0), Key(1), SE2d(1, 0, 0), SqrtInformation::Identity(3));
  f.Add<BetweenSE2>(Key(1), Key(2), SE2d(1, 0, 0), SqrtInformation::Identity(3));
  f.Add<BetweenSE2>(Key(0), Key(2), SE2d(1.8, 0, 0), SqrtInformation::Identity(3));
  Values batch = v;
  ASSERT_TRUE(Optimize(f, &batch).IsSolutionUsable());
  IncrementalSmoother smoother;
  const SmootherUpdate u = smoother.Update(f, v, {});
  ASSERT_TRUE(u.solved) << u.message;
  EXPECT_EQ(smoother.Estimate().At<SE2d>(0).translation(), Eigen::Vector2d(0, 0));
  EXPECT_LT(MaxDifference(smoother.Finish(), batch), 1e-9);
}

TEST(IncrementalSmoother, Refined3DPosesAndRobustFactorsReachTheSameOptimum) {
  // SE3 poses (quaternion parameters, 6-dof steps) with Huber on every factor, each new pose
  // guessed 0.2 m and 0.1 rad off where its odometry and its closure (which agree) put it:
  // with and without refinement the estimate after each update is the optimum of the graph so
  // far, and refinement needs fewer rounds.
  auto run = [](bool refine, int* rounds) {
    SmootherOptions o;
    o.refine_new_values = refine;
    IncrementalSmoother smoother(o);
    const SE3d step(SO3d::Exp(Eigen::Vector3d(0, 0, 0.3)), Eigen::Vector3d(1, 0, 0.1));
    *rounds = 0;
    for (int i = 0; i < 12; ++i) {
      FactorGraph f;
      Values v;
      const Key k = static_cast<Key>(i);
      if (i == 0) {
        v.Insert(k, SE3d());
      } else {
        const SE3d off(SO3d::Exp(Eigen::Vector3d(0.1, 0, 0)), Eigen::Vector3d(0.2, 0, 0));
        v.Insert(k, smoother.Estimate().At<SE3d>(k - 1) * step * off);
        f.Add<BetweenSE3>(k - 1, k, step, SqrtInformation::Identity(6));
        f.at(f.size() - 1).set_loss(MakeLoss("huber:1"));
      }
      if (i >= 2) {
        f.Add<BetweenSE3>(k - 2, k, step * step, SqrtInformation::Identity(6));
        f.at(f.size() - 1).set_loss(MakeLoss("huber:1"));
      }
      const SmootherUpdate u = smoother.Update(std::move(f), std::move(v), {});
      EXPECT_TRUE(u.solved || i == 0) << u.message;
      *rounds += u.iterations;
    }
    return smoother.Estimate();
  };
  int rounds_refined = 0, rounds_given = 0;
  const Values refined = run(true, &rounds_refined);
  const Values given = run(false, &rounds_given);
  for (Key k = 0; k < 12; ++k) {
    // The measurements agree: the optimum is the chain of steps from pose 0.
    SE3d expected;
    for (Key j = 0; j < k; ++j)
      expected = expected * SE3d(SO3d::Exp(Eigen::Vector3d(0, 0, 0.3)), Eigen::Vector3d(1, 0, 0.1));
    EXPECT_LT((refined.At<SE3d>(k).translation() - expected.translation()).norm(), 1e-6) << k;
    EXPECT_LT((given.At<SE3d>(k).translation() - expected.translation()).norm(), 1e-6) << k;
  }
  EXPECT_LT(rounds_refined, rounds_given);
}

// SmootherMode::kLocal: each update solved over a region around it, batch solves now and then.

// chi2 of the smoother's estimate relative to the optimum of its graph so far (a batch solve
// from the estimate).
double GapToOptimumSoFar(const IncrementalSmoother& smoother) {
  Values v = smoother.Estimate();
  const SolverSummary s = Optimize(smoother.graph(), &v, SmootherOptions().finish);
  EXPECT_TRUE(s.IsSolutionUsable()) << s.FullReport();
  return (smoother.graph().Chi2(smoother.Estimate()) - s.final_chi2) / s.final_chi2;
}

SmootherOptions LocalOptions() {
  SmootherOptions o;
  o.mode = SmootherMode::kLocal;
  return o;
}

TEST(LocalSmoother, EqualsBatchAfterFinishOnRandomAddsAndRemovals) {
  for (std::uint64_t seed : {1, 2, 3}) {
    const int poses = 150;
    const SimulatedGraph sim = SimulateWorld(SimWorld::kManhattan, poses, seed);
    IncrementalSmoother smoother(LocalOptions());
    FactorGraph final;
    int local = 0;
    Replay(sim, poses, 0.05, seed, &smoother, &final,
           [&](int, const SmootherUpdate& u) { local += u.solved && !u.batch ? 1 : 0; });
    // In a graph this small chi2 is small, and most loop closures gain more than the batch
    // rules allow (local_batch_correction): the larger worlds are where updates stay local.
    EXPECT_GT(local, 10) << "some updates should be solved locally";
    ASSERT_EQ(smoother.graph().size(), final.size());
    EXPECT_LT(final.size(), sim.graph.size()) << "some loop closures should have been removed";
    smoother.Finish();
    ASSERT_TRUE(smoother.finish_summary().IsSolutionUsable()) << smoother.finish_summary().FullReport();
    double batch_chi2 = 0;
    BatchOptimum(final, sim.initial, &batch_chi2);
    EXPECT_NEAR(final.Chi2(smoother.Estimate()), batch_chi2, 1e-9 * batch_chi2) << "seed " << seed;
  }
}

TEST(LocalSmoother, EveryUpdateIsWithin1e3OfTheOptimumSoFar) {
  // The bar for every estimate: chi2 within 1e-3 of the optimum of the graph so far.
  // Checked after every update of a 400-pose world (every closure, every batch solve).
  const int poses = 400;
  const SimulatedGraph sim = SimulateWorld(SimWorld::kManhattan, poses, 12);
  IncrementalSmoother smoother(LocalOptions());
  double worst = 0;
  int local = 0, batch = 0, region = 0;
  Replay(sim, poses, 0.0, 12, &smoother, nullptr, [&](int step, const SmootherUpdate& u) {
    if (step < 2) return;
    local += u.batch ? 0 : 1;
    batch += u.batch ? 1 : 0;
    region = std::max(region, u.region);
    worst = std::max(worst, GapToOptimumSoFar(smoother));
  });
  EXPECT_LT(worst, 1e-3);
  EXPECT_GT(local, batch / 2) << "local solves should not be the exception";
  EXPECT_LT(region, poses / 2) << "the regions should stay local";
}

TEST(LocalSmoother, OnALargerWorldMostUpdatesAreLocalAndNearTheOptimum) {
  // 3000 poses: chi2 grows with the graph, the batch rules fire less often, and most updates
  // are solved over a region of tens of variables; every 100th update is checked.
  const int poses = 3000;
  const SimulatedGraph sim = SimulateWorld(SimWorld::kManhattan, poses, 14);
  IncrementalSmoother smoother(LocalOptions());
  double worst = 0;
  int local = 0, late_local = 0, late = 0;
  long long region = 0;
  Replay(sim, poses, 0.0, 14, &smoother, nullptr, [&](int step, const SmootherUpdate& u) {
    local += u.batch ? 0 : 1;
    region += u.region;
    if (step >= poses / 2) {
      ++late;
      late_local += u.batch ? 0 : 1;
    }
    if (step % 100 != 99) return;
    worst = std::max(worst, GapToOptimumSoFar(smoother));
  });
  EXPECT_LT(worst, 1e-3);
  EXPECT_GT(late_local, 0.9 * late) << "in the second half, batch solves should be rare";
  EXPECT_LT(static_cast<double>(region) / local, 100) << "regions should be tens of variables";
}

TEST(LocalSmoother, ARegionReachesTheOptimumWithItsEdgeHeld) {
  // A chain of 30 poses with a closure between poses 10 and 20, every variable in the region
  // (local_tolerance 0: the region grows while any edge gain is left, here to the whole chain
  // but the held gauge), so the local solve is the batch optimum.
  SmootherOptions o = LocalOptions();
  o.local_tolerance = 0;
  o.local_batch_share = 1;
  o.local_batch_gap = 1e9;
  o.local_batch_correction = 1e9;
  IncrementalSmoother smoother(o);
  FactorGraph f;
  Values v;
  for (int i = 0; i < 30; ++i) {
    v.Insert(Key(i), SE2d(i, 0.01 * i * i, 0.002 * i));
    if (i > 0) f.Add<BetweenSE2>(Key(i - 1), Key(i), SE2d(1, 0, 0.01), SqrtInformation::Identity(3));
  }
  smoother.Update(std::move(f), std::move(v));  // the first update: a batch solve
  FactorGraph closure;
  closure.Add<BetweenSE2>(Key(10), Key(20), SE2d(9.5, 0.8, 0.15), SqrtInformation::Identity(3));
  const SmootherUpdate u = smoother.Update(std::move(closure));
  ASSERT_TRUE(u.solved);
  EXPECT_FALSE(u.batch);
  EXPECT_EQ(u.region, 29) << "every pose but the gauge";
  Values batch = smoother.Estimate();
  const SolverSummary s = Optimize(smoother.graph(), &batch, SmootherOptions().finish);
  EXPECT_NEAR(smoother.graph().Chi2(smoother.Estimate()), s.final_chi2, 1e-9 * s.final_chi2);
}

TEST(LocalSmoother, ARegionBeyondItsLimitIsSolvedInBatch) {
  // A ring of 60 whose closure bends the whole ring: with regions of at most 10 variables the
  // closing update is a batch solve, and its estimate is the optimum.
  SmootherOptions o = LocalOptions();
  o.local_max_region = 10;
  SmootherUpdate closing;
  const double gap = RingGap(o, 60, 0.01, &closing);
  EXPECT_TRUE(closing.batch);
  EXPECT_EQ(closing.region, 0);
  EXPECT_LT(gap, 1e-9);
  // With the default limit the ring is solved locally (60 variables) and is within 1e-3.
  SmootherUpdate local;
  EXPECT_LT(RingGap(LocalOptions(), 60, 0.01, &local), 1e-3);
}

TEST(LocalSmoother, BatchSolvesComeAtTheShareOfTheVariables) {
  // Only the share rule: a batch solve once the updates since the last reach 10% of the
  // variables, so about every 10th update at 100 poses, and never two in a row.
  SmootherOptions o = LocalOptions();
  o.local_batch_share = 0.1;
  o.local_batch_gap = 1e9;
  o.local_batch_correction = 1e9;
  const int poses = 200;
  const SimulatedGraph sim = SimulateWorld(SimWorld::kManhattan, poses, 13);
  IncrementalSmoother smoother(o);
  std::vector<int> batches;
  Replay(sim, poses, 0.0, 13, &smoother, nullptr, [&](int step, const SmootherUpdate& u) {
    if (u.batch) batches.push_back(step);
  });
  ASSERT_GE(batches.size(), 3u);
  for (std::size_t i = 1; i < batches.size(); ++i) {
    const int gap = batches[i] - batches[i - 1];
    EXPECT_GE(gap, static_cast<int>(0.1 * batches[i - 1])) << "at step " << batches[i];
    EXPECT_LE(gap, static_cast<int>(0.1 * (batches[i] + 1)) + 1) << "at step " << batches[i];
  }
}

TEST(LocalSmoother, RemovingALoopClosureRestoresThePreviousOptimum) {
  const int poses = 100;
  const SimulatedGraph sim = SimulateWorld(SimWorld::kManhattan, poses, 4);
  IncrementalSmoother smoother(LocalOptions());
  Replay(sim, poses, 0.0, 4, &smoother, nullptr);
  const Values before = smoother.Finish();
  const double chi2_before = smoother.finish_summary().final_chi2;
  FactorGraph closure;
  std::size_t j = 0;
  while (IsOdometry(sim.graph.at(j))) ++j;
  closure.Add(sim.graph.at(j).Clone());
  const SmootherUpdate added = smoother.Update(std::move(closure));
  const double with = smoother.graph().Chi2(smoother.Estimate());
  EXPECT_GT(with, chi2_before);
  const SmootherUpdate removed = smoother.Update({}, {}, {added.new_factor_ids[0]});
  EXPECT_EQ(removed.factors_removed, 1);
  // Solved locally around the closure's poses, already within 1e-3 of the previous optimum;
  // after Finish, the optimum itself.
  EXPECT_LT(smoother.graph().Chi2(smoother.Estimate()), (1 + 1e-3) * chi2_before);
  smoother.Finish();
  EXPECT_NEAR(smoother.finish_summary().final_chi2, chi2_before, 1e-9 * chi2_before);
}

TEST(LocalSmoother, Deterministic) {
  const int poses = 150;
  const SimulatedGraph sim = SimulateWorld(SimWorld::kManhattan, poses, 5);
  IncrementalSmoother a(LocalOptions()), b(LocalOptions());
  Replay(sim, poses, 0.05, 5, &a, nullptr);
  Replay(sim, poses, 0.05, 5, &b, nullptr);
  EXPECT_TRUE(BitIdentical(a.Estimate(), b.Estimate()));
  EXPECT_TRUE(BitIdentical(a.Finish(), b.Finish()));
}

TEST(LocalSmoother, RemovingTheLastFactorOfAVariableErasesIt) {
  const SimulatedGraph sim = SimulateWorld(SimWorld::kManhattan, 10, 8);
  IncrementalSmoother smoother(LocalOptions());
  Replay(sim, 10, 0.0, 8, &smoother, nullptr);
  const FactorId odometry = smoother.graph().id(smoother.graph().size() - 1);
  const SmootherUpdate u = smoother.Update({}, {}, {odometry});
  EXPECT_EQ(u.variables_removed, 1);
  EXPECT_FALSE(smoother.Estimate().Has(9));
}

TEST(LocalSmoother, Refined3DPosesReachTheBatchOptimum) {
  const int poses = 100;
  const SimulatedGraph sim = SimulateWorld(SimWorld::kSphere, poses, 3);
  IncrementalSmoother smoother(LocalOptions());
  FactorGraph final;
  double worst = 0;
  Replay(sim, poses, 0.0, 3, &smoother, &final, [&](int step, const SmootherUpdate&) {
    if (step % 10 != 9) return;
    worst = std::max(worst, GapToOptimumSoFar(smoother));
  });
  EXPECT_LT(worst, 1e-3);
  smoother.Finish();
  double batch_chi2 = 0;
  BatchOptimum(final, sim.initial, &batch_chi2);
  EXPECT_NEAR(final.Chi2(smoother.Estimate()), batch_chi2, 1e-9 * batch_chi2);
}

}  // namespace
}  // namespace tether
