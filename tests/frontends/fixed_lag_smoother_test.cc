// The fixed-lag smoother on simulated worlds whose loop closures all fall inside the window:
// its window against the batch optimum of the whole graph so far, the marginal covariances it
// keeps against those of the whole graph, a bounded window over a long run, handles that
// survive marginalisation, and the updates it refuses.
#include "tether/solvers/fixed_lag_smoother.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <vector>

#include "testing/simulated.h"
#include "tether/core/error.h"
#include "tether/factors/marginal_prior.h"
#include "tether/factors/prior.h"
#include "tether/solvers/covariance.h"
#include "tether/solvers/initialize.h"
#include "tether/solvers/optimizer.h"

namespace tether {
namespace {

using testing::SimulateWorld;

// Inserts every variable of `from` into *into.
void Append(const Values& from, Values* into) {
  for (Key k : from.keys()) into->InsertParams(k, from.TypeOf(k), from.Params(k));
}

// A simulated world without the loop closures that span more than `max_span` poses.
SimulatedGraph ShortLoops(SimWorld world, int poses, std::uint64_t seed, Key max_span) {
  SimulatedGraph sim = SimulateWorld(world, poses, seed);
  FactorGraph kept;
  for (std::size_t i = 0; i < sim.graph.size(); ++i) {
    const std::vector<Key>& k = sim.graph.at(i).keys();
    if (std::max(k[0], k[1]) - std::min(k[0], k[1]) <= max_span) kept.Add(sim.graph.at(i).Clone());
  }
  sim.graph = std::move(kept);
  return sim;
}

// Feeds the first `poses` poses of `sim` one per update, each guessed from the previous estimate and its
// odometry. `after(i, update, graph so far)` runs after each update.
template <class Smoother>
void Feed(const SimulatedGraph& sim, int poses, Smoother* smoother,
          const std::function<void(int, const SmootherUpdate&, const FactorGraph&)>& after = {}) {
  std::vector<std::vector<std::size_t>> by_step(sim.initial.size());
  for (std::size_t j = 0; j < sim.graph.size(); ++j) {
    const std::vector<Key>& k = sim.graph.at(j).keys();
    by_step[*std::max_element(k.begin(), k.end())].push_back(j);
  }
  FactorGraph so_far;
  for (int i = 0; i < poses; ++i) {
    const Key k = static_cast<Key>(i);
    const VarType type = sim.initial.TypeOf(k);
    std::vector<double> p(sim.initial.Params(k), sim.initial.Params(k) + AmbientDim(type));
    FactorGraph f;
    for (std::size_t j : by_step[static_cast<std::size_t>(i)]) {
      const Factor& factor = sim.graph.at(j);
      if (factor.keys().size() == 2 && factor.keys()[0] == k - 1 && factor.keys()[1] == k) {
        factor.Predict(0, smoother->Estimate().Params(k - 1), 1, p.data());
      }
      f.Add(factor.Clone());
      so_far.Add(factor.Clone());
    }
    Values v;
    v.InsertParams(k, type, p.data());
    const SmootherUpdate u = smoother->Update(std::move(f), std::move(v));
    if (after) after(i, u, so_far);
  }
}

// The batch optimum of `graph` from `start`.
Values BatchOptimum(const FactorGraph& graph, const Values& start) {
  Values v = start;
  const SolverSummary s = Optimize(graph, &v, SmootherOptions().finish);
  EXPECT_TRUE(s.IsSolutionUsable()) << s.FullReport();
  return v;
}

// Largest difference of the poses of `window` from the same poses in `whole`, each taken
// relative to the window's first pose (the fixed-lag smoother's gauge moves on with the window,
// the batch solve's stays at the first pose): position (metres) and rotation (radians, the
// tangent's rotation part).
template <class Pose>
void RelativeDifference(const Values& window, const Values& whole, double* position, double* rotation) {
  const Key first = *std::min_element(window.keys().begin(), window.keys().end());
  const Pose w0 = window.At<Pose>(first).Inverse(), b0 = whole.At<Pose>(first).Inverse();
  for (Key k : window.keys()) {
    const auto d = (b0 * whole.At<Pose>(k)).Local(w0 * window.At<Pose>(k));
    const int translation = d.size() == 3 ? 2 : 3;
    for (int j = 0; j < d.size(); ++j) {
      double& m = j < translation ? *position : *rotation;
      m = std::max(m, std::abs(d[j]));
    }
  }
}

void PoseDifference(const Values& window, const Values& whole, double* position, double* rotation) {
  *position = *rotation = 0;
  if (window.Count(VarType::kSE2) > 0) {
    RelativeDifference<SE2d>(window, whole, position, rotation);
  } else {
    RelativeDifference<SE3d>(window, whole, position, rotation);
  }
}

// The optimum of the window (its factors and the prior) against the batch optimum of the whole
// graph so far, at four steps along a world whose closures span at most `span` poses: the
// largest differences of the window's poses (metres, radians) over the four.
std::pair<double, double> WindowAgainstBatch(SimWorld world, int poses, Key span, double lag) {
  const SimulatedGraph sim = ShortLoops(world, poses, 21, span);
  FixedLagOptions o;
  o.lag = lag;
  FixedLagSmoother smoother(o);
  Values gone;  // the marginalised variables' final estimates
  int checks = 0;
  double largest_position = 0, largest_rotation = 0;
  Feed(sim, poses, &smoother, [&](int i, const SmootherUpdate&, const FactorGraph& so_far) {
    Append(smoother.TakeMarginalized(), &gone);
    if ((i + 1) % (poses / 4) != 0) return;
    Values window = smoother.Estimate();
    Optimize(smoother.graph(), &window, SmootherOptions().finish);
    Values start = gone;
    Append(window, &start);
    const Values batch = BatchOptimum(so_far, start);
    double position = 0, rotation = 0;
    PoseDifference(window, batch, &position, &rotation);
    largest_position = std::max(largest_position, position);
    largest_rotation = std::max(largest_rotation, rotation);
    std::printf(
        "[ fixed lag ] %s, lag %g, step %d: window %zu poses, %zu marginalised; largest difference from the "
        "batch optimum %.2e m, %.2e rad\n",
        ToString(world), lag, i, window.size(), smoother.marginalized(), position, rotation);
    ++checks;
  });
  EXPECT_EQ(checks, 4);
  EXPECT_GT(smoother.marginalized(), static_cast<std::size_t>(poses) - static_cast<std::size_t>(2 * lag));
  return {largest_position, largest_rotation};
}

// Every closure inside the lag: the window is at the batch optimum to rounding (the prior is
// linearised at the window's optimum, and the closures after it barely bend the separator).
TEST(FixedLagSmoother, TheWindowIsAtTheBatchOptimumWhenEveryClosureFallsInsideIt) {
  const auto [position, rotation] = WindowAgainstBatch(SimWorld::kManhattan, 400, 30, 50);
  EXPECT_LT(position, 1e-8);
  EXPECT_LT(rotation, 1e-8);
}

// In the sphere world the rings (closures of about 20 poses) cross the cut, so the separator is
// a dozen poses, and the closures that come after a marginalisation turn them against each
// other by some milliradians: the prior's linearisation, frozen where they were, is off by the
// second order of that (about 1e-3 m with a lag of 50). A longer lag leaves less to come after.
TEST(FixedLagSmoother, In3DTheFrozenLinearisationCostsLessWithALongerLag) {
  const auto [p50, r50] = WindowAgainstBatch(SimWorld::kSphere, 400, 30, 50);
  const auto [p200, r200] = WindowAgainstBatch(SimWorld::kSphere, 400, 30, 200);
  EXPECT_LT(p50, 3e-3);
  EXPECT_LT(r50, 1e-3);
  EXPECT_LT(p200, p50 / 5);
  EXPECT_LT(r200, r50 / 5);
  // Odometry alone: the separator is one pose, which nothing after can turn against another:
  // exact.
  const auto [p_chain, r_chain] = WindowAgainstBatch(SimWorld::kSphere, 200, 1, 20);
  EXPECT_LT(p_chain, 1e-9);
  EXPECT_LT(r_chain, 1e-9);
}

// Right after a marginalisation the window's marginal covariances are those of the whole
// graph at the same estimate: the prior carries exactly what the marginalised part said.
TEST(FixedLagSmoother, MarginalCovariancesAreThoseOfTheWholeGraph) {
  const int poses = 150;
  const SimulatedGraph sim = ShortLoops(SimWorld::kManhattan, poses, 22, 15);
  FixedLagOptions o;
  o.lag = 30;
  // Re-linearised at every step: the estimate is a converged Gauss-Newton point, so the
  // restart after a marginalisation does not move it.
  o.smoother.relinearize_threshold = 0;
  o.smoother.relinearize_sigmas = 0;
  FixedLagSmoother smoother(o);
  Values gone;
  int compared = 0;
  Feed(sim, poses, &smoother, [&](int, const SmootherUpdate& u, const FactorGraph& so_far) {
    Append(smoother.TakeMarginalized(), &gone);
    if (u.marginalized == 0) return;
    Values all = gone;
    Append(smoother.Estimate(), &all);
    // The window's gauge: the pose it holds (moved on with it), as the whole graph's.
    ASSERT_EQ(smoother.graph().fixed().size(), 1u);
    FactorGraph gauged = so_far;
    gauged.Fix(*smoother.graph().fixed().begin());
    const Marginals whole(gauged, all);
    for (Key k : smoother.Estimate().keys()) {
      if (smoother.graph().IsFixed(k)) continue;
      const Eigen::MatrixXd a = smoother.Marginal(k);
      const Eigen::MatrixXd b = whole.Marginal(k);
      EXPECT_LT((a - b).norm(), 1e-7 * b.norm()) << "key " << k << "\n" << a << "\n" << b;
    }
    ++compared;
  });
  EXPECT_GE(compared, 3);
}

TEST(FixedLagSmoother, TheWindowStaysBoundedOnALongRun) {
  const int poses = 1500;
  const SimulatedGraph sim = ShortLoops(SimWorld::kManhattan, poses, 23, 20);
  FixedLagOptions o;
  o.lag = 40;
  o.batch = 0.25;
  FixedLagSmoother smoother(o);
  std::size_t largest_window = 0, largest_graph = 0;
  int marginalisations = 0;
  Values all;
  Feed(sim, poses, &smoother, [&](int, const SmootherUpdate& u, const FactorGraph&) {
    largest_window = std::max(largest_window, smoother.Estimate().size());
    largest_graph = std::max(largest_graph, smoother.graph().size());
    marginalisations += u.marginalized > 0;
    Append(smoother.TakeMarginalized(), &all);
  });
  // At most lag * (1 + batch) + 1 poses before a marginalisation brings it back to lag + 1.
  EXPECT_LE(largest_window, 52u);
  EXPECT_GE(largest_window, 41u);
  EXPECT_LE(largest_graph, 4 * largest_window);
  EXPECT_EQ(smoother.marginalized() + smoother.Estimate().size(), static_cast<std::size_t>(poses));
  EXPECT_NEAR(marginalisations, (poses - 41) / 11, 2);  // every 11 poses once the window is full
  // Each pose's final estimate (when it left the window, or the window's now) is near the
  // batch optimum of the whole graph.
  Append(smoother.Estimate(), &all);
  ASSERT_EQ(all.size(), static_cast<std::size_t>(poses));
  const Values batch = BatchOptimum(sim.graph, all);
  double position = 0, rotation = 0;
  PoseDifference(all, batch, &position, &rotation);
  EXPECT_LT(position, 0.05);
  EXPECT_LT(rotation, 0.01);
  std::printf(
      "[ fixed lag ] 1500 poses, lag 40: window at most %zu poses and %zu factors, %d marginalisations; "
      "estimates at most %.2e m, %.2e rad from the batch optimum\n",
      largest_window, largest_graph, marginalisations, position, rotation);
}

// Ten thousand poses of relative measurements (closures up to 30 poses back, a lag of 120):
// the window's place in the world is known to the
// whole past only as well as some 1e-12 of its relative information, so a prior that kept it
// would let the window float. The gauge moving on with the window keeps every estimate at the
// batch optimum.
TEST(FixedLagSmoother, ALongWalkDoesNotFloat) {
  const int poses = 10000;
  const SimulatedGraph sim = ShortLoops(SimWorld::kManhattan, poses, 27, 30);
  FixedLagOptions o;
  o.lag = 120;
  FixedLagSmoother smoother(o);
  Values all;
  Feed(sim, poses, &smoother,
       [&](int, const SmootherUpdate&, const FactorGraph&) { Append(smoother.TakeMarginalized(), &all); });
  smoother.Finish();
  Append(smoother.Estimate(), &all);
  const double online = sim.graph.Chi2(all);
  const Values batch = BatchOptimum(sim.graph, all);
  const double optimum = sim.graph.Chi2(batch);
  EXPECT_LT((online - optimum) / optimum, 1e-8) << online << " against " << optimum;
}

TEST(FixedLagSmoother, HandlesFollowTheirFactorsAndMarginalisedOnesAreRefused) {
  const int poses = 60;
  const SimulatedGraph sim = ShortLoops(SimWorld::kManhattan, poses, 24, 10);
  FixedLagOptions o;
  o.lag = 10;
  o.batch = 0;
  FixedLagSmoother smoother(o);
  std::vector<std::pair<FactorId, int>> handles;  // and the step that added them
  Feed(sim, poses, &smoother, [&](int i, const SmootherUpdate& u, const FactorGraph&) {
    for (FactorId id : u.new_factor_ids) handles.push_back({id, i});
  });
  // A factor of the newest poses: removed through its handle after many restarts.
  const FactorId recent = handles.back().first;
  const std::size_t before = smoother.graph().size();
  // At the time of the last update (59): nothing else grows older, nothing is marginalised.
  const SmootherUpdate u = smoother.Update({}, {}, {recent}, poses - 1);
  EXPECT_EQ(u.marginalized, 0);
  EXPECT_EQ(u.factors_removed, 1);
  EXPECT_EQ(smoother.graph().size(), before - 1);
  EXPECT_THROW(smoother.Update({}, {}, {recent}), InvalidArgument);  // gone now
  // The first factor left with its variables.
  try {
    smoother.Update({}, {}, {handles.front().first});
    ADD_FAILURE() << "removing a marginalised factor was accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("marginalised"), std::string::npos) << e.what();
  }
  // A loop closure to a marginalised pose is refused and changes nothing.
  EXPECT_TRUE(smoother.WasMarginalized(Key(3)));
  EXPECT_FALSE(smoother.WasMarginalized(Key(poses - 1)));
  const Values before_estimate = smoother.Estimate();
  FactorGraph closure;
  closure.Add(sim.graph.at(0).Clone());  // the odometry 0 -> 1
  try {
    smoother.Update(std::move(closure));
    ADD_FAILURE() << "a factor on a marginalised pose was accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("marginalised"), std::string::npos) << e.what();
  }
  EXPECT_EQ(smoother.Estimate().keys(), before_estimate.keys());
  Values again;
  again.Insert(Key(2), SE2d(0, 0, 0));
  EXPECT_THROW(smoother.Update({}, std::move(again)), InvalidArgument);
  // Time runs forwards only.
  smoother.Update({}, {}, {}, 1000);
  EXPECT_THROW(smoother.Update({}, {}, {}, 999), InvalidArgument);
  EXPECT_THROW(smoother.Update({}, {}, {}, std::numeric_limits<double>::infinity()), InvalidArgument);
}

// Relative measurements only: the gauge (the held pose) moves on with the window, to the lowest
// pose of the separator, and the prior says nothing of the window's place in the world.
TEST(FixedLagSmoother, WithRelativeMeasurementsTheGaugeMovesOnWithTheWindow) {
  const int poses = 40;
  const SimulatedGraph sim = ShortLoops(SimWorld::kManhattan, poses, 25, 8);
  FixedLagOptions o;
  o.lag = 10;
  FixedLagSmoother smoother(o);
  Feed(sim, poses, &smoother);
  ASSERT_EQ(smoother.graph().fixed().size(), 1u);
  const Key gauge = *smoother.graph().fixed().begin();
  EXPECT_TRUE(smoother.Estimate().Has(gauge));
  EXPECT_TRUE(smoother.WasMarginalized(gauge - 1));
  int priors = 0;
  for (const auto& f : smoother.graph().factors()) {
    if (f->type_name() != std::string("MarginalPrior")) continue;
    ++priors;
    // Its information sees no rigid motion of the world: H N = 0, with N the tangent
    // directions in which a small translation and rotation of the world move its poses.
    const auto& prior = static_cast<const MarginalPrior&>(*f);
    const int n = static_cast<int>(3 * prior.keys().size());
    Eigen::MatrixXd N(n, 3);
    const double eps = 1e-7;
    for (int c = 0; c < 3; ++c) {
      const SE2d motion(c == 0 ? eps : 0, c == 1 ? eps : 0, c == 2 ? eps : 0);
      for (std::size_t k = 0; k < prior.keys().size(); ++k) {
        const SE2d x0 = SE2d::FromParams(prior.point(k));
        N.block<3, 1>(static_cast<int>(3 * k), c) = x0.Local(motion * x0) / eps;
      }
    }
    const Eigen::MatrixXd H = prior.Information();
    EXPECT_LT((H * N).norm(), 1e-6 * H.norm() * N.norm());
  }
  EXPECT_GT(priors, 0);
  // A user's fixed pose stays held while it is in the window.
  FixedLagSmoother held(o);
  Feed(sim, 5, &held);
  FactorGraph fix;
  fix.Fix(Key(4));
  held.Update(std::move(fix));
  EXPECT_TRUE(held.graph().IsFixed(Key(4)));
}

// A prior on the first pose anchors the graph in the world: no pose is held, the marginal
// prior carries the anchor, and the window is at the batch optimum in absolute terms.
TEST(FixedLagSmoother, WithAnAnchorTheMarginalPriorCarriesIt) {
  const int poses = 120;
  SimulatedGraph sim = ShortLoops(SimWorld::kManhattan, poses, 26, 15);
  sim.graph.Add<PriorSE2>(Key(0), sim.initial.At<SE2d>(0), SqrtInformation::Isotropic(3, 0.1));
  FixedLagOptions o;
  o.lag = 25;
  FixedLagSmoother smoother(o);
  Values gone;
  Feed(sim, poses, &smoother,
       [&](int, const SmootherUpdate&, const FactorGraph&) { Append(smoother.TakeMarginalized(), &gone); });
  EXPECT_TRUE(smoother.graph().fixed().empty());
  int anchors = 0;
  for (const auto& f : smoother.graph().factors()) {
    if (!f->anchors()) continue;
    ++anchors;
    EXPECT_EQ(f->type_name(), std::string("MarginalPrior"));
  }
  EXPECT_EQ(anchors, 1);
  Values window = smoother.Estimate();
  Optimize(smoother.graph(), &window, SmootherOptions().finish);
  Values start = gone;
  Append(window, &start);
  const Values batch = BatchOptimum(sim.graph, start);
  double largest = 0;
  for (Key k : window.keys()) {
    largest = std::max(largest, (window.At<SE2d>(k).translation() - batch.At<SE2d>(k).translation()).norm());
  }
  EXPECT_LT(largest, 1e-8);
}

TEST(FixedLagSmoother, InvalidOptionsThrow) {
  FixedLagOptions o;
  o.lag = -1;
  EXPECT_THROW(FixedLagSmoother{o}, InvalidArgument);
  o.lag = 10;
  o.batch = std::nan("");
  EXPECT_THROW(FixedLagSmoother{o}, InvalidArgument);
  o.batch = 0;
  o.smoother.rounds_per_update = 0;
  EXPECT_THROW(FixedLagSmoother{o}, InvalidArgument);
}

}  // namespace
}  // namespace tether
