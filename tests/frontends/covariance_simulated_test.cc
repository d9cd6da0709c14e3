// Marginal covariances of a simulated sphere (300 SE3 poses: large enough for CHOLMOD to
// choose its supernodal factor) against the dense inverse of H, for every linear solver. The
// other covariance tests, on graphs built by hand: tests/solvers/covariance_test.cc.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <string>
#include <vector>

#include "testing/dense_covariance.h"
#include "tether/frontends/simulation/simulate.h"
#include "tether/solvers/covariance.h"

namespace tether {
namespace {

using testing::Dense;
using testing::DenseCovariance;
using testing::ExpectNear;

class CovarianceTest : public ::testing::TestWithParam<const char*> {
 protected:
  CovarianceOptions Options() const {
    CovarianceOptions o;
    o.linear_solver = GetParam();
    return o;
  }
};

TEST_P(CovarianceTest, ASimulatedSphereMatchesTheDenseInverse) {
  // Large enough (300 SE3 poses) for CHOLMOD to choose its supernodal factor.
  SimulateOptions o;
  o.world = SimWorld::kSphere;
  o.poses = 300;
  o.seed = 5;
  const SimulatedGraph s = Simulate(o);
  const Marginals m(s.graph, s.initial, Options());
  const Dense d = DenseCovariance(s.graph, s.initial, m.fixed_keys());
  const std::vector<Eigen::MatrixXd> batch = m.MarginalsOf(m.free_keys());
  for (std::size_t i = 0; i < batch.size(); ++i) {
    const Key k = m.free_keys()[i];
    ExpectNear(batch[i], d.Block(k, k), "key " + std::to_string(k));
  }
  ExpectNear(m.JointMarginal({7, 250}).block(0, 6, 6, 6), d.Block(7, 250), "joint 7, 250");
  if (std::string(GetParam()) == "cholmod") {
    EXPECT_NE(m.Description().find("supernodal"), std::string::npos);
  }
}

INSTANTIATE_TEST_SUITE_P(Solvers, CovarianceTest, ::testing::Values("cholmod", "ldlt", "qr"));

}  // namespace
}  // namespace tether
