// Switchable constraints (tether/factors/switchable.h): Jacobians against central differences
// for the switch and the wrapped factor's variables, the clamp psi(s) = clamp(s, 0, 1) at and
// beyond its ends, the switch prior, and the Vertigo file forms read and written back.
#include <gtest/gtest.h>

#include <random>
#include <sstream>

#include "testing/jacobian_check.h"
#include "tether/core/graph_io.h"
#include "tether/core/robust_kernels.h"
#include "tether/factors/between_se2.h"
#include "tether/factors/between_se3.h"
#include "tether/factors/builtin.h"
#include "tether/factors/pose_point.h"
#include "tether/factors/switchable.h"

namespace tether {
namespace {

SqrtInformation Info(int n) {
  Eigen::MatrixXd a = Eigen::MatrixXd::Identity(n, n) * 4;
  a(0, 1) = a(1, 0) = 0.5;
  return SqrtInformation::FromInformation(a);
}

TEST(SwitchableFactor, JacobiansMatchCentralDifferencesInsideTheRange) {
  InternSwitchType();  // Values can hold a Switch from here on
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  for (double s : {0.05, 0.3, 0.7, 0.95}) {
    Values v;
    v.Insert(Key(1), SE2d(u(rng), u(rng), u(rng)));
    v.Insert(Key(7), SE2d(3 + u(rng), u(rng), u(rng)));
    v.Insert(Key(100), Switch{s});
    const SwitchableFactor f(std::make_unique<BetweenSE2>(1, 7, SE2d(2.5, 0.3, 0.2), Info(3)), 100);
    EXPECT_EQ(f.type_name(), "SwitchableBetweenSE2");
    ASSERT_EQ(f.keys().size(), 3u);
    EXPECT_EQ(f.switch_key(), Key(100));
    EXPECT_LT(testing::CheckJacobians(f, v, 1e-6, {2}), 1e-6) << "s " << s;

    Values w;
    w.Insert(Key(1), SE3d(SO3d::Exp(Eigen::Vector3d(u(rng), u(rng), u(rng))), Eigen::Vector3d(u(rng), 0, 1)));
    w.Insert(Key(9), SE3d(SO3d::Exp(Eigen::Vector3d(u(rng), u(rng), u(rng))), Eigen::Vector3d(2, u(rng), 0)));
    w.Insert(Key(100), Switch{s});
    const SwitchableFactor g(
        std::make_unique<BetweenSE3>(1, 9, SE3d(SO3d::Exp(Eigen::Vector3d(0.1, 0.2, -0.3)), Eigen::Vector3d(2, 0, 0)),
                                     Info(6)),
        100);
    EXPECT_LT(testing::CheckJacobians(g, w, 1e-6), 1e-6) << "s " << s;

    // Any factor can be wrapped: a pose-point one.
    Values x;
    x.Insert(Key(1), SE2d(u(rng), u(rng), u(rng)));
    x.Insert(Key(2), Eigen::Vector2d(4, u(rng)));
    x.Insert(Key(100), Switch{s});
    const SwitchableFactor h(std::make_unique<PosePoint2>(1, 2, Eigen::Vector2d(3, 1), Info(2)), 100);
    EXPECT_LT(testing::CheckJacobians(h, x, 1e-6), 1e-6) << "s " << s;
  }
}

TEST(SwitchableFactor, ErrorIsTheInnerErrorScaledByTheClampedSwitch) {
  Values v;
  v.Insert(Key(1), SE2d(0, 0, 0));
  v.Insert(Key(2), SE2d(2, 1, 0.5));
  const BetweenSE2 inner(1, 2, SE2d(1, 0, 0), Info(3));
  const double plain = inner.Chi2(v);
  ASSERT_GT(plain, 1);
  const SwitchableFactor f(inner.Clone(), 50);  // makes the Switch type known
  for (double s : {-0.5, 0.0, 0.25, 1.0, 1.5}) {
    Values w = v;
    w.Insert(Key(50), Switch{s});
    const double psi = SwitchScale(s);
    EXPECT_NEAR(f.Chi2(w), psi * psi * plain, 1e-12 * plain) << "s " << s;
    // Beyond the range the switch feels nothing of its closure (d e / d s = 0); inside it,
    // d e / d s is the inner error.
    std::vector<const double*> p = f.GatherParams(w);
    double e[3], j0[9], j1[9], js[3];
    double* jac[3] = {j0, j1, js};
    ASSERT_TRUE(f.Evaluate(p.data(), e, jac));
    double inner_e[3];
    ASSERT_TRUE(inner.Evaluate(p.data(), inner_e, nullptr));
    for (int i = 0; i < 3; ++i) {
      EXPECT_DOUBLE_EQ(e[i], psi * inner_e[i]);
      EXPECT_DOUBLE_EQ(js[i], (s < 0 || s > 1) ? 0.0 : inner_e[i]) << "s " << s;
    }
  }
  EXPECT_EQ(SwitchScale(-1), 0.0);
  EXPECT_EQ(SwitchScale(2), 1.0);
  EXPECT_EQ(SwitchScale(0.4), 0.4);
}

TEST(SwitchableFactor, KeepsTheInnerFactorsLossAndMark) {
  auto inner = std::make_unique<BetweenSE2>(1, 7, SE2d(1, 0, 0), Info(3));
  inner->set_loss(MakeLoss("huber:1"));
  inner->set_loop_closure(true);
  const SwitchableFactor f(std::move(inner), 9);
  ASSERT_NE(f.loss(), nullptr);
  EXPECT_EQ(f.loss()->name(), MakeLoss("huber:1")->name());
  EXPECT_TRUE(f.loop_closure());
  const std::unique_ptr<Factor> copy = f.Clone();
  EXPECT_EQ(copy->loss(), f.loss());
  EXPECT_TRUE(copy->loop_closure());
}

TEST(SwitchableFactor, NullInnerFactorThrows) { EXPECT_THROW(SwitchableFactor(nullptr, 3), InvalidArgument); }

TEST(SwitchPrior, ErrorAndJacobian) {
  InternSwitchType();
  Values v;
  v.Insert(Key(4), Switch{0.25});
  const SwitchPrior p(4, 1.0, SqrtInformation::Isotropic(1, 0.5));
  EXPECT_DOUBLE_EQ(p.Chi2(v), 0.75 * 0.75 * 4);
  EXPECT_LT(testing::CheckJacobians(p, v, 1e-8), 1e-8);
}

TEST(SwitchableFactor, VertigoFileFormsReadAndWriteBack) {
  const std::string text =
      "VERTEX_SE2 0 0 0 0\n"
      "VERTEX_SE2 1 1 0 0\n"
      "VERTEX_SE2 2 2 0.1 0.05\n"
      "VERTEX_SWITCH 10 1\n"
      "VERTEX_SWITCH 11 0.5\n"
      "EDGE_SE2 0 1 1 0 0 100 0 0 100 0 400\n"
      "EDGE_SE2 1 2 1 0 0 100 0 0 100 0 400\n"
      "EDGE_SE2_SWITCHABLE 0 2 10 2 0 0 100 0 0 100 0 400\n"
      "EDGE_SE2_SWITCHABLE 1 2 11 1 0.1 0 50 0 0 50 0 200\n"
      "EDGE_SWITCH_PRIOR 10 1 1\n"
      "EDGE_SWITCH_PRIOR 11 1 2\n";
  std::istringstream in(text);
  const GraphFile file = ReadGraph(in, "vertigo.g2o", DefaultRegistry());
  ASSERT_EQ(file.graph.size(), 6u);
  EXPECT_EQ(file.values.TypeOf(10), VarTypeOf<Switch>());
  EXPECT_DOUBLE_EQ(file.values.At<Switch>(11).value, 0.5);
  const auto* sw = dynamic_cast<const SwitchableFactor*>(&file.graph.at(2));
  ASSERT_NE(sw, nullptr);
  EXPECT_EQ(sw->switch_key(), Key(10));
  EXPECT_EQ(sw->inner().type_name(), "BetweenSE2");
  // A switchable edge carries its own switch: not marked as a loop closure (GNC and
  // switchable constraints would wrap it again).
  EXPECT_FALSE(file.graph.at(2).loop_closure());
  EXPECT_FALSE(file.graph.at(3).loop_closure());
  EXPECT_EQ(file.loop_closures, 0);
  EXPECT_DOUBLE_EQ(file.graph.at(5).Chi2(file.values), 0.25 * 2);

  std::ostringstream out;
  WriteG2o(out, file.values, file.graph, DefaultRegistry());
  std::istringstream again(out.str());
  const GraphFile back = ReadGraph(again, "again.g2o", DefaultRegistry());
  ASSERT_EQ(back.graph.size(), file.graph.size());
  for (std::size_t i = 0; i < file.graph.size(); ++i) {
    EXPECT_EQ(back.graph.at(i).type_name(), file.graph.at(i).type_name());
    EXPECT_EQ(back.graph.at(i).keys(), file.graph.at(i).keys());
    EXPECT_EQ(back.graph.at(i).Chi2(back.values), file.graph.at(i).Chi2(file.values)) << i;
  }
  EXPECT_NE(out.str().find("EDGE_SE2_SWITCHABLE 1 2 11 "), std::string::npos) << out.str();
  EXPECT_NE(out.str().find("VERTEX_SWITCH 11 0.5"), std::string::npos) << out.str();
}

TEST(SwitchableFactor, AShortLineNamesTheFieldsAsThePosePoseEdgeDoes) {
  std::istringstream in(
      "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 2 2 0 0\nVERTEX_SWITCH 9 1\n"
      "EDGE_SE2_SWITCHABLE 0 2 9 2 0 0 1 0 0 1 0\n");
  try {
    ReadGraph(in, "short.g2o", DefaultRegistry());
    ADD_FAILURE() << "a short line was read";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("short.g2o:4"), std::string::npos) << m;
    EXPECT_NE(m.find("id1 id2 id3 x y theta I11"), std::string::npos) << m;
  }
}

TEST(SwitchableFactor, SwitchableSE3LineReads) {
  const std::string text =
      "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\n"
      "VERTEX_SE3:QUAT 5 1 0 0 0 0 0 1\n"
      "VERTEX_SWITCH 9 1\n"
      "EDGE_SE3_SWITCHABLE 0 5 9 1 0 0 0 0 0 1 1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 1 0 0 1 0 1\n";
  std::istringstream in(text);
  const GraphFile file = ReadGraph(in, "vertigo3d.g2o", DefaultRegistry());
  ASSERT_EQ(file.graph.size(), 1u);
  EXPECT_EQ(file.graph.at(0).type_name(), "SwitchableBetweenSE3");
  EXPECT_FALSE(file.graph.at(0).loop_closure());
  EXPECT_NEAR(file.graph.at(0).Chi2(file.values), 0, 1e-20);
}

}  // namespace
}  // namespace tether
