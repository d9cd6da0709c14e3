// RangeBearing2: error against its definition, analytic Jacobians against central differences
// (random, near the bearing's wrap at +-pi, poses near pi), prediction, and the g2o line (round
// trip and every refused field). Range 0 and a small graph solved to its truth need a solver:
// tests/solvers/factor_solves_test.cc.
#include "tether/factors/range_bearing.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <sstream>

#include "testing/jacobian_check.h"
#include "testing/read_text.h"
#include "tether/core/graph_io.h"
#include "tether/factors/builtin.h"

namespace tether {
namespace {

constexpr double kPi = 3.14159265358979323846;

SqrtInformation RandomInformation(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  Eigen::Matrix2d a;
  a << u(rng), u(rng), u(rng), u(rng);
  return SqrtInformation::FromInformation(a * a.transpose() + 2 * Eigen::Matrix2d::Identity());
}

Eigen::Vector2d Error(const RangeBearing2& f, const Values& v) {
  Eigen::Vector2d e;
  const std::vector<const double*> p = f.GatherParams(v);
  EXPECT_TRUE(f.Evaluate(p.data(), e.data(), nullptr));
  return e;
}

TEST(RangeBearing2Test, ErrorMatchesDefinition) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-10, 10);
  for (int i = 0; i < 100; ++i) {
    const SE2d x(u(rng), u(rng), u(rng) * kPi / 10);
    const Eigen::Vector2d l(u(rng), u(rng));
    const double range = std::abs(u(rng)), bearing = u(rng) * kPi / 10;
    Values v;
    v.Insert(1, x);
    v.Insert(2, l);
    const RangeBearing2 f(1, 2, range, bearing, SqrtInformation::Identity(2));
    const Eigen::Vector2d d = x.Inverse() * l;  // the landmark in the pose's frame
    const Eigen::Vector2d e = Error(f, v);
    EXPECT_NEAR(e[0], d.norm() - range, 1e-12);
    double db = std::atan2(d.y(), d.x()) - bearing;
    while (db > kPi) db -= 2 * kPi;
    while (db <= -kPi) db += 2 * kPi;
    EXPECT_NEAR(e[1], db, 1e-12);
    EXPECT_GT(e[1], -kPi);
    EXPECT_LE(e[1], kPi);
  }
}

TEST(RangeBearing2Test, JacobiansMatchCentralDifferences) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 200; ++i) {
    Values v;
    const double th = i % 2 ? (kPi - 1e-4 * std::abs(u(rng))) * (u(rng) > 0 ? 1 : -1) : kPi * u(rng);
    v.Insert(1, SE2d(5 * u(rng), 5 * u(rng), th));
    v.Insert(2, Eigen::Vector2d(5 * u(rng), 5 * u(rng)));
    const RangeBearing2 f(1, 2, 5 * std::abs(u(rng)), kPi * u(rng), RandomInformation(rng));
    testing::CheckJacobians(f, v, 1e-6, {1});
  }
}

TEST(RangeBearing2Test, JacobiansAcrossTheBearingWrap) {
  // The landmark behind the pose, just above or below its x axis: atan2 jumps from pi to -pi
  // there, and the measured bearing is near pi or -pi, so the error crosses the wrap.
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 200; ++i) {
    const SE2d x(u(rng), u(rng), kPi * u(rng));
    const double seen = (kPi - 1e-7 * std::abs(u(rng))) * (i % 2 ? 1 : -1);  // bearing of the landmark
    const double range = 1 + 4 * std::abs(u(rng));
    Values v;
    v.Insert(1, x);
    v.Insert(2, Eigen::Vector2d(x * Eigen::Vector2d(range * std::cos(seen), range * std::sin(seen))));
    const double measured = (kPi - 1e-7 * std::abs(u(rng))) * (i % 4 < 2 ? 1 : -1);
    const RangeBearing2 f(1, 2, range + 0.1 * u(rng), measured, RandomInformation(rng));
    const Eigen::Vector2d e = Error(f, v);
    EXPECT_LT(std::abs(e[1]), 1e-6) << "the error must be the small wrapped difference";
    testing::CheckJacobians(f, v, 1e-6, {1});
  }
}

TEST(RangeBearing2Test, RefusesBadMeasurements) {
  const auto make = [](double range, double bearing) {
    return RangeBearing2(1, 2, range, bearing, SqrtInformation::Identity(2));
  };
  EXPECT_THROW(make(-1e-3, 0), InvalidArgument);
  EXPECT_THROW(make(std::nan(""), 0), InvalidArgument);
  EXPECT_THROW(make(INFINITY, 0), InvalidArgument);
  EXPECT_THROW(make(1, std::nan("")), InvalidArgument);
  EXPECT_THROW(make(1, -INFINITY), InvalidArgument);
  EXPECT_NO_THROW(make(0, 0));
  try {
    make(-2, 0);
    FAIL() << "no exception";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("range is -2"), std::string::npos) << e.what();
  }
}

TEST(RangeBearing2Test, PredictsTheLandmarkFromThePose) {
  const RangeBearing2 f(1, 2, 3.0, 2.5, SqrtInformation::Identity(2));
  const double pose[3] = {1, -2, 2.0};
  double l[2];
  ASSERT_TRUE(f.Predict(0, pose, 1, l));
  Values v;
  v.Insert(1, SE2d(1, -2, 2.0));
  v.Insert(2, Eigen::Vector2d(l[0], l[1]));
  EXPECT_LT(Error(f, v).norm(), 1e-12);
  double out[3];
  EXPECT_FALSE(f.Predict(1, l, 0, out)) << "one landmark does not place a pose";
}

GraphFile Read(const std::string& text) { return testing::ReadText(text, "rb.g2o"); }

std::string ReadError(const std::string& text) { return testing::ReadTextError(text, "rb.g2o"); }

TEST(RangeBearing2Test, G2oLineRoundTrip) {
  const std::string text =
      "VERTEX_SE2 0 0 0 0\n"
      "VERTEX_SE2 1 1 0.1 0.2\n"
      "VERTEX_XY 7 3 4\n"
      "EDGE_SE2 0 1 1 0.1 0.2 100 0 0 100 0 1000\n"
      "EDGE_RANGE_BEARING_SE2_XY 0 7 5.0000000000000009 0.9272952180016122 100 0.5 400\n"
      "EDGE_RANGE_BEARING_SE2_XY 1 7 4.1 3.1415926535897931 100 0 400\n";
  const GraphFile g = Read(text);
  ASSERT_EQ(g.graph.size(), 3u);
  const auto* f = dynamic_cast<const RangeBearing2*>(&g.graph.at(1));
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(f->range(), 5.0000000000000009);
  EXPECT_EQ(f->bearing(), 0.9272952180016122);
  EXPECT_EQ(f->noise().Information()(0, 1), 0.5);
  EXPECT_EQ(g.loop_closures, 0) << "a landmark observation is not a loop closure";
  std::ostringstream out;
  WriteG2o(out, g.values, g.graph, DefaultRegistry());
  EXPECT_NE(out.str().find("EDGE_RANGE_BEARING_SE2_XY 0 7 5.000000000000001 0.9272952180016122 100 0.5 400\n"),
            std::string::npos)
      << out.str();
  const GraphFile h = Read(out.str());
  ASSERT_EQ(h.graph.size(), g.graph.size());
  for (std::size_t i = 0; i < g.graph.size(); ++i) {
    EXPECT_EQ(h.graph.at(i).type_name(), g.graph.at(i).type_name());
    EXPECT_EQ(h.graph.at(i).Measurement(), g.graph.at(i).Measurement());
    EXPECT_EQ(h.graph.at(i).noise().Information(), g.graph.at(i).noise().Information());
  }
}

TEST(RangeBearing2Test, G2oLineErrorsNameFileLineAndField) {
  const std::string v = "VERTEX_SE2 0 0 0 0\nVERTEX_XY 7 3 4\n";
  const std::string negative = ReadError(v + "EDGE_RANGE_BEARING_SE2_XY 0 7 -1.5 0.3 1 0 1\n");
  EXPECT_NE(negative.find("rb.g2o:3: EDGE_RANGE_BEARING_SE2_XY: the range (field 3) is -1.5"), std::string::npos)
      << negative;
  const std::string nan = ReadError(v + "EDGE_RANGE_BEARING_SE2_XY 0 7 nan 0.3 1 0 1\n");
  EXPECT_NE(nan.find("rb.g2o:3: EDGE_RANGE_BEARING_SE2_XY field 3 ('nan') is NaN"), std::string::npos) << nan;
  const std::string inf = ReadError(v + "EDGE_RANGE_BEARING_SE2_XY 0 7 1 -inf 1 0 1\n");
  EXPECT_NE(inf.find("rb.g2o:3: EDGE_RANGE_BEARING_SE2_XY field 4 ('-inf') is inf"), std::string::npos) << inf;
  const std::string few = ReadError(v + "EDGE_RANGE_BEARING_SE2_XY 0 7 1 0.3 1 0\n");
  EXPECT_NE(few.find("rb.g2o:3: too few fields"), std::string::npos) << few;
  EXPECT_NE(few.find("range bearing I11 I12 I22"), std::string::npos) << few;
  const std::string swapped = ReadError(v + "EDGE_RANGE_BEARING_SE2_XY 7 0 1 0.3 1 0 1\n");
  EXPECT_NE(swapped.find("rb.g2o:3: id 7 is used here as SE2"), std::string::npos) << swapped;
  const std::string indefinite = ReadError(v + "EDGE_RANGE_BEARING_SE2_XY 0 7 1 0.3 1 2 1\n");
  EXPECT_NE(indefinite.find("rb.g2o:3: EDGE_RANGE_BEARING_SE2_XY"), std::string::npos) << indefinite;
}

}  // namespace
}  // namespace tether
