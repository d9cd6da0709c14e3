// The odometry_scale example plugin: a variable type of its own (VERTEX_SCALE) and a factor
// that uses it. A simulated robot whose wheel odometry over-reads every distance by 5% is
// solved with the scale as a variable, and the scale comes back; the same graph goes
// through a g2o file and `tether optimize --plugin`.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <random>
#include <string>

#include "tether/core/graph_io.h"
#include "tether/core/jacobian_check.h"
#include "tether/factors/builtin.h"
#include "tether/factors/prior.h"
#include "tether/plugins/plugin_loader.h"
#include "tether/solvers/optimizer.h"

namespace tether {
namespace {

constexpr double kTrueScale = 1.0 / 1.05;  // true distance = scale * measured distance
constexpr Key kScaleKey = 100000;
constexpr int kPoses = 80;

std::string PluginPath() { return std::string(TETHER_PLUGIN_BUILD_DIR) + "/odometry_scale.so"; }

struct ScaleWorld {
  GraphFile file;
  std::vector<SE2d> truth;
};

// A robot driving 1 m steps with slow turns; odometry reads 5% long, with small noise; a
// position-and-heading fix (PriorSE2) every 10 poses.
ScaleWorld Simulate(const Registry& registry) {
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
  for (int i = 1; i < kPoses; ++i) {
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

double PositionRmse(const Values& v, const std::vector<SE2d>& truth) {
  double s = 0;
  for (int i = 0; i < kPoses; ++i) s += (v.At<SE2d>(i).translation() - truth[i].translation()).squaredNorm();
  return std::sqrt(s / kPoses);
}

class ScalePluginTest : public ::testing::Test {
 protected:
  ScalePluginTest() {
    RegisterBuiltinFactors(registry_);
    loader_.Load(PluginPath());
  }
  Registry registry_;
  PluginLoader loader_{registry_};
};

TEST_F(ScalePluginTest, RegistersAVariableTypeAndAFactorThatUsesIt) {
  const LoadedPlugin& p = loader_.loaded().front();
  EXPECT_EQ(p.variable_names, std::vector<std::string>{"Scale"});
  EXPECT_EQ(p.type_names, std::vector<std::string>{"ScaledOdometrySE2"});
  VarType scale;
  ASSERT_TRUE(registry_.FindVariableByTag("VERTEX_SCALE", &scale));
  EXPECT_EQ(registry_.VariableOwner("Scale"), "odometry_scale");
  EXPECT_EQ(AmbientDim(scale), 1);
  EXPECT_EQ(TangentDim(scale), 1);
  const FactorType* f = registry_.FindByTag("EDGE_SE2_SCALED");
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(f->variable_types, (std::vector<VarType>{VarType::kSE2, VarType::kSE2, scale}));
  EXPECT_EQ(f->dim, 3);
}

TEST_F(ScalePluginTest, JacobiansMatchCentralDifferences) {
  ScaleWorld w = Simulate(registry_);
  w.file.values.Update(5, SE2d(3.0, -1.0, 3.1));  // an angle near pi for the wrap
  *w.file.values.Params(kScaleKey) = 0.9;
  for (std::size_t i = 0; i < 8; ++i) {
    if (w.file.graph.at(i).type_name() != "ScaledOdometrySE2") continue;
    JacobianCheckOptions o;
    o.angle_rows = {2};
    const JacobianCheck c = CheckJacobians(w.file.graph.at(i), w.file.values, o);
    EXPECT_TRUE(c.ok) << c.Report();
  }
}

TEST_F(ScalePluginTest, RecoversAFivePercentOdometryScaleError) {
  ScaleWorld w = Simulate(registry_);
  const double before = PositionRmse(w.file.values, w.truth);
  SolverOptions o;
  const SolverSummary s = Optimize(w.file.graph, &w.file.values, o);
  ASSERT_EQ(s.status, SolverStatus::kConverged) << s.FullReport();
  const double scale = *w.file.values.Params(kScaleKey);
  // The scale error is 4.8% (1 / 1.05); it must come back to within 0.3% (odometry noise
  // of 1 cm per metre and fixes of 5 cm over 80 m leave about 0.1%).
  EXPECT_NEAR(scale, kTrueScale, 0.003);
  const double after = PositionRmse(w.file.values, w.truth);
  EXPECT_LT(after, 0.1) << "before " << before;
  EXPECT_GT(before, 0.5);  // dead reckoning at the wrong scale drifts up to 4 m away

  // Without the scale variable (held at 1), the same graph cannot fit the fixes as well.
  ScaleWorld held = Simulate(registry_);
  held.file.graph.Fix(kScaleKey);
  const SolverSummary h = Optimize(held.file.graph, &held.file.values, o);
  ASSERT_TRUE(h.IsSolutionUsable());
  EXPECT_GT(h.final_chi2, 10 * s.final_chi2);
}

TEST_F(ScalePluginTest, ThroughAFileAndTheCommandLine) {
  ScaleWorld w = Simulate(registry_);
  const std::string dir = ::testing::TempDir();
  const std::string in = dir + "/scale_in.g2o", out = dir + "/scale_out.g2o";
  WriteG2oFile(in, w.file.values, w.file.graph, registry_);
  {
    std::ifstream f(in);
    const std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    EXPECT_NE(text.find("VERTEX_SCALE 100000 1\n"), std::string::npos);
    EXPECT_NE(text.find("EDGE_SE2_SCALED 0 1 100000 "), std::string::npos);
  }
  // (The spanning-tree start composes measurements alone; this factor cannot predict a pose
  // without the scale, so that start refuses such a graph, naming the first pose it cannot reach.)
  for (const char* init : {"file", "chordal"}) {
    std::remove(out.c_str());
    const std::string cmd = std::string(TETHER_CLI) + " optimize " + in + " -o " + out + " --plugin " + PluginPath() +
                            " --init " + init + " -q > " + dir + "/scale_cli.txt 2>&1";
    ASSERT_EQ(std::system(cmd.c_str()), 0) << init;
    const GraphFile g = ReadGraphFile(out, registry_);
    EXPECT_NEAR(*g.values.Params(kScaleKey), kTrueScale, 0.003) << init;
    EXPECT_LT(PositionRmse(g.values, w.truth), 0.1) << init;
  }
}

}  // namespace
}  // namespace tether
