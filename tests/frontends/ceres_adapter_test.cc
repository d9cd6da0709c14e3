// The Ceres adapter: its manifolds and cost functions against tether's retraction and
// Jacobians, agreement with the native Levenberg-Marquardt on synthetic graphs (SE2, SE3,
// Point2 landmarks), fixed variables and the gauge, failures, and the options it refuses.
#include "tether/solvers/ceres_adapter.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>
#include <stdexcept>

#include "tether/core/autodiff_factor.h"
#include "tether/core/error.h"
#include "tether/factors/between_se2.h"
#include "tether/factors/between_se3.h"
#include "tether/factors/pose_point.h"
#include "tether/factors/prior.h"
#include "tether/frontends/simulation/simulate.h"
#include "tether/solvers/ceres_problem.h"
#include "tether/solvers/optimizer.h"

namespace tether {
namespace {

using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

SimulatedGraph Sim(SimWorld w, int poses, std::uint64_t seed = 5) {
  SimulateOptions o;
  o.world = w;
  o.poses = poses;
  o.seed = seed;
  o.landmarks = 60;
  return Simulate(o);
}

bool AllFinite(const Values& v) {
  for (int t = 0; t < kNumBuiltinVarTypes; ++t)
    for (double x : v.Data(static_cast<VarType>(t)))
      if (!std::isfinite(x)) return false;
  return true;
}

// Largest difference between two solutions: position (m) and rotation angle (rad) of poses,
// position of points.
struct Difference {
  double position = 0, angle = 0;
};
Difference Compare(const Values& a, const Values& b) {
  Difference d;
  for (Key k : a.keys()) {
    switch (a.TypeOf(k)) {
      case VarType::kSE2: {
        const SE2d p = a.At<SE2d>(k), q = b.At<SE2d>(k);
        d.position = std::max(d.position, (p.translation() - q.translation()).norm());
        d.angle = std::max(d.angle, std::abs(WrapAngle(p.theta() - q.theta())));
        break;
      }
      case VarType::kSE3: {
        const SE3d p = a.At<SE3d>(k), q = b.At<SE3d>(k);
        d.position = std::max(d.position, (p.translation() - q.translation()).norm());
        d.angle = std::max(d.angle, (p.rotation().Inverse() * q.rotation()).Log().norm());
        break;
      }
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

// ---- the manifolds ----

std::vector<double> RandomParams(VarType t, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-3, 3);
  std::vector<double> x(AmbientDim(t));
  if (t == VarType::kSE2) {
    x = {u(rng), u(rng), SE2d(0, 0, u(rng)).theta()};
  } else if (t == VarType::kSE3) {
    const SE3d p(SO3d::Exp(Eigen::Vector3d(u(rng), u(rng), u(rng)) / 3.0), Eigen::Vector3d(u(rng), u(rng), u(rng)));
    p.ToParams(x.data());
  } else {
    for (double& v : x) v = u(rng);
  }
  return x;
}

TEST(CeresManifoldTest, PlusIsTetherRetractionAndItsJacobiansAreConsistent) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.5, 0.5);
  for (VarType t : {VarType::kSE2, VarType::kSE3, VarType::kPoint2, VarType::kPoint3}) {
    const VariableManifold m(t);
    const int a = AmbientDim(t), n = TangentDim(t);
    ASSERT_EQ(m.AmbientSize(), a);
    ASSERT_EQ(m.TangentSize(), n);
    for (int trial = 0; trial < 20; ++trial) {
      const std::vector<double> x = RandomParams(t, rng);
      std::vector<double> d(n), plus(a), expected(a), back(n);
      for (double& v : d) v = u(rng);
      // Plus is exactly RetractParams; Minus inverts it.
      ASSERT_TRUE(m.Plus(x.data(), d.data(), plus.data()));
      RetractParams(t, x.data(), d.data(), expected.data());
      for (int i = 0; i < a; ++i) EXPECT_EQ(plus[i], expected[i]) << ToString(t);
      ASSERT_TRUE(m.Minus(plus.data(), x.data(), back.data()));
      for (int i = 0; i < n; ++i) EXPECT_NEAR(back[i], d[i], 1e-12) << ToString(t);
      // PlusJacobian against central differences of Plus; MinusJacobian is a left inverse.
      RowMajor P(a, n), L(n, a);
      ASSERT_TRUE(m.PlusJacobian(x.data(), P.data()));
      ASSERT_TRUE(m.MinusJacobian(x.data(), L.data()));
      const double h = 1e-6;
      for (int j = 0; j < n; ++j) {
        std::vector<double> dp(n, 0.0), dm(n, 0.0), xp(a), xm(a);
        dp[j] = h;
        dm[j] = -h;
        m.Plus(x.data(), dp.data(), xp.data());
        m.Plus(x.data(), dm.data(), xm.data());
        for (int i = 0; i < a; ++i) EXPECT_NEAR(P(i, j), (xp[i] - xm[i]) / (2 * h), 1e-8) << ToString(t);
      }
      EXPECT_LT((L * P - Eigen::MatrixXd::Identity(n, n)).cwiseAbs().maxCoeff(), 1e-14) << ToString(t);
    }
  }
}

// ---- the cost functions ----

// The ambient Jacobian a FactorCostFunction reports, times the manifold's PlusJacobian, is
// the factor's own tangent Jacobian (what Ceres solves with), for every key of the factor.
TEST(CeresCostFunctionTest, AmbientJacobianTimesPlusJacobianIsTheTangentJacobian) {
  std::mt19937 rng(11);
  Values v;
  v.Insert(0, SE3d(SO3d::Exp(Eigen::Vector3d(0.3, -1.2, 2.0)), Eigen::Vector3d(1, 2, 3)));
  v.Insert(1, SE3d(SO3d::Exp(Eigen::Vector3d(-2.5, 0.4, 0.1)), Eigen::Vector3d(-1, 0.5, 2)));
  v.Insert(2, SE2d(1, -2, 3.0));
  v.Insert(3, Eigen::Vector2d(4, 1));
  Eigen::Matrix<double, 6, 6> info = Eigen::Matrix<double, 6, 6>::Random();
  info = info * info.transpose() + 6 * Eigen::Matrix<double, 6, 6>::Identity();
  const BetweenSE3 between(0, 1, SE3d(SO3d::Exp(Eigen::Vector3d(0.1, 0.2, 0.3)), Eigen::Vector3d(0.5, 0, 0)),
                           SqrtInformation::FromInformation(info));
  const PosePoint2 landmark(2, 3, Eigen::Vector2d(0.5, -1), SqrtInformation::Isotropic(2, 0.1));
  for (const Factor* f : {static_cast<const Factor*>(&between), static_cast<const Factor*>(&landmark)}) {
    const FactorCostFunction cost(f, nullptr);
    const std::vector<VarType> types = f->variable_types();
    const std::vector<const double*> p = f->GatherParams(v);
    const int m = f->dim();
    std::vector<RowMajor> tangent, ambient;
    std::vector<double*> tp, ap;
    for (VarType t : types) {
      tangent.emplace_back(m, TangentDim(t));
      ambient.emplace_back(m, AmbientDim(t));
    }
    for (std::size_t k = 0; k < types.size(); ++k) {
      tp.push_back(tangent[k].data());
      ap.push_back(ambient[k].data());
    }
    std::vector<double> r_tether(m), r_ceres(m);
    ASSERT_TRUE(f->Linearize(p.data(), r_tether.data(), tp.data()));
    ASSERT_TRUE(cost.Evaluate(p.data(), r_ceres.data(), ap.data()));
    EXPECT_EQ(r_ceres, r_tether);
    for (std::size_t k = 0; k < types.size(); ++k) {
      RowMajor P(AmbientDim(types[k]), TangentDim(types[k]));
      RetractJacobian(types[k], p[k], P.data());
      const double scale = std::max(1.0, tangent[k].cwiseAbs().maxCoeff());
      EXPECT_LT((ambient[k] * P - tangent[k]).cwiseAbs().maxCoeff(), 1e-12 * scale) << f->type_name() << " key " << k;
    }
  }
}

// Through Ceres' eyes: the reported Jacobian times PlusJacobian against central differences
// of the cost function along the manifold's Plus, including a factor that uses one variable
// twice (one parameter block, the Jacobians of both uses summed).
TEST(CeresCostFunctionTest, TangentJacobiansMatchCentralDifferencesAlongPlus) {
  Values v;
  v.Insert(0, SE3d(SO3d::Exp(Eigen::Vector3d(0.3, -1.2, 2.0)), Eigen::Vector3d(1, 2, 3)));
  v.Insert(1, SE3d(SO3d::Exp(Eigen::Vector3d(-2.5, 0.4, 0.1)), Eigen::Vector3d(-1, 0.5, 2)));
  v.Insert(2, SE2d(1, -2, 2.9));
  const BetweenSE3 between(0, 1, SE3d(SO3d::Exp(Eigen::Vector3d(0.1, 0.2, 0.3)), Eigen::Vector3d(0.5, 0, 0)),
                           SqrtInformation::Isotropic(6, 0.5));
  const BetweenSE2 self_loop(2, 2, SE2d(0.4, 0.1, 0.3), SqrtInformation::Isotropic(3, 0.5));
  for (const Factor* f : {static_cast<const Factor*>(&between), static_cast<const Factor*>(&self_loop)}) {
    const FactorCostFunction cost(f, nullptr);
    const std::size_t nb = cost.block_keys().size();
    ASSERT_EQ(nb, f == &self_loop ? 1u : 2u);
    ASSERT_EQ(cost.parameter_block_sizes().size(), nb);
    const int m = cost.num_residuals();
    std::vector<const double*> x;
    std::vector<RowMajor> ambient;
    std::vector<double*> ap;
    for (Key k : cost.block_keys()) {
      x.push_back(v.Params(k));
      ambient.emplace_back(m, AmbientDim(v.TypeOf(k)));
    }
    for (RowMajor& a : ambient) ap.push_back(a.data());
    std::vector<double> r(m);
    ASSERT_TRUE(cost.Evaluate(x.data(), r.data(), ap.data()));
    for (std::size_t b = 0; b < nb; ++b) {
      const VarType t = v.TypeOf(cost.block_keys()[b]);
      const VariableManifold manifold(t);
      RowMajor P(AmbientDim(t), TangentDim(t));
      manifold.PlusJacobian(x[b], P.data());
      const RowMajor analytic = ambient[b] * P;
      const double h = 1e-6;
      for (int j = 0; j < TangentDim(t); ++j) {
        std::vector<double> d(TangentDim(t), 0.0), xp(AmbientDim(t)), xm(AmbientDim(t)), rp(m), rm(m);
        d[j] = h;
        manifold.Plus(x[b], d.data(), xp.data());
        d[j] = -h;
        manifold.Plus(x[b], d.data(), xm.data());
        std::vector<const double*> at = x;
        at[b] = xp.data();
        ASSERT_TRUE(cost.Evaluate(at.data(), rp.data(), nullptr));
        at[b] = xm.data();
        ASSERT_TRUE(cost.Evaluate(at.data(), rm.data(), nullptr));
        for (int i = 0; i < m; ++i) {
          EXPECT_NEAR(analytic(i, j), (rp[i] - rm[i]) / (2 * h), 1e-7) << f->type_name() << " block " << b;
        }
      }
    }
  }
}

// ---- agreement with the native Levenberg-Marquardt ----

struct AgreementCase {
  SimWorld world;
  int poses;
};

class CeresAgreementTest : public ::testing::TestWithParam<AgreementCase> {};

// Both solvers minimise the same chi2 along the same retraction from the same start; they
// differ in their damping and in where they stop. Both stop once a step changes chi2 by less
// than function_tolerance of it; near a regular minimum LM converges quadratically, so the
// native solver ends far closer to the minimum than that, while Ceres discards the step that
// meets the tolerance and so ends up to function_tolerance above it. Hence:
// - default options: the final chi2 agree to 2 * function_tolerance (relative);
// - function_tolerance 1e-15 (both run until rounding stops them): to 1e-11 relative, and
//   every variable to 1e-7 (m, rad), which is what a chi2 gap at rounding level allows here.
TEST_P(CeresAgreementTest, SameFinalChi2AndPosesAsNativeLm) {
  const SimulatedGraph sim = Sim(GetParam().world, GetParam().poses);
  const double truth_chi2 = sim.graph.Chi2(sim.ground_truth);
  for (double ftol : {SolverOptions().function_tolerance, 1e-15}) {
    SCOPED_TRACE("function_tolerance " + std::to_string(ftol));
    Values native = sim.initial, ceres = sim.initial;
    SolverOptions o;
    o.function_tolerance = ftol;
    const SolverSummary sn = Optimize(sim.graph, &native, o);
    o.algorithm = Algorithm::kCeres;
    const SolverSummary sc = Optimize(sim.graph, &ceres, o);  // dispatched to OptimizeWithCeres
    ASSERT_EQ(sn.status, SolverStatus::kConverged) << sn.FullReport();
    ASSERT_EQ(sc.status, SolverStatus::kConverged) << sc.FullReport();
    EXPECT_EQ(sc.algorithm, Algorithm::kCeres);
    EXPECT_EQ(sc.initial_chi2, sim.graph.Chi2(sim.initial));
    EXPECT_NEAR(sc.initial_chi2, sn.initial_chi2, 1e-12 * sn.initial_chi2);
    EXPECT_EQ(sc.final_chi2, sim.graph.Chi2(ceres));
    EXPECT_LT(sc.final_chi2, truth_chi2);  // it did solve: below chi2 at the ground truth
    const double rel = std::abs(sc.final_chi2 - sn.final_chi2) / sn.final_chi2;
    const Difference d = Compare(native, ceres);
    if (ftol > 1e-12) {
      EXPECT_LT(rel, 2 * ftol) << sc.FullReport() << sn.FullReport();
    } else {
      EXPECT_LT(rel, 1e-11) << sc.FullReport() << sn.FullReport();
      EXPECT_LT(d.position, 1e-7);
      EXPECT_LT(d.angle, 1e-7);
    }
    // The summary describes the same problem.
    EXPECT_EQ(sc.num_variables, sn.num_variables);
    EXPECT_EQ(sc.num_fixed, sn.num_fixed);
    EXPECT_EQ(sc.num_residuals, sn.num_residuals);
    EXPECT_EQ(sc.tangent_dim, sn.tangent_dim);
    EXPECT_EQ(sc.num_factors, sn.num_factors);
    EXPECT_TRUE(sc.gauge_fixed_automatically);
    EXPECT_EQ(sc.gauge_key, sn.gauge_key);
    EXPECT_NE(sc.FullReport().find("ceres: Ceres Levenberg-Marquardt / SPARSE_NORMAL_CHOLESKY"), std::string::npos);
    std::printf(
        "%s, ftol %g: chi2 %.12g (native) %.12g (ceres), rel. diff %.2e; max diff %.2e m %.2e rad; "
        "iterations %d / %d\n",
        ToString(GetParam().world), ftol, sn.final_chi2, sc.final_chi2, rel, d.position, d.angle, sn.iterations,
        sc.iterations);
  }
}

INSTANTIATE_TEST_SUITE_P(Simulated, CeresAgreementTest,
                         ::testing::Values(AgreementCase{SimWorld::kManhattan, 500},
                                           AgreementCase{SimWorld::kSphere, 400},
                                           AgreementCase{SimWorld::kLandmarks, 200}),
                         [](const ::testing::TestParamInfo<AgreementCase>& i) {
                           return std::string(ToString(i.param.world));
                         });

// The iteration log: one row per Ceres iteration from 0, handed to the callback as it runs,
// chi2 never rising on accepted rows and ending at the final chi2.
TEST(CeresAdapterTest, CallbackSeesEveryIteration) {
  const SimulatedGraph sim = Sim(SimWorld::kSphere, 200);
  Values v = sim.initial;
  SolverOptions o;
  std::vector<IterationSummary> seen;
  o.callback = [&](const IterationSummary& it) { seen.push_back(it); };
  const SolverSummary s = OptimizeWithCeres(sim.graph, &v, o);
  ASSERT_EQ(s.status, SolverStatus::kConverged) << s.FullReport();
  ASSERT_EQ(seen.size(), s.log.size());
  ASSERT_GE(seen.size(), 2u);
  EXPECT_EQ(seen.front().iteration, 0);
  EXPECT_NEAR(seen.front().chi2, s.initial_chi2, 1e-9 * s.initial_chi2);
  EXPECT_EQ(s.iterations, static_cast<int>(seen.size()) - 1);
  double last = seen.front().chi2;
  for (std::size_t i = 1; i < seen.size(); ++i) {
    EXPECT_EQ(seen[i].iteration, static_cast<int>(i));
    EXPECT_GT(seen[i].lambda, 0.0);
    EXPECT_GE(seen[i].seconds, seen[i - 1].seconds);
    if (seen[i].accepted) {
      EXPECT_LT(seen[i].chi2, last);
      EXPECT_NEAR(seen[i].relative_decrease, (last - seen[i].chi2) / last, 1e-9);
      last = seen[i].chi2;
    }
  }
  EXPECT_NEAR(last, s.final_chi2, 1e-9 * s.final_chi2);
}

TEST(CeresAdapterTest, IterationLimitAndTimeLimit) {
  const SimulatedGraph sim = Sim(SimWorld::kSphere, 300);
  Values v = sim.initial;
  SolverOptions o;
  o.max_iterations = 1;
  SolverSummary s = OptimizeWithCeres(sim.graph, &v, o);
  EXPECT_EQ(s.status, SolverStatus::kMaxIterations) << s.message;
  EXPECT_EQ(s.iterations, 1);
  EXPECT_LT(s.final_chi2, s.initial_chi2);
  EXPECT_EQ(s.final_chi2, sim.graph.Chi2(v));
  v = sim.initial;
  o.max_iterations = 100;
  o.max_seconds = 1e-9;
  s = OptimizeWithCeres(sim.graph, &v, o);
  EXPECT_EQ(s.status, SolverStatus::kTimeLimit) << s.message;
  EXPECT_TRUE(s.IsSolutionUsable());
  EXPECT_TRUE(AllFinite(v));
}

// ---- fixed variables and the gauge ----

TEST(CeresAdapterTest, FixedVariablesStayBitIdentical) {
  SimulatedGraph sim = Sim(SimWorld::kLandmarks, 120);
  const Key pose_a = 0, pose_b = 57, landmark = 120 + 3;
  for (Key k : {pose_a, pose_b, landmark}) sim.graph.Fix(k);
  // Disturb the fixed variables a little so that the solver would want to move them.
  Values v = sim.initial;
  v.Update(pose_b, v.At<SE2d>(pose_b) * SE2d(0.013, -0.021, 0.017));
  v.Params(landmark)[0] += 0.031;
  const Values start = v;
  const SolverSummary s = OptimizeWithCeres(sim.graph, &v, {});
  ASSERT_EQ(s.status, SolverStatus::kConverged) << s.FullReport();
  EXPECT_FALSE(s.gauge_fixed_automatically);
  EXPECT_EQ(s.num_fixed, 3);
  for (Key k : {pose_a, pose_b, landmark}) {
    EXPECT_EQ(std::memcmp(v.Params(k), start.Params(k), AmbientDim(v.TypeOf(k)) * sizeof(double)), 0) << k;
  }
  // The free variables did move.
  EXPECT_GT(Compare(start, v).position, 1e-3);
}

TEST(CeresAdapterTest, GaugeAndUnusedVariablesAsNatively) {
  // Pose 0 exists but no factor uses it; the loop 1-2-3 must be anchored at pose 1, and pose 0
  // left alone.
  FactorGraph g;
  const auto noise = SqrtInformation::Identity(3);
  g.Add(std::make_unique<BetweenSE2>(1, 2, SE2d(1, 0, 2.0944), noise));
  g.Add(std::make_unique<BetweenSE2>(2, 3, SE2d(1, 0, 2.0944), noise));
  g.Add(std::make_unique<BetweenSE2>(3, 1, SE2d(1, 0, 2.0944), noise));
  Values v;
  v.Insert(0, SE2d(5, 6, 0.7));
  v.Insert(1, SE2d(0.1, 0.2, 0.3));
  v.Insert(2, SE2d(1, 0.1, 2.0));
  v.Insert(3, SE2d(0.5, 0.8, -2.0));
  Values native = v;
  const Values start = v;
  const SolverSummary sn = Optimize(g, &native, {});
  const SolverSummary s = OptimizeWithCeres(g, &v, {});
  ASSERT_EQ(s.status, SolverStatus::kConverged) << s.FullReport();
  EXPECT_TRUE(s.gauge_fixed_automatically);
  EXPECT_EQ(s.gauge_key, 1u);
  EXPECT_EQ(s.gauge_key, sn.gauge_key);
  EXPECT_NE(s.FullReport().find("held 1 fixed"), std::string::npos) << s.FullReport();
  EXPECT_EQ(s.num_variables, 2);
  EXPECT_EQ(s.num_fixed, 2);  // the gauge pose and the unused one, as natively
  EXPECT_EQ(s.num_fixed, sn.num_fixed);
  for (Key k : {Key(0), Key(1)}) EXPECT_EQ(std::memcmp(v.Params(k), start.Params(k), 3 * sizeof(double)), 0) << k;
  EXPECT_LT(s.final_chi2, 1e-10);
  EXPECT_LT(Compare(native, v).position, 1e-6);
  // A prior anchors the problem: then nothing is fixed automatically.
  g.Add(std::make_unique<PriorSE2>(2, SE2d(1, 0.1, 2.0), noise));
  v = start;
  const SolverSummary sp = OptimizeWithCeres(g, &v, {});
  EXPECT_FALSE(sp.gauge_fixed_automatically);
  EXPECT_EQ(sp.num_variables, 3);
}

// ---- failures ----

// Pulls a point towards (5, 5) but throws once x exceeds 2.
class ThrowingFactor : public AutoDiffFactor<ThrowingFactor, 2, Eigen::Vector2d> {
 public:
  explicit ThrowingFactor(Key k) : AutoDiffFactor({k}, SqrtInformation::Identity(2)) {}
  static constexpr const char* kTypeName = "Throwing";
  template <typename T>
  bool operator()(const T* const* p, T* e) const {
    if (p[0][0] > T(2)) throw std::runtime_error("measurement model undefined beyond x = 2");
    e[0] = p[0][0] - T(5);
    e[1] = p[0][1] - T(5);
    return true;
  }
};

// Finite error everywhere, but its Jacobian is NaN wherever y <= 0 (acos' at 1 times a zero
// derivative); the minimum lies at y = -0.5, inside that region.
class NanJacobianFactor : public AutoDiffFactor<NanJacobianFactor, 2, Eigen::Vector2d> {
 public:
  explicit NanJacobianFactor(Key k) : AutoDiffFactor({k}, SqrtInformation::Identity(2)) {}
  static constexpr const char* kTypeName = "NanJacobian";
  template <typename T>
  bool operator()(const T* const* p, T* e) const {
    using std::acos;
    T a = T(1) - p[0][1];
    if (a > T(1)) a = T(1);
    e[0] = T(10) * (p[0][1] + T(0.5));
    e[1] = p[0][0] - T(1) + acos(a);
    return true;
  }
};

TEST(CeresAdapterFailureTest, AFactorThatThrowsEndsDivergedWithTheStartValues) {
  FactorGraph g;
  g.Add(std::make_unique<ThrowingFactor>(1));
  Values v;
  v.Insert(1, Eigen::Vector2d(0, 0));
  const SolverSummary s = OptimizeWithCeres(g, &v, {});
  EXPECT_EQ(s.status, SolverStatus::kDiverged) << s.message;
  EXPECT_FALSE(s.IsSolutionUsable());
  EXPECT_NE(s.message.find("measurement model undefined beyond x = 2"), std::string::npos) << s.message;
  EXPECT_NE(s.message.find("start values were kept"), std::string::npos) << s.message;
  EXPECT_EQ(v.At<Eigen::Vector2d>(1), Eigen::Vector2d(0, 0));
  EXPECT_EQ(s.final_chi2, s.initial_chi2);
}

TEST(CeresAdapterFailureTest, NonFiniteJacobiansNeverReachTheValues) {
  // From a start where the Jacobian is finite, the steps lead into the NaN region: whatever
  // Ceres makes of it, the values stay finite, and a failure keeps the start.
  FactorGraph g;
  g.Add(std::make_unique<NanJacobianFactor>(1));
  Values v;
  v.Insert(1, Eigen::Vector2d(3, 1));
  const SolverSummary s = OptimizeWithCeres(g, &v, {});
  EXPECT_TRUE(AllFinite(v));
  EXPECT_TRUE(std::isfinite(s.final_chi2));
  EXPECT_EQ(s.final_chi2, g.Chi2(v));
  EXPECT_LE(s.final_chi2, s.initial_chi2);
  if (!s.IsSolutionUsable()) {
    EXPECT_EQ(s.status, SolverStatus::kDiverged);
    EXPECT_EQ(v.At<Eigen::Vector2d>(1), Eigen::Vector2d(3, 1));
    EXPECT_NE(s.message.find("start values were kept"), std::string::npos) << s.message;
  }
  // A start with a non-finite Jacobian is refused outright, as natively.
  v.Params(1)[1] = -1;
  const SolverSummary bad = OptimizeWithCeres(g, &v, {});
  EXPECT_EQ(bad.status, SolverStatus::kInvalidInput);
  EXPECT_NE(bad.message.find("Jacobian at the initial values is not finite"), std::string::npos) << bad.message;
  EXPECT_EQ(v.At<Eigen::Vector2d>(1), Eigen::Vector2d(3, -1));
}

TEST(CeresAdapterFailureTest, InvalidInputLeavesValuesUntouched) {
  const SimulatedGraph sim = Sim(SimWorld::kManhattan, 50);
  const Values start = sim.initial;
  Values v = start;
  SolverOptions o;
  o.linear_solver = LinearSolverType::kQR;
  SolverSummary s = OptimizeWithCeres(sim.graph, &v, o);
  EXPECT_EQ(s.status, SolverStatus::kInvalidInput);
  EXPECT_NE(s.message.find("SPARSE_NORMAL_CHOLESKY over SuiteSparse (cholmod); 'qr' is for the native"),
            std::string::npos)
      << s.message;
  o = SolverOptions();
  o.function_tolerance = -1;
  s = OptimizeWithCeres(sim.graph, &v, o);
  EXPECT_EQ(s.status, SolverStatus::kInvalidInput);
  EXPECT_NE(s.message.find("function_tolerance"), std::string::npos) << s.message;
  // A factor referring to a missing variable, and one whose noise has the wrong dimension.
  FactorGraph g = sim.graph;
  g.Add(std::make_unique<BetweenSE2>(3, 999, SE2d(), SqrtInformation::Identity(3)));
  s = OptimizeWithCeres(g, &v, {});
  EXPECT_EQ(s.status, SolverStatus::kInvalidInput);
  EXPECT_NE(s.message.find("which has no value"), std::string::npos) << s.message;
  FactorGraph g2 = sim.graph;
  g2.Add(std::make_unique<BetweenSE2>(3, 4, SE2d(), SqrtInformation::Identity(2)));
  s = OptimizeWithCeres(g2, &v, {});
  EXPECT_EQ(s.status, SolverStatus::kInvalidInput);
  EXPECT_NE(s.message.find("factor " + std::to_string(sim.graph.size())), std::string::npos) << s.message;
  for (Key k : start.keys()) EXPECT_EQ(std::memcmp(v.Params(k), start.Params(k), 3 * sizeof(double)), 0);
  EXPECT_THROW(OptimizeWithCeres(sim.graph, nullptr, {}), InvalidArgument);
}

TEST(CeresAdapterTest, NothingToOptimise) {
  FactorGraph g;
  g.Add(std::make_unique<BetweenSE2>(0, 1, SE2d(1, 0, 0), SqrtInformation::Identity(3)));
  g.Fix(0);
  g.Fix(1);
  Values v;
  v.Insert(0, SE2d());
  v.Insert(1, SE2d(2, 0, 0));
  const SolverSummary s = OptimizeWithCeres(g, &v, {});
  EXPECT_EQ(s.status, SolverStatus::kConverged);
  EXPECT_NE(s.message.find("every variable is fixed"), std::string::npos);
  EXPECT_DOUBLE_EQ(s.final_chi2, 1.0);
  EXPECT_EQ(v.At<SE2d>(1).x(), 2.0);
}

}  // namespace
}  // namespace tether
