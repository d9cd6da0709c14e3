// One property suite for all Lie groups: exp/log round trip, inverse, adjoint, retract/local,
// including angles near +-pi and rotations near pi.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "tether/core/se2.h"
#include "tether/core/se3.h"

namespace tether {
namespace {

constexpr double kPi = 3.14159265358979323846;

template <class G>
struct Traits;

template <>
struct Traits<SE2d> {
  using Tangent = Eigen::Vector3d;
  static Tangent Random(std::mt19937& rng, double angle_scale) {
    std::uniform_real_distribution<double> u(-1, 1);
    return Tangent(3 * u(rng), 3 * u(rng), angle_scale * u(rng));
  }
  static Tangent NearPi(std::mt19937& rng) {
    std::uniform_real_distribution<double> u(-1, 1);
    return Tangent(u(rng), u(rng), (kPi - 1e-7) * (u(rng) > 0 ? 1 : -1));
  }
  static Eigen::Matrix3d Hat(const Tangent& v) {
    Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
    m(0, 1) = -v[2];
    m(1, 0) = v[2];
    m(0, 2) = v[0];
    m(1, 2) = v[1];
    return m;
  }
};

template <>
struct Traits<SE3d> {
  using Tangent = Eigen::Matrix<double, 6, 1>;
  static Tangent Random(std::mt19937& rng, double angle_scale) {
    std::uniform_real_distribution<double> u(-1, 1);
    Tangent v;
    for (int i = 0; i < 3; ++i) v[i] = 3 * u(rng);
    Eigen::Vector3d axis(u(rng), u(rng), u(rng));
    axis.normalize();
    v.tail<3>() = axis * (angle_scale * std::abs(u(rng)));
    return v;
  }
  static Tangent NearPi(std::mt19937& rng) {
    Tangent v = Random(rng, 1.0);
    v.tail<3>() = v.tail<3>().normalized() * (kPi - 1e-7);
    return v;
  }
  static Eigen::Matrix4d Hat(const Tangent& v) {
    Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
    m.topLeftCorner<3, 3>() = Skew<double>(v.tail<3>());
    m.topRightCorner<3, 1>() = v.head<3>();
    return m;
  }
};

template <class G>
class LieGroupTest : public ::testing::Test {};
using Groups = ::testing::Types<SE2d, SE3d>;
TYPED_TEST_SUITE(LieGroupTest, Groups);

TYPED_TEST(LieGroupTest, ExpLogRoundTrip) {
  using T = Traits<TypeParam>;
  std::mt19937 rng(7);
  for (int i = 0; i < 200; ++i) {
    const auto v = T::Random(rng, kPi - 1e-3);
    EXPECT_TRUE(TypeParam::Exp(v).Log().isApprox(v, 1e-9)) << v.transpose();
  }
  for (int i = 0; i < 50; ++i) {
    const auto v = T::NearPi(rng);
    // Near pi the logarithm is unique up to the sign of the angle; compare the groups.
    const TypeParam g = TypeParam::Exp(v);
    EXPECT_TRUE(TypeParam::Exp(g.Log()).matrix().isApprox(g.matrix(), 1e-9));
  }
  // Tiny tangents take the series branch.
  const auto tiny = T::Random(rng, 1e-12);
  EXPECT_TRUE(TypeParam::Exp(tiny).Log().isApprox(tiny, 1e-9));
}

TYPED_TEST(LieGroupTest, ExpMatchesMatrixExponential) {
  using T = Traits<TypeParam>;
  std::mt19937 rng(11);
  for (int i = 0; i < 50; ++i) {
    const auto v = T::Random(rng, 2.0);
    // Matrix exponential by scaling and squaring of a Taylor series.
    auto A = T::Hat(v);
    using M = decltype(A);
    const M Ah = A / 1024.0;
    M e = M::Identity(), term = M::Identity();
    for (int k = 1; k < 20; ++k) {
      term = term * Ah / k;
      e += term;
    }
    for (int s = 0; s < 10; ++s) e = e * e;
    EXPECT_TRUE(TypeParam::Exp(v).matrix().isApprox(e, 1e-8));
  }
}

TYPED_TEST(LieGroupTest, InverseAndCompose) {
  using T = Traits<TypeParam>;
  std::mt19937 rng(3);
  for (int i = 0; i < 100; ++i) {
    const TypeParam a = TypeParam::Exp(T::Random(rng, kPi));
    const TypeParam b = TypeParam::Exp(T::Random(rng, kPi));
    using M = decltype(a.matrix());
    EXPECT_TRUE((a * a.Inverse()).matrix().isApprox(M::Identity(), 1e-12));
    EXPECT_TRUE((a * b).matrix().isApprox(a.matrix() * b.matrix(), 1e-12));
  }
}

TYPED_TEST(LieGroupTest, AdjointMovesTangentsAcross) {
  // X * Exp(v) == Exp(Ad_X v) * X
  using T = Traits<TypeParam>;
  std::mt19937 rng(5);
  for (int i = 0; i < 100; ++i) {
    const TypeParam x = TypeParam::Exp(T::Random(rng, kPi));
    const auto v = T::Random(rng, 1.0);
    const typename T::Tangent av = x.Adjoint() * v;
    EXPECT_TRUE((x * TypeParam::Exp(v)).matrix().isApprox((TypeParam::Exp(av) * x).matrix(), 1e-9));
  }
}

TYPED_TEST(LieGroupTest, RetractLocalAreInverse) {
  using T = Traits<TypeParam>;
  std::mt19937 rng(9);
  for (int i = 0; i < 100; ++i) {
    const TypeParam x = TypeParam::Exp(i % 5 == 0 ? T::NearPi(rng) : T::Random(rng, kPi));
    const auto d = T::Random(rng, 1.0);
    const TypeParam y = x.Retract(d);
    EXPECT_TRUE(x.Local(y).isApprox(d, 1e-9));
    // Retract agrees with the group exponential to first order.
    const typename T::Tangent small = T::Random(rng, 1e-5) * 1e-5;
    const double diff = (x.Retract(small).matrix() - (x * TypeParam::Exp(small)).matrix()).norm();
    EXPECT_LT(diff, 1e-12);
  }
}

TEST(SE2Test, AnglesWrapToHalfOpenInterval) {
  EXPECT_DOUBLE_EQ(SE2d(0, 0, kPi).theta(), kPi);
  EXPECT_DOUBLE_EQ(SE2d(0, 0, -kPi).theta(), kPi);
  EXPECT_NEAR(SE2d(0, 0, 3 * kPi + 0.5).theta(), -kPi + 0.5, 1e-12);
  EXPECT_NEAR(SE2d(0, 0, -7.0).theta(), -7.0 + 2 * kPi, 1e-12);
  // Composition across the cut stays wrapped.
  const SE2d a(0, 0, kPi - 0.1), b(0, 0, 0.3);
  EXPECT_NEAR((a * b).theta(), -kPi + 0.2, 1e-12);
}

// Above about 1e16 one reduction is not enough (2 pi floor(...) has lost the digits); any
// finite angle still ends in (-pi, pi], and wrapping it again gives it back.
TEST(SE2Test, HugeAnglesWrapIntoRangeAndStay) {
  for (double a : {1e16, -3e17, 1e77, -1e200, 1.7e308, -1.7976931348623157e308}) {
    const double w = WrapAngle(a);
    EXPECT_GT(w, -kPi) << a;
    EXPECT_LE(w, kPi) << a;
    EXPECT_EQ(WrapAngle(w), w) << a;
  }
  EXPECT_TRUE(std::isnan(WrapAngle(std::numeric_limits<double>::infinity())));
  EXPECT_TRUE(std::isnan(WrapAngle(std::nan(""))));
}

TEST(SO3Test, LogNearPiIsAccurate) {
  const Eigen::Vector3d axis = Eigen::Vector3d(1, 2, -0.5).normalized();
  for (double eps : {1e-3, 1e-6, 1e-9}) {
    const Eigen::Vector3d w = axis * (kPi - eps);
    EXPECT_TRUE(SO3d::Exp(w).Log().isApprox(w, 1e-9)) << eps;
  }
}

}  // namespace
}  // namespace tether
