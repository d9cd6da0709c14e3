// MarginalPrior: its Jacobians (the box-minus derivative included) against central differences
// for every built-in variable type and a registered one, the quadratic it stands for, and its
// refusals of inconsistent input.
#include "tether/factors/marginal_prior.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>

#include "tether/core/error.h"
#include "tether/core/jacobian_check.h"
#include "tether/core/values.h"

namespace tether {
namespace {

Eigen::MatrixXd RandomInformation(int n, std::mt19937& rng) {
  std::normal_distribution<double> N(0, 1);
  Eigen::MatrixXd A(n + 2, n);
  for (int i = 0; i < A.rows(); ++i)
    for (int j = 0; j < n; ++j) A(i, j) = N(rng);
  return A.transpose() * A;
}

TEST(MarginalPrior, JacobiansMatchCentralDifferencesAwayFromTheLinearisationPoint) {
  std::mt19937 rng(3);
  Values x0, x;
  x0.Insert(Key(1), SE2d(1, 2, 2.9));
  x.Insert(Key(1), SE2d(1.3, 1.8, -2.9));  // across the angle wrap
  x0.Insert(Key(2), SE3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized())),
                         Eigen::Vector3d(1, 0, -1)));
  x.Insert(Key(2), SE3d(Eigen::Quaterniond(Eigen::AngleAxisd(1.1, Eigen::Vector3d(-1, 2, 0.5).normalized())),
                        Eigen::Vector3d(1.2, 0.3, -0.8)));
  x0.Insert(Key(3), Eigen::Vector2d(4, 5));
  x.Insert(Key(3), Eigen::Vector2d(4.5, 4));
  x0.Insert(Key(4), Eigen::Vector3d(1, 1, 1));
  x.Insert(Key(4), Eigen::Vector3d(0, 1, 2));
  const std::vector<Key> keys{1, 2, 3, 4};
  std::vector<VarType> types;
  std::vector<double> points;
  for (Key k : keys) {
    types.push_back(x0.TypeOf(k));
    points.insert(points.end(), x0.Params(k), x0.Params(k) + AmbientDim(x0.TypeOf(k)));
  }
  const int n = 3 + 6 + 2 + 3;
  const Eigen::MatrixXd H = RandomInformation(n, rng);
  const Eigen::VectorXd g = Eigen::VectorXd::LinSpaced(n, -1, 2);
  const auto prior = MarginalPrior::FromInformation(keys, types, points, H, g);
  EXPECT_TRUE(prior->anchors());
  JacobianCheckOptions o;
  o.absolute_tolerance = 1e-6;
  o.relative_tolerance = 1e-6;
  const JacobianCheck c = CheckJacobians(*prior, x, o);
  EXPECT_TRUE(c.ok) << c.Report();
  // And at the linearisation point itself.
  const JacobianCheck c0 = CheckJacobians(*prior, x0, o);
  EXPECT_TRUE(c0.ok) << c0.Report();
}

// A registered type whose box-minus is not a plain difference: a point on the unit circle
// stored as (cos a, sin a), stepped by an angle.
VarType CircleType() {
  VariableType t;
  t.name = "MarginalPriorTestCircle";
  t.ambient_dim = 2;
  t.tangent_dim = 1;
  t.retract = [](const double* x, const double* d, double* out) {
    const double a = std::atan2(x[1], x[0]) + d[0];
    out[0] = std::cos(a), out[1] = std::sin(a);
  };
  t.local = [](const double* x, const double* y, double* d) {
    d[0] = std::remainder(std::atan2(y[1], y[0]) - std::atan2(x[1], x[0]), 2 * M_PI);
  };
  t.identity = [](double* x) { x[0] = 1, x[1] = 0; };
  return InternVariableType(t);
}

TEST(MarginalPrior, ARegisteredTypesJacobianComesFromItsBoxPlusAndBoxMinus) {
  std::mt19937 rng(5);
  const VarType circle = CircleType();
  const std::vector<double> points{std::cos(0.4), std::sin(0.4), 1, 2, 0.5};
  const auto prior = MarginalPrior::FromInformation({1, 2}, {circle, VarType::kSE2}, points, RandomInformation(4, rng),
                                                    Eigen::Vector4d(1, -1, 0.5, 2));
  Values x;
  const double c[2] = {std::cos(1.3), std::sin(1.3)};
  x.InsertParams(Key(1), circle, c);
  x.Insert(Key(2), SE2d(1.5, 2.5, 0.9));
  const JacobianCheck check = CheckJacobians(*prior, x);
  EXPECT_TRUE(check.ok) << check.Report();
}

TEST(MarginalPrior, TheResidualIsTheQuadraticItWasMadeFrom) {
  std::mt19937 rng(4);
  Values x0;
  x0.Insert(Key(7), SE2d(1, 2, 0.3));
  x0.Insert(Key(9), Eigen::Vector2d(-1, 3));
  const Eigen::MatrixXd H = RandomInformation(5, rng);
  Eigen::VectorXd g(5);
  g << 0.5, -1, 2, 0.1, -0.3;
  std::vector<double> points{1, 2, 0.3, -1, 3};
  const auto prior = MarginalPrior::FromInformation({7, 9}, {VarType::kSE2, VarType::kPoint2}, points, H, g);
  EXPECT_LT((prior->Information() - H).norm(), 1e-9 * H.norm());
  EXPECT_LT((prior->Gradient() - g).norm(), 1e-9 * g.norm());
  // |e(x0 (+) xi)|^2 - |e(x0)|^2 = xi^T H xi + 2 g^T xi for a small xi.
  Eigen::VectorXd xi(5);
  xi << 0.01, -0.02, 0.005, 0.03, -0.01;
  Values x = x0;
  x.Retract(Key(7), xi.data());
  x.Retract(Key(9), xi.data() + 3);
  const double expected = xi.dot(H * xi) + 2 * g.dot(xi);
  const double got = prior->Chi2(x) - prior->Chi2(x0);
  EXPECT_NEAR(got, expected, 1e-12 + 1e-9 * std::abs(expected));
}

TEST(MarginalPrior, UnobservedDirectionsAreLeftOut) {
  // Information along one direction of a Point2 only: one residual row.
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(2, 2);
  H(0, 0) = 4;
  const Eigen::Vector2d g(2, 0);
  const auto prior = MarginalPrior::FromInformation({3}, {VarType::kPoint2}, {0, 0}, H, g);
  EXPECT_EQ(prior->residual_dim(), 1);
  EXPECT_LT((prior->Information() - H).norm(), 1e-12);
}

TEST(MarginalPrior, RefusesInconsistentInput) {
  EXPECT_THROW(MarginalPrior({1}, {VarType::kSE2}, {0, 0}, Eigen::MatrixXd::Identity(3, 3), Eigen::VectorXd::Zero(3)),
               InvalidArgument);  // two parameters for an SE2
  EXPECT_THROW(
      MarginalPrior({1}, {VarType::kSE2}, {0, 0, 0}, Eigen::MatrixXd::Identity(3, 2), Eigen::VectorXd::Zero(3)),
      InvalidArgument);  // R's columns are not the tangent's
  EXPECT_THROW(
      MarginalPrior({1, 2}, {VarType::kSE2}, {0, 0, 0}, Eigen::MatrixXd::Identity(3, 3), Eigen::VectorXd::Zero(3)),
      InvalidArgument);  // a type missing
  Eigen::MatrixXd R = Eigen::MatrixXd::Identity(2, 2);
  R(0, 1) = std::nan("");
  EXPECT_THROW(MarginalPrior({1}, {VarType::kPoint2}, {0, 0}, R, Eigen::VectorXd::Zero(2)), InvalidArgument);
  EXPECT_THROW(MarginalPrior::FromInformation({1}, {VarType::kPoint2}, {0, 0}, Eigen::MatrixXd::Zero(2, 2),
                                              Eigen::VectorXd::Zero(2)),
               InvalidArgument);  // no information at all
}

}  // namespace
}  // namespace tether
