// Landmark files: iSAM's text format (ODOMETRY, EDGE2, LANDMARK with square-root information)
// and TORO's BR lines. How the format is recognised, the landmark key rule, the noise readings,
// the round trip through g2o, and an error naming file, line and field for every malformed line.
#include <gtest/gtest.h>

#include <cmath>
#include <sstream>
#include <string>

#include "testing/read_text.h"
#include "tether/core/graph_io.h"
#include "tether/factors/builtin.h"
#include "tether/factors/range_bearing.h"

namespace tether {
namespace {

constexpr Key kOffset = 1000000000;

GraphFile Read(const std::string& text, const std::string& name = "l.txt", const ReadOptions& options = {}) {
  return testing::ReadText(text, name, options);
}

std::string ReadError(const std::string& text, const std::string& name = "l.txt", const ReadOptions& options = {}) {
  return testing::ReadTextError(text, name, options);
}

#define EXPECT_CONTAINS(haystack, needle)                                                       \
  do {                                                                                          \
    const std::string h_ = (haystack);                                                          \
    EXPECT_NE(h_.find(needle), std::string::npos) << "missing: " << (needle) << "\nin: " << h_; \
  } while (0)

const char* kIsam =
    "EDGE2 0 1 1 0 0.1 2 1 0 3 0 4\n"
    "ODOMETRY 1 2 1 0.5 -0.2 10 0 0 10 0 20\n"
    "LANDMARK 1 0 2 3 2 1 3\n"
    "LANDMARK 2 0 1 3.5 2 0 2\n"
    "LANDMARK 0 7 -1 2 5 0 5\n";

TEST(LandmarkFilesTest, IsamLinesBecomePoseAndLandmarkFactors) {
  const GraphFile g = Read(kIsam);
  ASSERT_EQ(g.graph.size(), 5u);
  EXPECT_EQ(g.graph.at(0).type_name(), "BetweenSE2");
  EXPECT_EQ(g.graph.at(1).type_name(), "BetweenSE2");
  EXPECT_EQ(g.graph.at(2).type_name(), "PosePoint2");
  // Landmark 0 and pose 0 are different variables: the landmark's key is offset.
  EXPECT_EQ(g.graph.at(2).keys(), (std::vector<Key>{1, kOffset}));
  EXPECT_EQ(g.values.TypeOf(0), VarType::kSE2);
  EXPECT_EQ(g.values.TypeOf(kOffset), VarType::kPoint2);
  EXPECT_EQ(g.values.TypeOf(kOffset + 7), VarType::kPoint2);
  // The numbers are the upper triangle of R, row by row; the information is R^T R.
  Eigen::Matrix3d r;
  r << 2, 1, 0, 0, 3, 0, 0, 0, 4;
  EXPECT_EQ(g.graph.at(0).noise().Information(), Eigen::MatrixXd(r.transpose() * r));
  Eigen::Matrix2d rl;
  rl << 2, 1, 0, 3;
  EXPECT_EQ(g.graph.at(2).noise().Information(), Eigen::MatrixXd(rl.transpose() * rl));
  EXPECT_EQ(g.graph.at(2).Measurement(), (std::vector<double>{2, 3}));
  // Everything was initialised from the edges (iSAM files have no vertices): landmark 0 from pose 1.
  EXPECT_EQ(g.initialised_by_spanning_tree, 5);
  EXPECT_EQ(g.loop_closures, 0);
}

TEST(LandmarkFilesTest, FormatIsRecognisedByContentNameAndOption) {
  // Auto: the LANDMARK line makes the file iSAM, so the EDGE2 line before it is read with iSAM's
  // layout (as TORO's, 2 1 0 3 0 4 would be I11=2 I12=1 I22=0 I33=3: not positive definite).
  EXPECT_EQ(Read(kIsam).graph.at(0).noise().Information()(1, 1), 10);
  // FileFormat::kIsam without any iSAM-only line.
  ReadOptions isam;
  isam.format = FileFormat::kIsam;
  EXPECT_EQ(Read("EDGE2 0 1 1 0 0 2 1 0 3 0 4\n", "l.txt", isam).graph.at(0).noise().Information()(1, 1), 10);
  // Without one, EDGE2 is TORO's; so it is in a .graph file or with FileFormat::kToro.
  const std::string toro_edge = "EDGE2 0 1 1 0 0 10 1 20 30 2 3\n";
  EXPECT_EQ(Read(toro_edge).graph.at(0).noise().Information()(0, 2), 2);
  EXPECT_EQ(Read(toro_edge + "LANDMARK 1 3 1 1 1 0 1\n", "l.graph").graph.at(0).noise().Information()(0, 2), 2);
  ReadOptions toro;
  toro.format = FileFormat::kToro;
  EXPECT_EQ(Read(toro_edge + "LANDMARK 1 3 1 1 1 0 1\n", "l.txt", toro).graph.at(0).noise().Information()(0, 2), 2);
  // g2o: iSAM tags are unknown, with a hint.
  ReadOptions g2o;
  g2o.format = FileFormat::kG2o;
  EXPECT_CONTAINS(ReadError("LANDMARK 1 3 1 1 1 0 1\n", "l.txt", g2o), "l.txt:1: unknown tag 'LANDMARK'; known tags: ");
  EXPECT_CONTAINS(ReadError("ODOMETRY 0 1 1 0 0 1 0 0 1 0 1\n", "l.txt", g2o),
                  "it is an iSAM tag: read the file as iSAM (FileFormat::kIsam or FileFormat::kAuto)");
  EXPECT_CONTAINS(ReadError("BR 0 1 0.5 2 0.1 0.1\n", "l.txt", g2o), "it is a TORO tag");
}

TEST(LandmarkFilesTest, LateIsamLineAfterTorosEdge2IsAnError) {
  // Over 64 KiB of EDGE2 lines read as TORO's, then a LANDMARK: refused, never mixed silently.
  std::string text;
  for (int i = 0; text.size() < (1 << 16) + 100; ++i) {
    text += "EDGE2 " + std::to_string(i) + " " + std::to_string(i + 1) + " 1 0 0 10 0 10 10 0 0\n";
  }
  const std::size_t lines = static_cast<std::size_t>(std::count(text.begin(), text.end(), '\n'));
  const std::string m = ReadError(text + "LANDMARK 0 1 1 1 1 0 1\n");
  EXPECT_CONTAINS(m, "l.txt:" + std::to_string(lines + 1) +
                         ": LANDMARK is a tag of iSAM's format, whose EDGE2 lists the information otherwise than "
                         "TORO's, but line 1 was read as a TORO EDGE2");
  EXPECT_CONTAINS(m, "FileFormat::kIsam");
  // A late iSAM line without EDGE2 before it is fine.
  EXPECT_NO_THROW(Read(std::string((1 << 16) + 10, '#') + "\nODOMETRY 0 1 1 0 0 1 0 0 1 0 1\n"));
}

TEST(LandmarkFilesTest, CovarianceReading) {
  ReadOptions cov;
  cov.isam_noise = IsamNoise::kCovariance;
  const GraphFile g = Read("ODOMETRY 0 1 1 0 0 0.0001 0 0 4e-06 0 4e-06\nLANDMARK 1 5 2 3 0.4 0.1 0.4\n", "v.txt", cov);
  const Eigen::MatrixXd omega = g.graph.at(0).noise().Information();
  EXPECT_NEAR(omega(0, 0), 1e4, 1e-8);
  EXPECT_NEAR(omega(2, 2), 2.5e5, 1e-6);
  Eigen::Matrix2d c;
  c << 0.4, 0.1, 0.1, 0.4;
  EXPECT_LT((g.graph.at(1).noise().Information() - Eigen::MatrixXd(c.inverse())).norm(), 1e-12);
  EXPECT_CONTAINS(ReadError("LANDMARK 1 5 2 3 0.4 1 0.4\n", "v.txt", cov),
                  "v.txt:1: LANDMARK: the covariance (fields 5 to 7, read as a covariance: IsamNoise::kCovariance) "
                  "is not usable: ");
  // Read as iSAM's, the option is used and nothing is said; on a file that is not iSAM's it
  // changes nothing, and the reader says so.
  EXPECT_TRUE(g.warnings.empty());
  const GraphFile g2o = Read("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n", "p.g2o", cov);
  ASSERT_EQ(g2o.warnings.size(), 1u);
  EXPECT_CONTAINS(g2o.warnings[0], "p.g2o: the iSAM noise reading 'covariance' changed nothing");
  EXPECT_TRUE(
      Read("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n", "p.g2o").warnings.empty());
}

TEST(LandmarkFilesTest, ToroBearingRangeLines) {
  const std::string text =
      "VERTEX2 0 0 0 0\n"
      "VERTEX2 1 1 0 0.5\n"
      "EDGE2 0 1 1 0 0.5 10 0 10 20 0 0\n"
      "BR 0 0 0.7853981633974483 2.8284271247461903 0.05 0.2\n"
      "BR 1 0 1.0 2.0 0.05 0.2\n";
  const GraphFile g = Read(text, "e.graph");
  ASSERT_EQ(g.graph.size(), 3u);
  const auto* br = dynamic_cast<const RangeBearing2*>(&g.graph.at(1));
  ASSERT_NE(br, nullptr);
  EXPECT_EQ(br->keys(), (std::vector<Key>{0, kOffset}));
  EXPECT_EQ(br->range(), 2.8284271247461903);
  EXPECT_EQ(br->bearing(), 0.7853981633974483);
  // Residual (range, bearing): information diag(1/sigma_range^2, 1/sigma_bearing^2).
  EXPECT_NEAR(br->noise().Information()(0, 0), 25, 1e-12);
  EXPECT_NEAR(br->noise().Information()(1, 1), 400, 1e-9);
  // The landmark has no vertex line and needs none: it is placed from the first pose seeing it.
  EXPECT_EQ(g.initialised_by_spanning_tree, 1);
  EXPECT_LT((g.values.At<Eigen::Vector2d>(kOffset) - Eigen::Vector2d(2, 2)).norm(), 1e-12);
  // A pose without its vertex line is still an error in a file that has them.
  EXPECT_CONTAINS(ReadError(text + "BR 2 0 1.0 2.0 0.05 0.2\n", "e.graph"),
                  "e.graph:6: BR uses id 2, which has no vertex line");
}

TEST(LandmarkFilesTest, WrittenAsG2oAndReadBack) {
  const GraphFile g = Read(std::string(kIsam) + "", "l.txt");
  std::ostringstream out;
  WriteG2o(out, g.values, g.graph, DefaultRegistry());
  EXPECT_CONTAINS(out.str(), "VERTEX_XY 1000000000 ");
  EXPECT_CONTAINS(out.str(), "EDGE_SE2_XY 1 1000000000 2 3 4 2 10\n");
  const GraphFile h = Read(out.str(), "l.g2o");
  ASSERT_EQ(h.graph.size(), g.graph.size());
  for (std::size_t i = 0; i < g.graph.size(); ++i) {
    EXPECT_EQ(h.graph.at(i).keys(), g.graph.at(i).keys());
    EXPECT_EQ(h.graph.at(i).Measurement(), g.graph.at(i).Measurement());
    EXPECT_EQ(h.graph.at(i).noise().Information(), g.graph.at(i).noise().Information());
  }
  EXPECT_EQ(h.values.keys(), g.values.keys());
}

TEST(LandmarkFilesTest, OdometryIsNeverALoopClosure) {
  // Victoria Park's pose ids skip the numbers its landmarks use: ODOMETRY 4 6 is odometry.
  const GraphFile g = Read("ODOMETRY 4 6 1 0 0 1 0 0 1 0 1\nEDGE2 6 9 1 0 0 1 0 0 1 0 1\n");
  EXPECT_FALSE(g.graph.at(0).loop_closure());
  EXPECT_TRUE(g.graph.at(1).loop_closure());
  EXPECT_EQ(g.loop_closures, 1);
}

TEST(LandmarkFilesTest, LandmarkKeyOffsetIsAnOption) {
  ReadOptions o;
  o.landmark_key_offset = 100;
  const GraphFile g = Read("ODOMETRY 0 1 1 0 0 1 0 0 1 0 1\nLANDMARK 1 5 1 1 1 0 1\n", "l.txt", o);
  EXPECT_EQ(g.graph.at(1).keys(), (std::vector<Key>{1, 105}));
  // A pose id that meets a landmark key is refused naming the rule.
  EXPECT_CONTAINS(ReadError("LANDMARK 0 5 1 1 1 0 1\nODOMETRY 0 105 1 0 0 1 0 0 1 0 1\n", "l.txt", o),
                  "l.txt:2: id 105 is used here as SE2 (ODOMETRY), but line 1 (LANDMARK) made it Point2");
  EXPECT_CONTAINS(ReadError("LANDMARK 0 5 1 1 1 0 1\nODOMETRY 0 105 1 0 0 1 0 0 1 0 1\n", "l.txt", o),
                  "(the ids of LANDMARK and BR landmarks are offset by 100: ReadOptions::landmark_key_offset)");
  EXPECT_CONTAINS(ReadError("LANDMARK 0 18446744073709551615 1 1 1 0 1\n"),
                  "l.txt:1: LANDMARK field 2: landmark id 18446744073709551615 plus the landmark key offset "
                  "1000000000 passes the largest key");
}

TEST(LandmarkFilesTest, EveryMalformedLineNamesFileLineAndField) {
  const std::string odo = "ODOMETRY 0 1 1 0 0 1 0 0 1 0 1\n";
  EXPECT_EQ(ReadError("ODOMETRY 0 1 1 0 0 1 0 0 1 0\n"),
            "l.txt:1: too few fields: ODOMETRY needs 11 after the tag (id1 id2 dx dy dtheta R11 R12 R13 R22 R23 R33 "
            "(square-root information, upper triangle row by row, iSAM's layout)), found 10; fix or remove the line");
  EXPECT_CONTAINS(ReadError("ODOMETRY 0 1 1 0 0 1 0 0 1 0 1 7\n"), "l.txt:1: too many fields: ODOMETRY needs 11");
  EXPECT_EQ(ReadError("ODOMETRY 0 1 1 0 zero 1 0 0 1 0 1\n"),
            "l.txt:1: ODOMETRY field 5 ('zero') is not a number; fix or remove the line");
  EXPECT_CONTAINS(ReadError("ODOMETRY 0 -1 1 0 0 1 0 0 1 0 1\n"), "l.txt:1: ODOMETRY field 2 ('-1') is a negative id");
  EXPECT_CONTAINS(ReadError("ODOMETRY 0 1 1 0 0 1 0 0 1 0 nan\n"), "l.txt:1: ODOMETRY field 11 ('nan') is NaN");
  EXPECT_EQ(ReadError("ODOMETRY 0 1 1 0 0 1 0 0 0 0 1\n"),
            "l.txt:1: ODOMETRY field 9 (R22, a diagonal entry of the square-root information) is 0, so the "
            "information R^T R is singular; fix or remove the line");
  EXPECT_CONTAINS(ReadError("ODOMETRY 3 3 1 0 0 1 0 0 1 0 1\n"), "l.txt:1: ODOMETRY connects id 3 to itself");
  EXPECT_CONTAINS(ReadError(odo + "EDGE2 1 2 1 0 0 1 0 0 1 0 0\n"), "l.txt:2: EDGE2 field 11 (R33, a diagonal");
  EXPECT_CONTAINS(ReadError(odo + "EDGE2 1 2 1 0 0 1 0 0 1 0\n"), "l.txt:2: too few fields: EDGE2 needs 11");
  EXPECT_EQ(ReadError(odo + "LANDMARK 1 4 2 3 1 0\n"),
            "l.txt:2: too few fields: LANDMARK needs 7 after the tag (pose landmark dx dy R11 R12 R22 (square-root "
            "information, upper triangle row by row)), found 6; fix or remove the line");
  EXPECT_EQ(ReadError(odo + "LANDMARK 1 4 2 3 0 0 1\n"),
            "l.txt:2: LANDMARK field 5 (R11, a diagonal entry of the square-root information) is 0, so the "
            "information R^T R is singular; fix or remove the line");
  EXPECT_CONTAINS(ReadError(odo + "LANDMARK 1 x 2 3 1 0 1\n"), "l.txt:2: LANDMARK field 2 ('x') is not an id");
  EXPECT_CONTAINS(ReadError(odo + "LANDMARK 1 4 2 inf 1 0 1\n"), "l.txt:2: LANDMARK field 4 ('inf') is inf");
  // A LANDMARK whose pose is a landmark elsewhere (here through another rule: a vertex line).
  EXPECT_CONTAINS(ReadError("VERTEX_XY 1 0 0\n" + odo), "l.txt:2: id 1 is used here as SE2 (ODOMETRY)");
  // TORO BR.
  const std::string v = "VERTEX2 0 0 0 0\n";
  EXPECT_EQ(ReadError(v + "BR 0 4 0.5 2 0.1\n", "e.graph"),
            "e.graph:2: too few fields: BR needs 6 after the tag (pose landmark bearing range sigma_bearing "
            "sigma_range), found 5; fix or remove the line");
  EXPECT_EQ(ReadError(v + "BR 0 4 0.5 -2 0.1 0.1\n", "e.graph"),
            "e.graph:2: BR range (field 4) is -2; a range is a positive distance (at range 0 the landmark has no "
            "bearing); fix or remove the line");
  EXPECT_EQ(ReadError(v + "BR 0 4 0.5 0 0.1 0.1\n", "e.graph"),
            "e.graph:2: BR range (field 4) is 0; a range is a positive distance (at range 0 the landmark has no "
            "bearing); fix or remove the line");
  EXPECT_EQ(ReadError(v + "BR 0 4 0.5 2 0 0.1\n", "e.graph"),
            "e.graph:2: BR sigma_bearing (field 5) is 0; a standard deviation must be positive; fix or remove the "
            "line");
  EXPECT_EQ(ReadError(v + "BR 0 4 0.5 2 0.1 -1\n", "e.graph"),
            "e.graph:2: BR sigma_range (field 6) is -1; a standard deviation must be positive; fix or remove the "
            "line");
  EXPECT_CONTAINS(ReadError(v + "BR 0 4 0.5 2 1e-300 0.1\n", "e.graph"), "e.graph:2: BR");
  EXPECT_CONTAINS(ReadError(v + "BR 0 4 nan 2 0.1 0.1\n", "e.graph"), "e.graph:2: BR field 3 ('nan') is NaN");
  EXPECT_CONTAINS(ReadError(v + "BR 0 4 0.5 2 0.1 0.1 9\n", "e.graph"), "e.graph:2: too many fields: BR needs 6");
}

}  // namespace
}  // namespace tether
