// The odometry_scale example plugin: a variable type of its own (VERTEX_SCALE) and a factor
// that uses it. A simulated robot whose wheel odometry over-reads every distance by 5% is
// solved with the scale as a variable, and the scale comes back (the same graph through a g2o
// file and `tether optimize --plugin`: tests/tools/scale_plugin_cli_test.cc).
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "testing/scale_world.h"
#include "tether/core/jacobian_check.h"
#include "tether/solvers/optimizer.h"

namespace tether {
namespace {

using testing::kScaleKey;
using testing::kTrueScale;
using testing::PositionRmse;
using testing::ScalePluginTest;
using testing::ScaleWorld;
using testing::SimulateScaleWorld;

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
  ScaleWorld w = SimulateScaleWorld(registry_);
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
  ScaleWorld w = SimulateScaleWorld(registry_);
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
  ScaleWorld held = SimulateScaleWorld(registry_);
  held.file.graph.Fix(kScaleKey);
  const SolverSummary h = Optimize(held.file.graph, &held.file.values, o);
  ASSERT_TRUE(h.IsSolutionUsable());
  EXPECT_GT(h.final_chi2, 10 * s.final_chi2);
}

}  // namespace
}  // namespace tether
