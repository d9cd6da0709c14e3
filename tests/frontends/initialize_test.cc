// Initial guesses: spanning tree and chordal relaxation.
#include "tether/solvers/initialize.h"

#include <gtest/gtest.h>

#include <cmath>

#include "tether/core/error.h"
#include "tether/factors/between_se2.h"
#include "tether/factors/prior.h"
#include "tether/frontends/simulation/simulate.h"
#include "tether/solvers/optimizer.h"

namespace tether {
namespace {

SimulatedGraph Sim(SimWorld w, int poses, double sigma_scale, std::uint64_t seed = 5) {
  SimulateOptions o;
  o.world = w;
  o.poses = poses;
  o.seed = seed;
  o.translation_sigma *= sigma_scale;
  o.rotation_sigma *= sigma_scale;
  return Simulate(o);
}

// Largest position and rotation difference between the variables of `a` and `b`.
struct Difference {
  double position = 0, angle = 0;
};
Difference Compare(const Values& a, const Values& b) {
  Difference d;
  for (Key k : a.keys()) {
    switch (a.TypeOf(k)) {
      case VarType::kSE2:
        d.position = std::max(d.position, (a.At<SE2d>(k).translation() - b.At<SE2d>(k).translation()).norm());
        d.angle = std::max(d.angle, std::abs(WrapAngle(a.At<SE2d>(k).theta() - b.At<SE2d>(k).theta())));
        break;
      case VarType::kSE3:
        d.position = std::max(d.position, (a.At<SE3d>(k).translation() - b.At<SE3d>(k).translation()).norm());
        d.angle = std::max(d.angle, (a.At<SE3d>(k).rotation().Inverse() * b.At<SE3d>(k).rotation()).Log().norm());
        break;
      case VarType::kPoint2:
        d.position = std::max(d.position, (a.At<Eigen::Vector2d>(k) - b.At<Eigen::Vector2d>(k)).norm());
        break;
      case VarType::kPoint3:
        d.position = std::max(d.position, (a.At<Eigen::Vector3d>(k) - b.At<Eigen::Vector3d>(k)).norm());
        break;
    }
  }
  return d;
}

// Values with every pose except key 0 moved far from the truth (key 0 kept: it is the anchor).
Values Scrambled(const Values& truth) {
  Values v = truth;
  for (Key k : v.keys()) {
    if (k == 0) continue;
    double* p = v.Params(k);
    for (int i = 0; i < AmbientDim(v.TypeOf(k)); ++i) p[i] += 3.0 + 0.1 * static_cast<double>(i);
    if (v.TypeOf(k) == VarType::kSE3) v.Update(k, v.At<SE3d>(k));  // renormalise the quaternion
  }
  return v;
}

TEST(InitializeTest, NamesRoundTrip) {
  for (InitMethod m : {InitMethod::kFile, InitMethod::kSpanningTree, InitMethod::kChordal}) {
    InitMethod back = InitMethod::kFile;
    ASSERT_TRUE(FromString(ToString(m), &back));
    EXPECT_EQ(back, m);
  }
  InitMethod m;
  EXPECT_FALSE(FromString("lago", &m));
  EXPECT_STREQ(ToString(InitMethod::kSpanningTree), "spanning-tree");
}

TEST(InitializeTest, FileKeepsTheValues) {
  const SimulatedGraph sim = Sim(SimWorld::kManhattan, 100, 1.0);
  Values v = sim.initial;
  const InitSummary s = Initialize(sim.graph, &v, InitMethod::kFile);
  EXPECT_EQ(v.Data(VarType::kSE2), sim.initial.Data(VarType::kSE2));
  EXPECT_EQ(s.poses_set, 0);
}

// With (almost) exact measurements, both methods put every variable back on the truth from a
// start far from it, whatever the world: SE2 with loop closures, SE3, SE2 with landmarks.
class ExactMeasurementsTest : public ::testing::TestWithParam<std::tuple<SimWorld, InitMethod>> {};

TEST_P(ExactMeasurementsTest, RecoversTheTruth) {
  const auto [world, method] = GetParam();
  const SimulatedGraph sim = Sim(world, 150, 1e-7);
  Values v = Scrambled(sim.ground_truth);
  ASSERT_GT(Compare(v, sim.ground_truth).position, 1.0);
  const InitSummary s = Initialize(sim.graph, &v, method);
  const Difference d = Compare(v, sim.ground_truth);
  EXPECT_LT(d.position, 1e-4) << ToString(method);
  EXPECT_LT(d.angle, 1e-5) << ToString(method);
  EXPECT_EQ(s.poses_set, 149);
  EXPECT_EQ(s.points_set, static_cast<int>(sim.ground_truth.size()) - 150);
  EXPECT_EQ(s.anchors, 1);
  // The anchor (the lowest key, nothing being fixed) stays bit for bit where it was.
  const double* a = v.Params(0);
  const double* t = sim.ground_truth.Params(0);
  for (int i = 0; i < AmbientDim(v.TypeOf(0)); ++i) EXPECT_EQ(a[i], t[i]);
}

INSTANTIATE_TEST_SUITE_P(Worlds, ExactMeasurementsTest,
                         ::testing::Combine(::testing::Values(SimWorld::kManhattan, SimWorld::kSphere,
                                                              SimWorld::kLandmarks),
                                            ::testing::Values(InitMethod::kSpanningTree, InitMethod::kChordal)));

// The point of the chordal relaxation: with realistic noise, the spanning tree piles up the
// odometry's rotation errors along the way, the relaxation spreads them over all loops, so
// its guess is far closer to the optimum.
TEST(InitializeTest, ChordalStartsCloserThanTheSpanningTree) {
  for (SimWorld w : {SimWorld::kManhattan, SimWorld::kSphere}) {
    const SimulatedGraph sim = Sim(w, 1500, 3.0);
    Values tree = sim.initial, chordal = sim.initial;
    Initialize(sim.graph, &tree, InitMethod::kSpanningTree);
    const InitSummary s = Initialize(sim.graph, &chordal, InitMethod::kChordal);
    EXPECT_EQ(s.measurements_used, static_cast<int>(sim.graph.size()));
    const double tree_chi2 = sim.graph.Chi2(tree), chordal_chi2 = sim.graph.Chi2(chordal);
    EXPECT_LT(chordal_chi2, tree_chi2 / 10) << static_cast<int>(w);
    // And the solve from it reaches the same optimum as from the truth.
    Values from_truth = sim.ground_truth;
    const SolverSummary a = Optimize(sim.graph, &chordal, {});
    const SolverSummary b = Optimize(sim.graph, &from_truth, {});
    EXPECT_NEAR(a.final_chi2, b.final_chi2, 1e-6 * b.final_chi2) << static_cast<int>(w);
  }
}

// Fixed poses are anchors: they keep their values exactly, and every piece of the graph that
// holds one needs no other anchor.
TEST(InitializeTest, FixedPosesAreAnchors) {
  for (InitMethod method : {InitMethod::kSpanningTree, InitMethod::kChordal}) {
    SimulatedGraph sim = Sim(SimWorld::kManhattan, 200, 1.0);
    sim.graph.Fix(7);
    sim.graph.Fix(120);
    Values v = Scrambled(sim.initial);
    const Values before = v;
    const InitSummary s = Initialize(sim.graph, &v, method);
    EXPECT_EQ(s.anchors, 2) << ToString(method);
    for (Key k : {Key{7}, Key{120}}) {
      for (int i = 0; i < 3; ++i) EXPECT_EQ(v.Params(k)[i], before.Params(k)[i]) << ToString(method);
    }
    EXPECT_GT((v.At<SE2d>(0).translation() - before.At<SE2d>(0).translation()).norm(), 1.0) << ToString(method);
  }
}

// Values no factor uses are left alone; variables the factors use but that have no value get one.
TEST(InitializeTest, UnusedValuesStayAndMissingOnesAreAdded) {
  for (InitMethod method : {InitMethod::kSpanningTree, InitMethod::kChordal}) {
    const SimulatedGraph sim = Sim(SimWorld::kManhattan, 50, 1.0);
    Values v;
    v.Insert(0, sim.ground_truth.At<SE2d>(0));  // only the anchor
    v.Insert(999, SE2d(1, 2, 3));               // used by nothing
    const InitSummary s = Initialize(sim.graph, &v, method);
    EXPECT_EQ(v.size(), 51u);
    EXPECT_EQ(v.At<SE2d>(999).x(), 1.0);
    EXPECT_EQ(v.At<SE2d>(999).theta(), SE2d(1, 2, 3).theta());
    EXPECT_LT(sim.graph.Chi2(v), 1e3) << ToString(method);
    (void)s;
  }
}

// A variable that no chain of predicting factors reaches gets a clear error, and the values
// are not touched.
TEST(InitializeTest, UnreachableVariableThrowsAndChangesNothing) {
  for (InitMethod method : {InitMethod::kSpanningTree, InitMethod::kChordal}) {
    SimulatedGraph sim = Sim(SimWorld::kManhattan, 30, 1.0);
    // Pose 500 is only seen by a prior: nothing predicts it, and it has no value.
    sim.graph.Add(std::make_unique<PriorSE2>(500, SE2d(1, 1, 0), SqrtInformation::Isotropic(3, 0.1)));
    Values v = Scrambled(sim.initial);
    const Values before = v;
    try {
      Initialize(sim.graph, &v, method);
      FAIL() << ToString(method) << " accepted an unreachable variable";
    } catch (const InvalidArgument& e) {
      EXPECT_NE(std::string(e.what()).find("500"), std::string::npos) << e.what();
    }
    EXPECT_EQ(v.Data(VarType::kSE2), before.Data(VarType::kSE2));
  }
}

// A factor that measures only the change of heading between two SE2 poses, and can predict
// one from the other (with no change of position). It fixes nothing about positions.
class HeadingChange : public Factor {
 public:
  HeadingChange(Key a, Key b, double z) : Factor({a, b}, SqrtInformation::Isotropic(1, 0.01)), z_(z) {}
  std::string type_name() const override { return "HeadingChange"; }
  int residual_dim() const override { return 1; }
  std::vector<VarType> variable_types() const override { return {VarType::kSE2, VarType::kSE2}; }
  bool Evaluate(const double* const* p, double* e, double* const* j) const override {
    e[0] = WrapAngle(p[1][2] - p[0][2] - z_);
    if (j && j[0]) j[0][0] = 0, j[0][1] = 0, j[0][2] = -1;
    if (j && j[1]) j[1][0] = 0, j[1][1] = 0, j[1][2] = 1;
    return true;
  }
  std::unique_ptr<Factor> Clone() const override { return std::make_unique<HeadingChange>(*this); }
  bool Predict(std::size_t known, const double* kp, std::size_t unknown, double* out) const override {
    if (known > 1 || unknown > 1 || known == unknown) return false;
    out[0] = kp[0], out[1] = kp[1], out[2] = WrapAngle(kp[2] + (known == 0 ? z_ : -z_));
    return true;
  }

 private:
  double z_;
};

// Measurements that fix rotations but not positions make the translation system singular:
// a clear error that says what to do, and the values are not touched. The spanning tree
// still composes them.
TEST(InitializeTest, SingularTranslationSystemIsAClearError) {
  FactorGraph graph;
  graph.Add(std::make_unique<HeadingChange>(0, 1, 0.3));
  graph.Add(std::make_unique<HeadingChange>(1, 2, -0.1));
  Values v;
  v.Insert(0, SE2d(1, 2, 0));
  v.Insert(1, SE2d(5, 5, 1));
  v.Insert(2, SE2d(7, 7, 2));
  const Values before = v;
  try {
    Initialize(graph, &v, InitMethod::kChordal);
    FAIL() << "a singular translation system was accepted";
  } catch (const InvalidArgument& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("translation system is singular"), std::string::npos) << m;
    EXPECT_NE(m.find("--init spanning-tree"), std::string::npos) << m;
  }
  EXPECT_EQ(v.Data(VarType::kSE2), before.Data(VarType::kSE2));
  Initialize(graph, &v, InitMethod::kSpanningTree);
  EXPECT_NEAR(v.At<SE2d>(2).theta(), 0.2, 1e-12);
  EXPECT_EQ(v.At<SE2d>(2).x(), 1.0);
}

// Pieces linked by nothing each get their own anchor.
TEST(InitializeTest, EveryPieceHasAnAnchor) {
  FactorGraph graph;
  const SqrtInformation noise = SqrtInformation::Isotropic(3, 0.1);
  graph.Add(std::make_unique<BetweenSE2>(0, 1, SE2d(1, 0, 0.1), noise));
  graph.Add(std::make_unique<BetweenSE2>(10, 11, SE2d(0, 1, -0.2), noise));
  Values v;
  v.Insert(0, SE2d(5, 5, 0));
  v.Insert(1, SE2d(0, 0, 0));
  v.Insert(10, SE2d(-3, 2, 1));
  v.Insert(11, SE2d(0, 0, 0));
  for (InitMethod method : {InitMethod::kSpanningTree, InitMethod::kChordal}) {
    Values w = v;
    const InitSummary s = Initialize(graph, &w, method);
    EXPECT_EQ(s.anchors, 2) << ToString(method);
    EXPECT_NEAR(graph.Chi2(w), 0.0, 1e-18) << ToString(method);
    EXPECT_EQ(w.At<SE2d>(10).x(), -3.0);  // anchors stay
    EXPECT_EQ(w.At<SE2d>(0).x(), 5.0);
  }
}

}  // namespace
}  // namespace tether
