// Every built-in factor: analytic Jacobians against central differences on random inputs,
// including angles near +-pi and rotations near pi; errors against their definitions.
#include <gtest/gtest.h>

#include <random>

#include "testing/jacobian_check.h"
#include "tether/core/autodiff_factor.h"
#include "tether/factors/between_se2.h"
#include "tether/factors/between_se3.h"
#include "tether/factors/builtin.h"
#include "tether/factors/pose_point.h"
#include "tether/factors/prior.h"

namespace tether {
namespace {

constexpr double kPi = 3.14159265358979323846;

SE2d RandomSE2(std::mt19937& rng, bool near_pi) {
  std::uniform_real_distribution<double> u(-1, 1);
  const double th = near_pi ? (kPi - 1e-4 * std::abs(u(rng))) * (u(rng) > 0 ? 1 : -1) : kPi * u(rng);
  return SE2d(5 * u(rng), 5 * u(rng), th);
}

SE3d RandomSE3(std::mt19937& rng, bool near_pi) {
  std::uniform_real_distribution<double> u(-1, 1);
  Eigen::Matrix<double, 6, 1> v;
  for (int i = 0; i < 3; ++i) v[i] = 5 * u(rng);
  const Eigen::Vector3d axis = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
  v.tail<3>() = axis * (near_pi ? kPi - 1e-4 * std::abs(u(rng)) : kPi * std::abs(u(rng)));
  return SE3d(SO3d::Exp(v.tail<3>()), v.head<3>());
}

SqrtInformation RandomInformation(std::mt19937& rng, int n) {
  std::uniform_real_distribution<double> u(-1, 1);
  Eigen::MatrixXd a = Eigen::MatrixXd::NullaryExpr(n, n, [&]() { return u(rng); });
  return SqrtInformation::FromInformation(a * a.transpose() + n * Eigen::MatrixXd::Identity(n, n));
}

Eigen::Matrix<double, 6, 1> SmallTangent(std::mt19937& rng, double s) {
  std::uniform_real_distribution<double> u(-s, s);
  Eigen::Matrix<double, 6, 1> v;
  for (int i = 0; i < 6; ++i) v[i] = u(rng);
  return v;
}

class FactorJacobianTest : public ::testing::TestWithParam<bool> {};  // param: near pi

TEST_P(FactorJacobianTest, BetweenSE2) {
  std::mt19937 rng(GetParam() ? 21 : 20);
  for (int i = 0; i < 100; ++i) {
    Values v;
    v.Insert(1, RandomSE2(rng, GetParam()));
    v.Insert(2, RandomSE2(rng, GetParam()));
    const SE2d z = i % 2 ? RandomSE2(rng, GetParam()) : v.At<SE2d>(1).Inverse() * v.At<SE2d>(2);
    BetweenSE2 f(1, 2, z, RandomInformation(rng, 3));
    testing::CheckJacobians(f, v, 1e-6, {2});
  }
}

TEST_P(FactorJacobianTest, BetweenSE3) {
  std::mt19937 rng(GetParam() ? 31 : 30);
  for (int i = 0; i < 100; ++i) {
    Values v;
    v.Insert(1, RandomSE3(rng, GetParam()));
    v.Insert(2, RandomSE3(rng, GetParam()));
    // The measurement is near the true relative pose (as in real graphs), so the error
    // rotation is small even when the poses are near pi.
    const SE3d rel = v.At<SE3d>(1).Inverse() * v.At<SE3d>(2);
    const SE3d z = rel * SE3d::Exp(SmallTangent(rng, i % 3 == 0 ? 1.0 : 0.1));
    BetweenSE3 f(1, 2, z, RandomInformation(rng, 6));
    testing::CheckJacobians(f, v, 1e-6);
  }
}

TEST_P(FactorJacobianTest, PosePoint2) {
  std::mt19937 rng(GetParam() ? 41 : 40);
  std::uniform_real_distribution<double> u(-5, 5);
  for (int i = 0; i < 100; ++i) {
    Values v;
    v.Insert(1, RandomSE2(rng, GetParam()));
    v.Insert(2, Eigen::Vector2d(u(rng), u(rng)));
    PosePoint2 f(1, 2, Eigen::Vector2d(u(rng), u(rng)), RandomInformation(rng, 2));
    testing::CheckJacobians(f, v, 1e-6);
  }
}

TEST_P(FactorJacobianTest, PosePoint3) {
  std::mt19937 rng(GetParam() ? 51 : 50);
  std::uniform_real_distribution<double> u(-5, 5);
  for (int i = 0; i < 100; ++i) {
    Values v;
    v.Insert(1, RandomSE3(rng, GetParam()));
    v.Insert(2, Eigen::Vector3d(u(rng), u(rng), u(rng)));
    PosePoint3 f(1, 2, Eigen::Vector3d(u(rng), u(rng), u(rng)), RandomInformation(rng, 3));
    testing::CheckJacobians(f, v, 1e-6);
  }
}

TEST_P(FactorJacobianTest, Priors) {
  std::mt19937 rng(GetParam() ? 61 : 60);
  for (int i = 0; i < 100; ++i) {
    Values v;
    v.Insert(1, RandomSE2(rng, GetParam()));
    v.Insert(2, RandomSE3(rng, GetParam()));
    PriorSE2 p2(1, RandomSE2(rng, GetParam()), RandomInformation(rng, 3));
    testing::CheckJacobians(p2, v, 1e-6, {2});
    PriorSE3 p3(2, v.At<SE3d>(2) * SE3d::Exp(SmallTangent(rng, 0.3)), RandomInformation(rng, 6));
    testing::CheckJacobians(p3, v, 1e-6);
  }
}

INSTANTIATE_TEST_SUITE_P(Angles, FactorJacobianTest, ::testing::Values(false, true),
                         [](const ::testing::TestParamInfo<bool>& i) { return i.param ? "NearPi" : "Random"; });

TEST(FactorErrorTest, BetweenSE2MatchesDefinition) {
  // e = toVector(Z^-1 (Xi^-1 Xj)), computed here with the group operations.
  std::mt19937 rng(1);
  for (int i = 0; i < 50; ++i) {
    Values v;
    v.Insert(1, RandomSE2(rng, false));
    v.Insert(2, RandomSE2(rng, false));
    const SE2d z = RandomSE2(rng, false);
    BetweenSE2 f(1, 2, z, SqrtInformation::Identity(3));
    const SE2d e = z.Inverse() * (v.At<SE2d>(1).Inverse() * v.At<SE2d>(2));
    const auto p = f.GatherParams(v);
    double err[3];
    ASSERT_TRUE(f.Evaluate(p.data(), err, nullptr));
    EXPECT_NEAR(err[0], e.x(), 1e-12);
    EXPECT_NEAR(err[1], e.y(), 1e-12);
    EXPECT_NEAR(err[2], e.theta(), 1e-12);
    EXPECT_NEAR(f.Chi2(v), e.x() * e.x() + e.y() * e.y() + e.theta() * e.theta(), 1e-9);
  }
}

TEST(FactorErrorTest, BetweenSE3QuaternionSignIsNormalised) {
  // A measurement 0.2 rad away, once with a negated quaternion: same error, w >= 0 part.
  Values v;
  v.Insert(1, SE3d());
  v.Insert(2, SE3d(SO3d::Exp(Eigen::Vector3d(0.2, 0, 0)), Eigen::Vector3d(1, 2, 3)));
  Eigen::Quaterniond q(1, 0, 0, 0);
  BetweenSE3 f(1, 2, SE3d(q, Eigen::Vector3d(1, 2, 3)), SqrtInformation::Identity(6));
  const auto p = f.GatherParams(v);
  double e[6];
  ASSERT_TRUE(f.Evaluate(p.data(), e, nullptr));
  EXPECT_NEAR(e[3], std::sin(0.1), 1e-12);
  q.coeffs() = -q.coeffs();
  BetweenSE3 g(1, 2, SE3d(q, Eigen::Vector3d(1, 2, 3)), SqrtInformation::Identity(6));
  double e2[6];
  ASSERT_TRUE(g.Evaluate(p.data(), e2, nullptr));
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(e[i], e2[i], 1e-12);
}

TEST(FactorErrorTest, WhiteningGivesChi2OfInformation) {
  std::mt19937 rng(2);
  Values v;
  v.Insert(1, RandomSE2(rng, false));
  v.Insert(2, RandomSE2(rng, false));
  const SqrtInformation n = RandomInformation(rng, 3);
  BetweenSE2 f(1, 2, RandomSE2(rng, false), n);
  const auto p = f.GatherParams(v);
  Eigen::Vector3d e;
  ASSERT_TRUE(f.Evaluate(p.data(), e.data(), nullptr));
  EXPECT_NEAR(f.Chi2(v), e.dot(n.Information() * e), 1e-9 * f.Chi2(v));
}

// The same SE3 relative-pose error written as a templated residual: autodiff through
// ceres::Jet must reproduce the analytic Jacobians.
class AutoBetweenSE3 : public AutoDiffFactor<AutoBetweenSE3, 6, SE3d, SE3d> {
 public:
  AutoBetweenSE3(Key i, Key j, const SE3d& z, SqrtInformation n) : AutoDiffFactor({i, j}, n), z_(z) {}
  static constexpr const char* kTypeName = "AutoBetweenSE3";
  template <typename T>
  bool operator()(const T* const* p, T* e) const {
    const SE3<T> xi = SE3<T>::FromParams(p[0]), xj = SE3<T>::FromParams(p[1]);
    const SE3<T> z(z_.quaternion().cast<T>(), z_.translation().cast<T>());
    const SE3<T> d = z.Inverse() * (xi.Inverse() * xj);
    Eigen::Quaternion<T> q = d.quaternion();
    if (q.w() < T(0)) q.coeffs() = -q.coeffs();
    for (int i = 0; i < 3; ++i) e[i] = d.translation()[i];
    e[3] = q.x(), e[4] = q.y(), e[5] = q.z();
    return true;
  }

 private:
  SE3d z_;
};

TEST(AutoDiffFactorTest, MatchesAnalyticJacobians) {
  std::mt19937 rng(8);
  for (int i = 0; i < 50; ++i) {
    Values v;
    v.Insert(1, RandomSE3(rng, i % 2 == 0));
    v.Insert(2, RandomSE3(rng, i % 2 == 0));
    const SE3d z = (v.At<SE3d>(1).Inverse() * v.At<SE3d>(2)) * SE3d::Exp(SmallTangent(rng, 0.2));
    BetweenSE3 analytic(1, 2, z, SqrtInformation::Identity(6));
    AutoBetweenSE3 autodiff(1, 2, z, SqrtInformation::Identity(6));
    const auto p = analytic.GatherParams(v);
    double ea[6], eb[6], ja[2][36], jb[2][36];
    double* pa[2] = {ja[0], ja[1]};
    double* pb[2] = {jb[0], jb[1]};
    ASSERT_TRUE(analytic.Evaluate(p.data(), ea, pa));
    ASSERT_TRUE(autodiff.Evaluate(p.data(), eb, pb));
    for (int r = 0; r < 6; ++r) EXPECT_NEAR(ea[r], eb[r], 1e-12);
    for (int k = 0; k < 2; ++k)
      for (int c = 0; c < 36; ++c) EXPECT_NEAR(ja[k][c], jb[k][c], 1e-9) << k << "," << c;
    testing::CheckJacobians(autodiff, v, 1e-6);
  }
}

TEST(RegistryTest, BuiltinsAreRegisteredByTag) {
  const Registry& r = DefaultRegistry();
  for (const char* tag : {"EDGE_SE2", "EDGE_SE3:QUAT", "EDGE_SE2_XY", "EDGE_PRIOR_SE2"}) {
    const FactorType* t = r.FindByTag(tag);
    ASSERT_NE(t, nullptr) << tag;
    EXPECT_EQ(t->owner, "builtin");
  }
  EXPECT_EQ(r.FindByTag("EDGE_SE2")->name, "BetweenSE2");
  EXPECT_EQ(r.FindByName("BetweenSE3")->dim, 6);
  EXPECT_EQ(r.FindByName("PosePoint3")->variable_types.size(), 2u);
}

TEST(PredictTest, BetweenFactorsComposeBothWays) {
  std::mt19937 rng(4);
  const SE3d a = RandomSE3(rng, false), z = RandomSE3(rng, false);
  BetweenSE3 f(1, 2, z, SqrtInformation::Identity(6));
  double pa[7], pb[7], back[7];
  a.ToParams(pa);
  ASSERT_TRUE(f.Predict(0, pa, 1, pb));
  EXPECT_TRUE((SE3d::FromParams(pb).matrix()).isApprox((a * z).matrix(), 1e-12));
  ASSERT_TRUE(f.Predict(1, pb, 0, back));
  EXPECT_TRUE(SE3d::FromParams(back).matrix().isApprox(a.matrix(), 1e-12));
  PriorSE2 prior(1, SE2d(), SqrtInformation::Identity(3));
  EXPECT_FALSE(prior.Predict(0, pa, 0, pb));
}

}  // namespace
}  // namespace tether
