#pragma once
// Shared test helper: the odometry_scale example plugin (plugins/examples/odometry_scale) on a
// simulated robot whose wheel odometry over-reads every distance by 5%, for
// tests/solvers/scale_plugin_test.cc and tests/tools/scale_plugin_cli_test.cc.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "tether/core/graph_io.h"
#include "tether/factors/builtin.h"
#include "tether/factors/prior.h"
#include "tether/plugins/plugin_loader.h"

namespace tether {
namespace testing {

inline constexpr double kTrueScale = 1.0 / 1.05;  // true distance = scale * measured distance
inline constexpr Key kScaleKey = 100000;
inline constexpr int kScalePoses = 80;

inline std::string ScalePluginPath() { return std::string(TETHER_PLUGIN_BUILD_DIR) + "/odometry_scale.so"; }

struct ScaleWorld {
  GraphFile file;
  std::vector<SE2d> truth;
};

// A robot driving 1 m steps with slow turns; odometry reads 5% long, with small noise; a
// position-and-heading fix (PriorSE2) every 10 poses.
inline ScaleWorld SimulateScaleWorld(const Registry& registry) {
  std::mt19937 rng(11);
  std::normal_distribution<double> n(0, 1);
  const FactorType* scaled = registry.FindByName("ScaledOdometrySE2");
  EXPECT_NE(scaled, nullptr);
  ScaleWorld w;
  w.truth.push_back(SE2d(0, 0, 0));
  SE2d dead_reckoned = w.truth[0];
  w.file.values.Insert(0, dead_reckoned);
  const SqrtInformation odo = SqrtInformation::FromSigmas(Eigen::Vector3d(0.01, 0.01, 0.002));
  const SqrtInformation fix = SqrtInformation::FromSigmas(Eigen::Vector3d(0.05, 0.05, 0.01));
  for (int i = 1; i < kScalePoses; ++i) {
    const SE2d step(1.0, 0.0, 0.25 * std::sin(0.15 * i));
    w.truth.push_back(w.truth.back() * step);
    const double z[3] = {step.x() / kTrueScale + 0.01 * n(rng), step.y() / kTrueScale + 0.01 * n(rng),
                         step.theta() + 0.002 * n(rng)};
    w.file.graph.Add(scaled->make({Key(i - 1), Key(i), kScaleKey}, z, odo));
    dead_reckoned = dead_reckoned * SE2d(z[0], z[1], z[2]);
    w.file.values.Insert(i, dead_reckoned);
    if (i % 10 == 0) {
      const SE2d t = w.truth.back();
      w.file.graph.Add(std::make_unique<PriorSE2>(
          i, SE2d(t.x() + 0.05 * n(rng), t.y() + 0.05 * n(rng), t.theta() + 0.01 * n(rng)), fix));
    }
  }
  w.file.graph.Add(std::make_unique<PriorSE2>(0, w.truth[0], fix));
  double one[1] = {1.0};  // the start: no scale error assumed
  w.file.values.InsertParams(kScaleKey, registry.variable_types().at("Scale"), one);
  return w;
}

inline double PositionRmse(const Values& v, const std::vector<SE2d>& truth) {
  double s = 0;
  for (int i = 0; i < kScalePoses; ++i) s += (v.At<SE2d>(i).translation() - truth[i].translation()).squaredNorm();
  return std::sqrt(s / kScalePoses);
}

// A registry with the built-in types and the odometry_scale plugin loaded.
class ScalePluginTest : public ::testing::Test {
 protected:
  ScalePluginTest() {
    RegisterBuiltinFactors(registry_);
    loader_.Load(ScalePluginPath());
  }
  Registry registry_;
  PluginLoader loader_{registry_};
};

}  // namespace testing
}  // namespace tether
