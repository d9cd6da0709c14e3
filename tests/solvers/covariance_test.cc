// Marginal covariances against the dense inverse of H = J^T J, J built from each factor's
// whitened Jacobians at the same values (testing/dense_covariance.h), for every linear solver;
// the errors for held variables, unknown keys and singular systems; the automatic gauge. A
// simulated sphere large enough for CHOLMOD's supernodal factor:
// tests/frontends/covariance_simulated_test.cc.
#include "tether/solvers/covariance.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <map>

#include "testing/dense_covariance.h"
#include "tether/core/error.h"
#include "tether/factors/between_se2.h"
#include "tether/factors/between_se3.h"
#include "tether/factors/pose_point.h"
#include "tether/factors/prior.h"

namespace tether {
namespace {

using testing::Dense;
using testing::DenseCovariance;
using testing::ExpectNear;

SqrtInformation Noise(int dim, double sigma) { return SqrtInformation::Isotropic(dim, sigma); }

// Five SE2 poses, odometry with two loop closures, two Point2 landmarks; values off the
// optimum (the linearisation point need not be one).
void Se2Graph(FactorGraph* g, Values* v, bool anchor) {
  for (int i = 0; i < 5; ++i) v->Insert(i, SE2d(1.0 * i + 0.05 * i * i, 0.1 * i, 0.2 * i - 0.1));
  v->Insert(10, Eigen::Vector2d(2.0, 1.5));
  v->Insert(11, Eigen::Vector2d(3.5, -1.0));
  for (int i = 0; i + 1 < 5; ++i) g->Add<BetweenSE2>(i, i + 1, SE2d(1.0, 0.05, 0.15), Noise(3, 0.1 + 0.02 * i));
  g->Add<BetweenSE2>(0, 3, SE2d(3.0, 0.2, 0.5), Noise(3, 0.3));
  g->Add<BetweenSE2>(1, 4, SE2d(2.9, 0.1, 0.4), Noise(3, 0.25));
  g->Add<PosePoint2>(1, 10, Eigen::Vector2d(1.0, 1.4), Noise(2, 0.05));
  g->Add<PosePoint2>(2, 10, Eigen::Vector2d(0.1, 1.5), Noise(2, 0.07));
  g->Add<PosePoint2>(3, 11, Eigen::Vector2d(0.4, -1.3), Noise(2, 0.05));
  if (anchor) g->Add<PriorSE2>(0, SE2d(0, 0, -0.1), Noise(3, 0.01));
}

class CovarianceTest : public ::testing::TestWithParam<const char*> {
 protected:
  CovarianceOptions Options() const {
    CovarianceOptions o;
    o.linear_solver = GetParam();
    return o;
  }
  // Every free variable's marginal (one at a time and in one batch) and the joint block of
  // `joint` against the dense inverse.
  void CheckAll(const FactorGraph& g, const Values& v, const std::vector<Key>& joint) {
    const Marginals m(g, v, Options());
    const Dense d = DenseCovariance(g, v, m.fixed_keys());
    ASSERT_EQ(m.free_keys().size(), d.offset.size());
    const std::vector<Eigen::MatrixXd> batch = m.MarginalsOf(m.free_keys());
    for (std::size_t i = 0; i < batch.size(); ++i) {
      const Key k = m.free_keys()[i];
      ExpectNear(m.Marginal(k), d.Block(k, k), "Marginal(" + std::to_string(k) + ")");
      ExpectNear(batch[i], d.Block(k, k), "MarginalsOf, key " + std::to_string(k));
    }
    const Eigen::MatrixXd j = m.JointMarginal(joint);
    for (std::size_t a = 0, r = 0; a < joint.size(); r += d.dim.at(joint[a]), ++a) {
      for (std::size_t b = 0, c = 0; b < joint.size(); c += d.dim.at(joint[b]), ++b) {
        ExpectNear(
            j.block(static_cast<Eigen::Index>(r), static_cast<Eigen::Index>(c), d.dim.at(joint[a]), d.dim.at(joint[b])),
            d.Block(joint[a], joint[b]), "joint block " + std::to_string(a) + ", " + std::to_string(b));
      }
    }
  }
};

TEST_P(CovarianceTest, Se2PosesLoopClosuresAndLandmarksMatchTheDenseInverse) {
  FactorGraph g;
  Values v;
  Se2Graph(&g, &v, true);
  CheckAll(g, v, {4, 10, 0, 11});
}

TEST_P(CovarianceTest, Se3ChainWithALoopClosureMatchesTheDenseInverse) {
  FactorGraph g;
  Values v;
  for (int i = 0; i < 5; ++i) {
    Eigen::Matrix<double, 6, 1> x;
    x << 1.0 * i, 0.2 * i, -0.1 * i, 0.1 * i, -0.05 * i, 0.3 * i;
    v.Insert(i, SE3d::Exp(x));
  }
  Eigen::Matrix<double, 6, 1> step;
  step << 1.0, 0.25, -0.05, 0.12, -0.04, 0.28;
  for (int i = 0; i + 1 < 5; ++i) g.Add<BetweenSE3>(i, i + 1, SE3d::Exp(step), Noise(6, 0.1 + 0.01 * i));
  g.Add<BetweenSE3>(0, 4, SE3d::Exp(4 * step), Noise(6, 0.5));
  v.Insert(20, Eigen::Vector3d(2.0, 1.0, 0.5));
  g.Add<PosePoint3>(2, 20, Eigen::Vector3d(0.1, 0.5, 0.9), Noise(3, 0.05));
  g.Add<PosePoint3>(3, 20, Eigen::Vector3d(-0.8, 0.2, 0.8), Noise(3, 0.05));
  g.Fix(0);
  CheckAll(g, v, {3, 20, 1});
}

TEST_P(CovarianceTest, AFixedVariableHasNoCovariance) {
  FactorGraph g;
  Values v;
  Se2Graph(&g, &v, true);
  g.Fix(2);
  const Marginals m(g, v, Options());
  try {
    m.Marginal(2);
    FAIL() << "no error for a fixed variable";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("variable 2 is held fixed"), std::string::npos) << e.what();
  }
  EXPECT_THROW(m.JointMarginal({1, 2}), InvalidArgument);
  EXPECT_THROW(m.Marginal(99), InvalidArgument);
  EXPECT_THROW(m.JointMarginal({1, 1}), InvalidArgument);
  CheckAll(g, v, {1, 3});
}

TEST_P(CovarianceTest, WithoutAnchorTheFirstPoseIsHeldAsOptimizeDoes) {
  FactorGraph g;
  Values v;
  Se2Graph(&g, &v, false);
  const Marginals m(g, v, Options());
  EXPECT_TRUE(m.gauge_fixed_automatically());
  EXPECT_EQ(m.gauge_key(), 0u);
  EXPECT_NE(m.Description().find("variable 0 held fixed (automatic gauge)"), std::string::npos) << m.Description();
  try {
    m.Marginal(0);
    FAIL() << "no error for the gauge variable";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("variable 0 is held fixed to remove the gauge freedom"), std::string::npos)
        << e.what();
  }
  CheckAll(g, v, {1, 10});
}

TEST_P(CovarianceTest, ASingularSystemSaysSo) {
  // Poses 5 and 6 are tied to each other only: nothing holds them in place.
  FactorGraph g;
  Values v;
  Se2Graph(&g, &v, true);
  v.Insert(5, SE2d(0, 1, 0));
  v.Insert(6, SE2d(1, 1, 0));
  g.Add<BetweenSE2>(5, 6, SE2d(1, 0, 0), Noise(3, 0.1));
  try {
    const Marginals m(g, v, Options());
    FAIL() << "no error for a singular H";
  } catch (const RankDeficientError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("H is singular"), std::string::npos) << what;
    if (std::string(GetParam()) != "qr") {
      EXPECT_TRUE(what.find("variable 5 (SE2)") != std::string::npos ||
                  what.find("variable 6 (SE2)") != std::string::npos)
          << what;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Solvers, CovarianceTest, ::testing::Values("cholmod", "ldlt", "qr"));

TEST(CovarianceOptionsTest, RejectsAnUnknownSolver) {
  CovarianceOptions o;
  EXPECT_TRUE(o.IsValid(nullptr));
  o.linear_solver = "magic";
  std::string why;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("cholmod, ldlt or qr"), std::string::npos);
  FactorGraph g;
  Values v;
  Se2Graph(&g, &v, true);
  EXPECT_THROW(Marginals(g, v, o), InvalidArgument);
}

}  // namespace
}  // namespace tether
