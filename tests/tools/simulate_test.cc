#include "tether/frontends/simulation/simulate.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <set>
#include <string>

#include "tether/core/error.h"
#include "tether/solvers/optimizer.h"

namespace tether {
namespace {

SimulateOptions Options(SimWorld world, int poses, std::uint64_t seed = 1) {
  SimulateOptions o;
  o.world = world;
  o.poses = poses;
  o.seed = seed;
  return o;
}

/// Everything a simulation produced, printed exactly (%.17g), for comparisons.
std::string Fingerprint(const SimulatedGraph& g) {
  std::string s;
  char buf[64];
  auto num = [&](double v) {
    std::snprintf(buf, sizeof(buf), "%.17g ", v);
    s += buf;
  };
  for (const Values* v : {&g.ground_truth, &g.initial}) {
    for (Key k : v->keys()) {
      s += std::to_string(k) + ":";
      const double* p = v->Params(k);
      for (int i = 0; i < AmbientDim(v->TypeOf(k)); ++i) num(p[i]);
      s += "\n";
    }
  }
  for (const auto& f : g.graph.factors()) {
    s += f->type_name();
    for (Key k : f->keys()) s += " " + std::to_string(k);
    s += " |";
    for (double m : f->Measurement()) num(m);
    const Eigen::MatrixXd info = f->noise().Information();
    for (int i = 0; i < info.size(); ++i) num(info.data()[i]);
    s += "\n";
  }
  return s;
}

int ResidualDims(const FactorGraph& graph) {
  int n = 0;
  for (const auto& f : graph.factors()) n += f->dim();
  return n;
}

double MaxPositionDifference(const Values& a, const Values& b) {
  double worst = 0.0;
  for (Key k : a.keys()) {
    const double* p = a.Params(k);
    const double* q = b.Params(k);
    const int dims = a.TypeOf(k) == VarType::kSE3 || a.TypeOf(k) == VarType::kPoint3 ? 3 : 2;
    double d2 = 0.0;
    for (int i = 0; i < dims; ++i) d2 += (p[i] - q[i]) * (p[i] - q[i]);
    worst = std::max(worst, std::sqrt(d2));
  }
  return worst;
}

bool IsConsecutive(const Factor& f) {
  const Key a = f.keys()[0], b = f.keys()[1];
  return b == a + 1;
}

// Ground-truth grid positions of the first 20 of 400 manhattan poses for seed 1.
constexpr const char* kPinnedWalk =
    "(0,0)(1,0)(2,0)(3,0)(4,0)(4,-1)(3,-1)(3,0)(3,1)(4,1)(5,1)(5,0)(4,0)(3,0)(2,0)(2,1)(2,2)(2,3)(1,3)(0,3)";

const SimWorld kWorlds[] = {SimWorld::kManhattan, SimWorld::kSphere, SimWorld::kLandmarks};

// ---- names and options ----

TEST(SimWorldTest, NamesRoundTrip) {
  for (SimWorld w : kWorlds) {
    SimWorld parsed = SimWorld::kManhattan;
    ASSERT_TRUE(FromString(ToString(w), &parsed)) << ToString(w);
    EXPECT_EQ(parsed, w);
  }
  EXPECT_STREQ(ToString(SimWorld::kManhattan), "manhattan");
  EXPECT_STREQ(ToString(SimWorld::kSphere), "sphere");
  EXPECT_STREQ(ToString(SimWorld::kLandmarks), "landmarks");
  SimWorld w = SimWorld::kSphere;
  EXPECT_FALSE(FromString("Manhattan", &w));
  EXPECT_FALSE(FromString("", &w));
  EXPECT_EQ(w, SimWorld::kSphere);
}

TEST(SimulateOptionsTest, DefaultsAreValid) {
  std::string why = "stale";
  EXPECT_TRUE(SimulateOptions().IsValid(&why));
  EXPECT_TRUE(why.empty());
  EXPECT_TRUE(SimulateOptions().IsValid(nullptr));
  for (SimWorld w : kWorlds) EXPECT_TRUE(Options(w, 1).IsValid(nullptr)) << ToString(w);
}

TEST(SimulateOptionsTest, InvalidOptionsAreRejectedWithTheFieldNamed) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  struct Case {
    const char* field;
    void (*change)(SimulateOptions*, double);
    double value;
  };
  auto set_probability = [](SimulateOptions* o, double v) { o->loop_closure_probability = v; };
  const Case cases[] = {
      {"poses", [](SimulateOptions* o, double v) { o->poses = static_cast<int>(v); }, 0},
      {"poses", [](SimulateOptions* o, double v) { o->poses = static_cast<int>(v); }, -5},
      {"translation_sigma", [](SimulateOptions* o, double v) { o->translation_sigma = v; }, 0.0},
      {"translation_sigma", [](SimulateOptions* o, double v) { o->translation_sigma = v; }, -0.1},
      {"translation_sigma", [](SimulateOptions* o, double v) { o->translation_sigma = v; }, nan},
      {"rotation_sigma", [](SimulateOptions* o, double v) { o->rotation_sigma = v; }, 0.0},
      {"rotation_sigma", [](SimulateOptions* o, double v) { o->rotation_sigma = v; }, 0.7},
      {"rotation_sigma", [](SimulateOptions* o, double v) { o->rotation_sigma = v; }, nan},
      {"loop_closure_probability", set_probability, 1.5},
      {"loop_closure_probability", set_probability, -0.1},
      {"loop_closure_probability", set_probability, nan},
  };
  for (const Case& c : cases) {
    SimulateOptions o;
    c.change(&o, c.value);
    std::string why;
    EXPECT_FALSE(o.IsValid(&why)) << c.field << " = " << c.value;
    EXPECT_NE(why.find(c.field), std::string::npos) << why;
    try {
      Simulate(o);
      ADD_FAILURE() << "Simulate accepted " << c.field << " = " << c.value;
    } catch (const InvalidArgument& e) {
      EXPECT_NE(std::string(e.what()).find(c.field), std::string::npos) << e.what();
    }
  }
}

TEST(SimulateOptionsTest, LandmarkFieldsAreCheckedForTheLandmarksWorldOnly) {
  SimulateOptions o;
  o.landmarks = 0;
  o.landmark_range = 0.0;
  EXPECT_TRUE(o.IsValid(nullptr));  // manhattan ignores them
  o.world = SimWorld::kLandmarks;
  std::string why;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("landmarks"), std::string::npos) << why;
  o.landmarks = 10;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("landmark_range"), std::string::npos) << why;
  o.landmark_range = 3.0;
  EXPECT_TRUE(o.IsValid(&why)) << why;
}

// ---- determinism ----

TEST(SimulateTest, SameSeedGivesIdenticalOutputDifferentSeedDifferent) {
  for (SimWorld w : kWorlds) {
    const std::string a = Fingerprint(Simulate(Options(w, 200, 7)));
    const std::string b = Fingerprint(Simulate(Options(w, 200, 7)));
    const std::string c = Fingerprint(Simulate(Options(w, 200, 8)));
    EXPECT_EQ(a, b) << ToString(w);
    EXPECT_NE(a, c) << ToString(w);
  }
}

// The grid walk only depends on std::mt19937_64 (specified by the standard) and exact
// comparisons, so it is the same on every platform: a change here changes every manhattan graph.
TEST(SimulateTest, ManhattanWalkIsPinned) {
  const SimulatedGraph g = Simulate(Options(SimWorld::kManhattan, 400, 1));
  std::string walk;
  for (Key k = 0; k < 20; ++k) {
    const SE2d p = g.ground_truth.At<SE2d>(k);
    walk += "(" + std::to_string(std::lround(p.x())) + "," + std::to_string(std::lround(p.y())) + ")";
  }
  EXPECT_EQ(walk, kPinnedWalk);
}

TEST(SimulateTest, NoiseSigmasDoNotChangeTheWorld) {
  for (SimWorld w : kWorlds) {
    SimulateOptions o = Options(w, 300, 3);
    const SimulatedGraph a = Simulate(o);
    o.translation_sigma = 0.2;
    o.rotation_sigma = 0.05;
    const SimulatedGraph b = Simulate(o);
    EXPECT_EQ(MaxPositionDifference(a.ground_truth, b.ground_truth), 0.0) << ToString(w);
    ASSERT_EQ(a.graph.size(), b.graph.size()) << ToString(w);
    for (std::size_t i = 0; i < a.graph.size(); ++i) EXPECT_EQ(a.graph.at(i).keys(), b.graph.at(i).keys());
  }
}

// ---- sizes and structure ----

TEST(SimulateTest, ManhattanHasPosesOdometryAndNearbyLoopClosures) {
  const SimulatedGraph g = Simulate(Options(SimWorld::kManhattan, 500));
  EXPECT_EQ(g.ground_truth.size(), 500u);
  EXPECT_EQ(g.initial.size(), 500u);
  EXPECT_EQ(g.ground_truth.Count(VarType::kSE2), 500u);
  EXPECT_EQ(g.odometry_factors, 499);
  EXPECT_GT(g.loop_closures, 50);
  EXPECT_EQ(g.graph.size(), static_cast<std::size_t>(g.odometry_factors + g.loop_closures));
  EXPECT_TRUE(g.graph.fixed().empty());
  int loops = 0;
  for (const auto& f : g.graph.factors()) {
    ASSERT_EQ(f->type_name(), "BetweenSE2");
    const Key a = f->keys()[0], b = f->keys()[1];
    ASSERT_LT(a, b);
    ASSERT_LT(b, 500u);
    if (IsConsecutive(*f)) continue;
    ++loops;
    // A loop closure joins poses at most one grid step apart.
    const SE2d pa = g.ground_truth.At<SE2d>(a), pb = g.ground_truth.At<SE2d>(b);
    EXPECT_LE((pa.translation() - pb.translation()).norm(), 1.0 + 1e-9);
  }
  EXPECT_EQ(loops, g.loop_closures);
  // Unit steps on a grid, headings multiples of 90 degrees.
  for (Key k = 1; k < 500; ++k) {
    const SE2d d = g.ground_truth.At<SE2d>(k - 1).Inverse() * g.ground_truth.At<SE2d>(k);
    EXPECT_NEAR(d.translation().norm(), 1.0, 1e-9);
    const double quarter = d.theta() / (0.5 * M_PI);
    EXPECT_NEAR(quarter, std::round(quarter), 1e-9);
  }
}

TEST(SimulateTest, SphereHasSE3PosesAndLoopClosuresToThePreviousRing) {
  const SimulatedGraph g = Simulate(Options(SimWorld::kSphere, 400));
  EXPECT_EQ(g.ground_truth.Count(VarType::kSE3), 400u);
  EXPECT_EQ(g.initial.Count(VarType::kSE3), 400u);
  EXPECT_EQ(g.odometry_factors, 399);
  EXPECT_GT(g.loop_closures, 50);
  EXPECT_EQ(g.graph.size(), static_cast<std::size_t>(g.odometry_factors + g.loop_closures));
  // All poses on one sphere around the origin.
  const double radius = g.ground_truth.At<SE3d>(0).translation().norm();
  for (Key k = 0; k < 400; ++k) EXPECT_NEAR(g.ground_truth.At<SE3d>(k).translation().norm(), radius, 1e-9);
  for (const auto& f : g.graph.factors()) {
    ASSERT_EQ(f->type_name(), "BetweenSE3");
    if (IsConsecutive(*f)) continue;
    const double gap =
        (g.ground_truth.At<SE3d>(f->keys()[0]).translation() - g.ground_truth.At<SE3d>(f->keys()[1]).translation())
            .norm();
    EXPECT_LT(gap, 2.0);  // neighbours on the previous ring
  }
}

TEST(SimulateTest, LandmarksAreObservedWithinRangeAndKeyedAfterThePoses) {
  SimulateOptions o = Options(SimWorld::kLandmarks, 300);
  o.landmarks = 40;
  const SimulatedGraph g = Simulate(o);
  EXPECT_EQ(g.ground_truth.Count(VarType::kSE2), 300u);
  EXPECT_EQ(g.ground_truth.Count(VarType::kPoint2), 40u);
  EXPECT_EQ(g.initial.Count(VarType::kPoint2), 40u);
  for (Key k = 300; k < 340; ++k) {
    EXPECT_EQ(g.ground_truth.TypeOf(k), VarType::kPoint2);
    EXPECT_EQ(g.initial.TypeOf(k), VarType::kPoint2);
  }
  EXPECT_EQ(g.loop_closures, 0);
  std::set<Key> observed;
  int observations = 0;
  for (const auto& f : g.graph.factors()) {
    if (f->type_name() == "BetweenSE2") {
      EXPECT_TRUE(IsConsecutive(*f));
      continue;
    }
    ASSERT_EQ(f->type_name(), "PosePoint2");
    ++observations;
    const Key pose = f->keys()[0], point = f->keys()[1];
    ASSERT_LT(pose, 300u);
    ASSERT_GE(point, 300u);
    observed.insert(point);
    const double d = (g.ground_truth.At<Eigen::Vector2d>(point) - g.ground_truth.At<SE2d>(pose).translation()).norm();
    EXPECT_LE(d, o.landmark_range + 1e-9);
  }
  EXPECT_EQ(observations, g.observations);
  EXPECT_EQ(observed.size(), 40u);  // every landmark is seen
  EXPECT_GT(g.observations, 300);   // most poses see something
}

TEST(SimulateTest, SinglePose) {
  for (SimWorld w : kWorlds) {
    SimulateOptions o = Options(w, 1);
    o.landmarks = 3;
    const SimulatedGraph g = Simulate(o);
    EXPECT_EQ(g.odometry_factors, 0);
    EXPECT_EQ(g.loop_closures, 0);
    if (w == SimWorld::kLandmarks) {
      EXPECT_EQ(g.ground_truth.size(), 4u);
      EXPECT_EQ(g.graph.size(), 3u);  // the one pose sees all three
    } else {
      EXPECT_EQ(g.ground_truth.size(), 1u);
      EXPECT_TRUE(g.graph.empty());
    }
    EXPECT_EQ(MaxPositionDifference(g.ground_truth, g.initial) < 1.0, true);
  }
}

TEST(SimulateTest, LoopClosureProbabilityControlsTheirNumber) {
  for (SimWorld w : {SimWorld::kManhattan, SimWorld::kSphere}) {
    SimulateOptions o = Options(w, 300);
    o.loop_closure_probability = 0.0;
    EXPECT_EQ(Simulate(o).loop_closures, 0) << ToString(w);
    o.loop_closure_probability = 0.2;
    const int some = Simulate(o).loop_closures;
    o.loop_closure_probability = 1.0;
    const int all = Simulate(o).loop_closures;
    EXPECT_GT(some, 0) << ToString(w);
    EXPECT_GT(all, 2 * some) << ToString(w);
  }
}

// ---- noise and initial values ----

// chi2 at the ground truth is a sum of squared standard normals, one per residual dimension,
// when the information matrices match the noise actually applied.
TEST(SimulateTest, GroundTruthChi2MatchesResidualDimensions) {
  for (SimWorld w : kWorlds) {
    for (double sigma_scale : {1.0, 4.0}) {
      SimulateOptions o = Options(w, 400, 11);
      o.translation_sigma *= sigma_scale;
      o.rotation_sigma *= sigma_scale;
      const SimulatedGraph g = Simulate(o);
      const int dims = ResidualDims(g.graph);
      const double chi2 = g.graph.Chi2(g.ground_truth);
      EXPECT_NEAR(chi2 / dims, 1.0, 0.3) << ToString(w) << " sigma x" << sigma_scale << ": chi2 " << chi2 << " over "
                                         << dims << " residual dimensions";
    }
  }
}

TEST(SimulateTest, InitialComposesOdometryFromTheTrueFirstPose) {
  for (SimWorld w : kWorlds) {
    const SimulatedGraph g = Simulate(Options(w, 300, 5));
    ASSERT_EQ(g.initial.size(), g.ground_truth.size());
    ASSERT_EQ(g.initial.keys(), g.ground_truth.keys());
    const double* p0 = g.initial.Params(0);
    const double* t0 = g.ground_truth.Params(0);
    for (int i = 0; i < AmbientDim(g.initial.TypeOf(0)); ++i) EXPECT_EQ(p0[i], t0[i]) << ToString(w);
    // Odometry is satisfied exactly by the initial values, and so is each landmark's first
    // observation.
    std::set<Key> seen;
    for (const auto& f : g.graph.factors()) {
      const bool odometry = f->type_name() != "PosePoint2" && IsConsecutive(*f);
      const bool first_sighting = f->type_name() == "PosePoint2" && seen.insert(f->keys()[1]).second;
      if (odometry || first_sighting) {
        EXPECT_NEAR(f->Chi2(g.initial), 0.0, 1e-12) << ToString(w);
      }
    }
    // ... and drifts away from the truth.
    EXPECT_GT(MaxPositionDifference(g.ground_truth, g.initial), 0.25) << ToString(w);
    EXPECT_GT(g.graph.Chi2(g.initial), 2.0 * g.graph.Chi2(g.ground_truth)) << ToString(w);
  }
}

// End to end: optimising from `initial` lands at a minimum whose chi2 follows a chi-square
// distribution with (residual dimensions - free tangent dimensions) degrees of freedom, below
// the ground truth's chi2, with the trajectory much closer to the truth than the initial one.
TEST(SimulateTest, OptimisingRecoversTheGroundTruth) {
  for (SimWorld w : kWorlds) {
    const SimulatedGraph g = Simulate(Options(w, 200, 2));
    Values v = g.initial;
    const SolverSummary summary = Optimize(g.graph, &v);
    ASSERT_TRUE(summary.IsSolutionUsable()) << ToString(w) << ": " << summary.FullReport();
    int free_dims = -TangentDim(g.initial.TypeOf(0));  // the solver holds pose 0 fixed
    for (Key k : g.initial.keys()) free_dims += TangentDim(g.initial.TypeOf(k));
    const int dof = ResidualDims(g.graph) - free_dims;
    const double chi2 = g.graph.Chi2(v);
    EXPECT_LE(chi2, g.graph.Chi2(g.ground_truth)) << ToString(w);
    EXPECT_NEAR(chi2 / dof, 1.0, 0.3) << ToString(w) << ": chi2 " << chi2 << " with " << dof << " dof";
    EXPECT_LT(MaxPositionDifference(g.ground_truth, v), 0.5 * MaxPositionDifference(g.ground_truth, g.initial))
        << ToString(w);
  }
}

}  // namespace
}  // namespace tether
