// Plugin factors solved through the Ceres adapter: the example plugins (range_2d with an
// analytic Jacobian, position_prior differentiated with ceres::Jet) in graphs with built-in
// odometry, solved by Ceres and by the native Levenberg-Marquardt to the same optimum.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>

#include "tether/core/error.h"
#include "tether/factors/between_se2.h"
#include "tether/factors/between_se3.h"
#include "tether/factors/builtin.h"
#include "tether/plugins/plugin_loader.h"
#include "tether/solvers/ceres_adapter.h"
#include "tether/solvers/optimizer.h"

namespace tether {
namespace {

Key X(int i) { return Symbol('x', i); }

std::string PluginPath(const std::string& name) { return std::string(TETHER_PLUGIN_BUILD_DIR) + "/" + name + ".so"; }

class CeresPluginTest : public ::testing::Test {
 protected:
  CeresPluginTest() { RegisterBuiltinFactors(registry_); }

  const FactorType& LoadType(const std::string& plugin, const std::string& tag) {
    loader_.Load(PluginPath(plugin));
    const FactorType* t = registry_.FindByTag(tag);
    if (t == nullptr) throw Error("plugin " + plugin + " did not register " + tag);
    return *t;
  }

  // Solves `graph` from `start` natively and with Ceres, both run until rounding stops them
  // (function_tolerance 1e-15, see tests/frontends/ceres_adapter_test.cc), and expects the
  // same chi2 to 1e-11 relative and the same poses to 1e-7.
  static void ExpectSameOptimum(const FactorGraph& graph, const Values& start) {
    SolverOptions o;
    o.function_tolerance = 1e-15;
    Values native = start, ceres = start;
    const SolverSummary sn = Optimize(graph, &native, o);
    const SolverSummary sc = OptimizeWithCeres(graph, &ceres, o);
    ASSERT_EQ(sn.status, SolverStatus::kConverged) << sn.FullReport();
    ASSERT_EQ(sc.status, SolverStatus::kConverged) << sc.FullReport();
    EXPECT_LT(sc.final_chi2, 0.1 * sc.initial_chi2);  // it did solve
    EXPECT_NEAR(sc.final_chi2, sn.final_chi2, 1e-11 * sn.final_chi2) << sc.FullReport() << sn.FullReport();
    EXPECT_EQ(sc.num_residuals, sn.num_residuals);
    EXPECT_EQ(sc.gauge_fixed_automatically, sn.gauge_fixed_automatically);
    double worst = 0;
    for (Key k : start.keys()) {
      const int n = AmbientDim(start.TypeOf(k));
      for (int i = 0; i < n; ++i) worst = std::max(worst, std::abs(native.Params(k)[i] - ceres.Params(k)[i]));
    }
    EXPECT_LT(worst, 1e-7);
    std::printf("chi2 %.6g -> %.12g (native) %.12g (ceres); max parameter difference %.2e\n", sc.initial_chi2,
                sn.final_chi2, sc.final_chi2, worst);
  }

  Registry registry_;
  PluginLoader loader_{registry_};
};

// A robot on a circle with noisy odometry, ranges to four fixed beacons (range_2d) and GPS
// fixes on every 5th pose (position_prior, SE2); the start is dead reckoning, 0.5 m off.
TEST_F(CeresPluginTest, RangesAndGpsPriorsSE2) {
  const FactorType& range = LoadType("range_2d", "EDGE_RANGE_SE2_XY");
  const FactorType& gps = LoadType("position_prior", "EDGE_POSITION_PRIOR_SE2");
  std::mt19937 rng(3);
  std::normal_distribution<double> n01(0, 1);
  FactorGraph graph;
  Values values;
  const int n = 30;
  std::vector<SE2d> truth;
  for (int k = 0; k < n; ++k) {
    const double a = 0.9 * 2 * M_PI * k / n;
    truth.emplace_back(6 * std::cos(a), 6 * std::sin(a), a + M_PI / 2);
  }
  SE2d x(6.5, -0.3, M_PI / 2 + 0.1);
  values.Insert(X(0), x);
  for (int i = 0; i + 1 < n; ++i) {
    const SE2d z = truth[i].Inverse() * truth[i + 1] * SE2d(0.05 * n01(rng), 0.05 * n01(rng), 0.01 * n01(rng));
    graph.Add(std::make_unique<BetweenSE2>(X(i), X(i + 1), z, SqrtInformation::Isotropic(3, 0.05)));
    x = x * z;
    values.Insert(X(i + 1), x);
  }
  const Eigen::Vector2d beacons[] = {{10, 10}, {-10, 10}, {-10, -10}, {10, -11}};
  for (int j = 0; j < 4; ++j) {
    values.Insert(100 + j, beacons[j]);
    graph.Fix(100 + j);
    for (int i = 0; i < n; ++i) {
      const double r = (beacons[j] - truth[i].translation()).norm() + 0.1 * n01(rng);
      graph.Add(range.make({X(i), Key(100 + j)}, &r, SqrtInformation::Isotropic(1, 0.1)));
    }
  }
  for (int i = 0; i < n; i += 5) {
    const Eigen::Vector2d z = truth[i].translation() + Eigen::Vector2d(0.3 * n01(rng), 0.3 * n01(rng));
    graph.Add(gps.make({X(i)}, z.data(), SqrtInformation::Isotropic(2, 0.3)));
  }
  ExpectSameOptimum(graph, values);
}

// A 3D helix with SE3 odometry and GPS fixes (position_prior, SE3, an autodiff factor) on
// every 4th pose; nothing fixed, the priors hold the frame.
TEST_F(CeresPluginTest, GpsPriorsSE3) {
  const FactorType& gps = LoadType("position_prior", "EDGE_POSITION_PRIOR_SE3");
  std::mt19937 rng(5);
  std::normal_distribution<double> n01(0, 1);
  FactorGraph graph;
  Values values;
  const int n = 30;
  std::vector<SE3d> truth;
  for (int i = 0; i < n; ++i) {
    const double a = 0.2 * i;
    truth.emplace_back(SO3d::Exp(Eigen::Vector3d(0.1 * std::sin(a), 0.05, a)),
                       Eigen::Vector3d(5 * std::cos(a), 5 * std::sin(a), 0.1 * i));
  }
  Eigen::Matrix<double, 6, 1> offset;
  offset << 0.8, -0.4, 0.3, 0.05, -0.05, 0.15;
  SE3d x = truth[0] * SE3d::Exp(offset);
  values.Insert(X(0), x);
  for (int i = 0; i + 1 < n; ++i) {
    const SE3d noise(SO3d::Exp(0.005 * Eigen::Vector3d(n01(rng), n01(rng), n01(rng))),
                     0.03 * Eigen::Vector3d(n01(rng), n01(rng), n01(rng)));
    const SE3d z = truth[i].Inverse() * truth[i + 1] * noise;
    graph.Add(std::make_unique<BetweenSE3>(X(i), X(i + 1), z, SqrtInformation::Isotropic(6, 0.03)));
    x = x * z;
    values.Insert(X(i + 1), x);
  }
  for (int i = 0; i < n; i += 4) {
    const Eigen::Vector3d z = truth[i].translation() + 0.3 * Eigen::Vector3d(n01(rng), n01(rng), n01(rng));
    graph.Add(gps.make({X(i)}, z.data(), SqrtInformation::Isotropic(3, 0.3)));
  }
  ExpectSameOptimum(graph, values);
}

}  // namespace
}  // namespace tether
