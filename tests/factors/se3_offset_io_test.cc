// g2o's 3D landmark and prior edges with their sensor offset: EDGE_SE3_TRACKXYZ and
// EDGE_SE3_PRIOR with a parameter id naming a PARAMS_SE3OFFSET line. Round trip, the offset
// applied exactly (chi2 as g2o defines it), and every refused line (a small graph solved:
// tests/solvers/factor_solves_test.cc).
#include <gtest/gtest.h>

#include <random>
#include <sstream>
#include <string>

#include "testing/read_text.h"
#include "tether/core/graph_io.h"
#include "tether/factors/builtin.h"
#include "tether/factors/pose_point.h"
#include "tether/factors/prior.h"

namespace tether {
namespace {

GraphFile Read(const std::string& text) { return testing::ReadText(text, "o.g2o"); }

std::string ReadError(const std::string& text) { return testing::ReadTextError(text, "o.g2o"); }

std::string Written(const GraphFile& g) {
  std::ostringstream out;
  WriteG2o(out, g.values, g.graph, DefaultRegistry());
  return out.str();
}

std::size_t Count(const std::string& s, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t at = s.find(what); at != std::string::npos; at = s.find(what, at + 1)) ++n;
  return n;
}

const char* kIdentityLine = "PARAMS_SE3OFFSET 0 0 0 0 0 0 0 1\n";

const std::string kPrior21 = " 100 0 0 0 0 0 100 0 0 0 0 100 0 0 0 400 0 0 400 0 400";

TEST(Se3OffsetIoTest, IdentityOffsetRoundTripsBitForBit) {
  const std::string text = std::string("PARAMS_SE3OFFSET 4 0 0 0 0 0 0 1\n") +
                           "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\n"
                           "VERTEX_SE3:QUAT 1 1 0.1 0 0 0 0.0998334166468282 0.9950041652780258\n"
                           "VERTEX_TRACKXYZ 9 2 3 4\n"
                           "EDGE_SE3:QUAT 0 1 1 0.1 0 0 0 0.0998334166468282 0.9950041652780258" +
                           " 100 0 0 0 0 0 100 0 0 0 0 100 0 0 0 400 0 0 400 0 400\n" +
                           "EDGE_SE3_TRACKXYZ 0 9 4 2 3 4.0000000000000009 10 1 0 20 2 30\n" +
                           "EDGE_SE3_TRACKXYZ 1 9 4 1.3 2.9 3.9 10 0 0 10 0 10\n" + "EDGE_SE3_PRIOR 0 4 0 0 0 0 0 0 1" +
                           kPrior21 + "\n";
  const GraphFile g = Read(text);
  ASSERT_EQ(g.graph.size(), 4u);
  EXPECT_EQ(g.graph.at(1).type_name(), "PosePoint3");
  EXPECT_EQ(g.graph.at(3).type_name(), "PriorSE3");
  EXPECT_EQ(g.graph.at(1).Measurement(), (std::vector<double>{2, 3, 4.0000000000000009}));
  EXPECT_EQ(g.graph.at(1).noise().Information()(0, 1), 1);
  EXPECT_EQ(g.loop_closures, 0);
  const std::string out = Written(g);
  // The parameter line first, once; every edge refers to it by id 0.
  EXPECT_EQ(out.rfind(kIdentityLine, 0), 0u) << out;
  EXPECT_EQ(Count(out, "PARAMS_SE3OFFSET"), 1u) << out;
  EXPECT_NE(out.find("EDGE_SE3_TRACKXYZ 0 9 0 2 3 4.000000000000001 10 1 0 20 2 30\n"), std::string::npos) << out;
  EXPECT_NE(out.find("EDGE_SE3_PRIOR 0 0 0 0 0 0 0 0 1" + kPrior21 + "\n"), std::string::npos) << out;
  const GraphFile h = Read(out);
  ASSERT_EQ(h.graph.size(), g.graph.size());
  for (std::size_t i = 0; i < g.graph.size(); ++i) {
    EXPECT_EQ(h.graph.at(i).type_name(), g.graph.at(i).type_name());
    EXPECT_EQ(h.graph.at(i).keys(), g.graph.at(i).keys());
    EXPECT_EQ(h.graph.at(i).noise().Information(), g.graph.at(i).noise().Information());
    const std::vector<double> a = g.graph.at(i).Measurement(), b = h.graph.at(i).Measurement();
    ASSERT_EQ(a.size(), b.size());
    // The quaternion of EDGE_SE3:QUAT is normalised again on reading: its last bits may move.
    for (std::size_t j = 0; j < a.size(); ++j) {
      if (i == 0) {
        EXPECT_NEAR(a[j], b[j], 1e-15);
      } else {
        EXPECT_EQ(a[j], b[j]);
      }
    }
  }
  // A graph without such edges gets no parameter line.
  FactorGraph none;
  std::ostringstream plain;
  WriteG2o(plain, g.values, none, DefaultRegistry());
  EXPECT_EQ(plain.str().find("PARAMS"), std::string::npos);
}

TEST(Se3OffsetIoTest, TrackXyzAppliesAnOffsetExactly) {
  // g2o: e = (X P)^-1 l - z, chi2 = e^T Omega e. The factor read must give that chi2 at any
  // estimate, and so must the graph written back (with the identity offset).
  const SE3d offset(Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, -1).normalized())),
                    Eigen::Vector3d(0.3, -0.2, 1.1));
  double p[7];
  offset.ToParams(p);
  std::string line = "PARAMS_SE3OFFSET 2";
  for (double v : p) line += " " + FormatDouble(v);
  const std::string text = line +
                           "\nVERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nVERTEX_TRACKXYZ 5 1 2 3\n"
                           "EDGE_SE3_TRACKXYZ 0 5 2 0.5 -1 2 10 1 2 20 3 30\n";
  const GraphFile g = Read(text);
  const GraphFile back = Read(Written(g));
  Eigen::Matrix3d omega;
  omega << 10, 1, 2, 1, 20, 3, 2, 3, 30;
  const Eigen::Vector3d z(0.5, -1, 2);
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 20; ++i) {
    Values v;
    const SE3d x(Eigen::Quaterniond(Eigen::AngleAxisd(3 * u(rng), Eigen::Vector3d(u(rng), u(rng), 1).normalized())),
                 Eigen::Vector3d(u(rng), u(rng), u(rng)));
    const Eigen::Vector3d l(5 * u(rng), 5 * u(rng), 5 * u(rng));
    v.Insert(0, x);
    v.Insert(5, l);
    const Eigen::Vector3d e = (x * offset).Inverse() * l - z;
    const double chi2 = e.dot(omega * e);
    EXPECT_NEAR(g.graph.at(0).Chi2(v), chi2, 1e-9 * (1 + chi2));
    EXPECT_NEAR(back.graph.at(0).Chi2(v), chi2, 1e-9 * (1 + chi2));
  }
}

TEST(Se3OffsetIoTest, EdgesWithoutVerticesAreInitialisedThroughTheOffset) {
  const GraphFile g =
      Read(std::string(kIdentityLine) + "PARAMS_SE3OFFSET 3 1 0 0 0 0 0.7071067811865476 0.7071067811865476\n" +
           "EDGE_SE3_PRIOR 0 0 0 0 0 0 0 0 1" + kPrior21 + "\n" + "EDGE_SE3_TRACKXYZ 0 7 3 2 0 0 10 0 0 10 0 10\n");
  // The sensor sits 1 m ahead, turned 90 degrees left: 2 m ahead of it is (1, 2, 0).
  EXPECT_LT((g.values.At<Eigen::Vector3d>(7) - Eigen::Vector3d(1, 2, 0)).norm(), 1e-12);
}

TEST(Se3OffsetIoTest, ErrorsNameFileLineAndField) {
  const std::string v = "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nVERTEX_TRACKXYZ 5 1 2 3\n";
  EXPECT_EQ(ReadError(v + "EDGE_SE3_TRACKXYZ 0 5 7 1 2 3 1 0 0 1 0 1\n"),
            "o.g2o:3: EDGE_SE3_TRACKXYZ field 3 names parameter 7, which no PARAMS_SE3OFFSET line above it defines; "
            "add 'PARAMS_SE3OFFSET 7 0 0 0 0 0 0 1' (a sensor at the robot's origin) before this line, or fix the id");
  // Defined below its first use: g2o needs it above too.
  EXPECT_NE(ReadError(v + "EDGE_SE3_TRACKXYZ 0 5 0 1 2 3 1 0 0 1 0 1\n" + kIdentityLine)
                .find("o.g2o:3: EDGE_SE3_TRACKXYZ field 3 names parameter 0, which no PARAMS_SE3OFFSET line above"),
            std::string::npos);
  EXPECT_EQ(ReadError(std::string(kIdentityLine) + v + "PARAMS_SE3OFFSET 0 1 0 0 0 0 0 1\n"),
            "o.g2o:4: duplicate parameter id 0: line 1 defines it already (PARAMS_SE3OFFSET); remove one of the two "
            "lines or renumber one");
  EXPECT_NE(ReadError("PARAMS_SE3OFFSET 0 1 2 3 0 0 0 0\n" + v)
                .find("o.g2o:1: PARAMS_SE3OFFSET quaternion (qx qy qz qw, fields 5 to 8) is zero"),
            std::string::npos);
  EXPECT_NE(ReadError("PARAMS_SE3OFFSET 0 1 2 3 0 0 0\n" + v)
                .find("o.g2o:1: too few fields: PARAMS_SE3OFFSET needs 8 after the tag (id x y z qx qy qz qw)"),
            std::string::npos);
  EXPECT_NE(ReadError("PARAMS_SE3OFFSET 0 1 2 x 0 0 0 1\n" + v)
                .find("o.g2o:1: PARAMS_SE3OFFSET field 4 ('x') is not a number"),
            std::string::npos);
  EXPECT_NE(ReadError("PARAMS_SE3OFFSET -1 0 0 0 0 0 0 1\n" + v).find("o.g2o:1: PARAMS_SE3OFFSET field 1 ('-1')"),
            std::string::npos);
  const std::string few = ReadError(std::string(kIdentityLine) + v + "EDGE_SE3_TRACKXYZ 0 5 0 1 2 3 1 0 0 1 0\n");
  EXPECT_NE(few.find("o.g2o:4: too few fields: EDGE_SE3_TRACKXYZ needs 12 after the tag (pose point offset_id x y z "
                     "I11 I12 I13 I22 I23 I33)"),
            std::string::npos)
      << few;
  const std::string offset_prior =
      ReadError("PARAMS_SE3OFFSET 2 0 0 1 0 0 0 1\n" + v + "EDGE_SE3_PRIOR 0 2 0 0 0 0 0 0 1" + kPrior21 + "\n");
  EXPECT_NE(offset_prior.find("o.g2o:4: EDGE_SE3_PRIOR field 2 names parameter 2, a sensor offset (PARAMS_SE3OFFSET "
                              "at line 1) that is not the identity"),
            std::string::npos)
      << offset_prior;
  const std::string zero_q =
      ReadError(std::string(kIdentityLine) + v + "EDGE_SE3_PRIOR 0 0 0 0 0 0 0 0 0" + kPrior21 + "\n");
  EXPECT_NE(zero_q.find("o.g2o:4: EDGE_SE3_PRIOR: quaternion of the measurement is zero"), std::string::npos) << zero_q;
  const std::string indefinite =
      ReadError(std::string(kIdentityLine) + v + "EDGE_SE3_TRACKXYZ 0 5 0 1 2 3 1 5 0 1 0 1\n");
  EXPECT_NE(indefinite.find("o.g2o:4: EDGE_SE3_TRACKXYZ"), std::string::npos) << indefinite;
  EXPECT_NE(indefinite.find("--repair-information"), std::string::npos) << indefinite;
  const std::string swapped = ReadError(std::string(kIdentityLine) + v + "EDGE_SE3_TRACKXYZ 5 0 0 1 2 3 1 0 0 1 0 1\n");
  EXPECT_NE(swapped.find("o.g2o:4: id 5 is used here as SE3"), std::string::npos) << swapped;
}

}  // namespace
}  // namespace tether
