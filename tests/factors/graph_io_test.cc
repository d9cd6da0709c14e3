#include "tether/core/graph_io.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "tether/factors/between_se2.h"
#include "tether/factors/between_se3.h"
#include "tether/factors/builtin.h"
#include "tether/factors/pose_point.h"
#include "tether/factors/prior.h"

namespace tether {
namespace {

namespace fs = std::filesystem;

#define EXPECT_CONTAINS(text, part) EXPECT_NE(std::string(text).find(part), std::string::npos) << (text)

template <typename E, typename Fn>
std::string ErrorOf(Fn fn) {
  try {
    fn();
  } catch (const E& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected an exception";
  return "";
}

GraphFile Read(const std::string& text, const std::string& name = "t.g2o", const ReadOptions& options = {},
               const Registry& registry = DefaultRegistry()) {
  std::istringstream in(text);
  return ReadGraph(in, name, registry, options);
}

std::string ReadError(const std::string& text, const std::string& name = "t.g2o", const ReadOptions& options = {}) {
  return ErrorOf<ParseError>([&] { Read(text, name, options); });
}

ReadOptions Repair(InformationRepair r) {
  ReadOptions o;
  o.repair = r;
  return o;
}

ReadOptions Partial() {
  ReadOptions o;
  o.allow_partial_vertices = true;
  return o;
}

ReadOptions Format(FileFormat f) {
  ReadOptions o;
  o.format = f;
  return o;
}

void ExpectSE2Near(const SE2d& a, const SE2d& b, double tol = 1e-12) {
  EXPECT_NEAR(a.x(), b.x(), tol);
  EXPECT_NEAR(a.y(), b.y(), tol);
  EXPECT_NEAR(std::remainder(a.theta() - b.theta(), 2 * M_PI), 0.0, tol);
}

void ExpectSE3Near(const SE3d& a, const SE3d& b, double tol = 1e-12) {
  EXPECT_LT((a.translation() - b.translation()).norm(), tol);
  EXPECT_NEAR(std::abs(a.quaternion().dot(b.quaternion())), 1.0, tol);
}

// Same variables (keys, order, types, parameters), factors, measurements, information and FIX set.
void ExpectSameGraph(const GraphFile& a, const GraphFile& b, double tol) {
  ASSERT_EQ(a.values.keys(), b.values.keys());
  for (Key k : a.values.keys()) {
    ASSERT_EQ(a.values.TypeOf(k), b.values.TypeOf(k)) << k;
    const int n = AmbientDim(a.values.TypeOf(k));
    for (int i = 0; i < n; ++i) EXPECT_NEAR(a.values.Params(k)[i], b.values.Params(k)[i], tol) << "key " << k;
  }
  ASSERT_EQ(a.graph.size(), b.graph.size());
  for (std::size_t i = 0; i < a.graph.size(); ++i) {
    const Factor& fa = a.graph.at(i);
    const Factor& fb = b.graph.at(i);
    EXPECT_EQ(fa.type_name(), fb.type_name()) << i;
    EXPECT_EQ(fa.keys(), fb.keys()) << i;
    const std::vector<double> ma = fa.Measurement(), mb = fb.Measurement();
    ASSERT_EQ(ma.size(), mb.size());
    for (std::size_t j = 0; j < ma.size(); ++j) EXPECT_NEAR(ma[j], mb[j], tol * std::max(1.0, std::abs(ma[j])));
    const Eigen::MatrixXd ia = fa.noise().Information(), ib = fb.noise().Information();
    EXPECT_LE((ia - ib).norm(), tol * std::max(1.0, ia.norm())) << "factor " << i;
  }
  EXPECT_EQ(a.graph.fixed(), b.graph.fixed());
}

// A temporary folder, removed at the end of the test.
class TempDir {
 public:
  TempDir() {
    path_ = fs::temp_directory_path() /
            ("tether_graph_io_test_" + std::to_string(::getpid()) + "_" + std::to_string(counter_++));
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  std::string File(const std::string& name) const { return (path_ / name).string(); }
  std::vector<std::string> Entries() const {
    std::vector<std::string> out;
    for (const auto& e : fs::directory_iterator(path_)) out.push_back(e.path().filename().string());
    std::sort(out.begin(), out.end());
    return out;
  }
  void Write(const std::string& name, const std::string& text) const { std::ofstream(File(name)) << text; }

 private:
  static inline int counter_ = 0;
  fs::path path_;
};

const char* const kInfo3 = " 1 0 0 1 0 1";  // identity, upper triangle of a 3x3

std::string Edge(Key i, Key j, double x, double y, double th) {
  std::ostringstream s;
  s.precision(17);
  s << "EDGE_SE2 " << i << ' ' << j << ' ' << x << ' ' << y << ' ' << th << kInfo3 << "\n";
  return s.str();
}

// ---------------------------------------------------------------------------------------------
// Reading g2o

TEST(GraphIoTest, ReadsA2DGraphWithCommentsBlankLinesFixAndCarriageReturns) {
  const GraphFile g = Read(
      "# a comment\n"
      "\n"
      "VERTEX_SE2 0 0 0 0\r\n"
      "VERTEX_SE2 1 1.5 -2 0.25\n"
      "   # indented comment\n"
      "\t\n"
      "VERTEX_SE2 2 3 0 4\n"  // theta 4 is wrapped to 4 - 2 pi
      "EDGE_SE2 0 1 1.5 -2 0.25 10 1 2 20 3 30\r\n"
      "EDGE_SE2 1 2 1 0 0 1 0 0 1 0 1\n"
      "FIX 0\n");
  EXPECT_EQ(g.values.keys(), (std::vector<Key>{0, 1, 2}));
  ExpectSE2Near(g.values.At<SE2d>(1), SE2d(1.5, -2, 0.25), 0);
  EXPECT_NEAR(g.values.At<SE2d>(2).theta(), 4 - 2 * M_PI, 1e-15);
  ASSERT_EQ(g.graph.size(), 2u);
  EXPECT_EQ(g.graph.at(0).type_name(), "BetweenSE2");
  EXPECT_EQ(g.graph.at(0).keys(), (std::vector<Key>{0, 1}));
  EXPECT_EQ(g.graph.at(0).Measurement(), (std::vector<double>{1.5, -2, 0.25}));
  Eigen::Matrix3d info;
  info << 10, 1, 2, 1, 20, 3, 2, 3, 30;
  EXPECT_LT((g.graph.at(0).noise().Information() - info).norm(), 1e-12);
  EXPECT_EQ(g.graph.fixed(), (std::set<Key>{0}));
  EXPECT_TRUE(g.warnings.empty());
  EXPECT_EQ(g.repaired_informations, 0);
  EXPECT_EQ(g.initialised_by_spanning_tree, 0);
}

TEST(GraphIoTest, LoopClosuresAreEdgesBetweenPosesWhoseIdsAreNotConsecutive) {
  const std::string text =
      "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nVERTEX_SE2 2 2 0 0\nVERTEX_SE2 3 3 0 0\n"
      "VERTEX_XY 7 1 1\n"
      "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n"
      "EDGE_SE2 2 1 -1 0 0 1 0 0 1 0 1\n"  // consecutive, written backwards
      "EDGE_SE2 1 2 1 0 0 1 0 0 1 0 1\n"
      "EDGE_SE2 2 3 1 0 0 1 0 0 1 0 1\n"
      "EDGE_SE2 0 2 2 0 0 1 0 0 1 0 1\n"   // loop closure
      "EDGE_SE2 3 0 -3 0 0 1 0 0 1 0 1\n"  // loop closure
      "EDGE_SE2_XY 3 7 -2 1 1 0 1\n";      // a landmark: never a loop closure
  const GraphFile g = Read(text);
  EXPECT_EQ(g.loop_closures, 2);
  std::vector<bool> marked;
  for (std::size_t i = 0; i < g.graph.size(); ++i) marked.push_back(g.graph.at(i).loop_closure());
  EXPECT_EQ(marked, (std::vector<bool>{false, false, false, false, true, true, false}));
  // A copy of the graph keeps the marks; the rule kNone marks nothing.
  EXPECT_TRUE(g.graph.at(4).Clone()->loop_closure());
  ReadOptions none;
  none.loop_closures = LoopClosureRule::kNone;
  const GraphFile n = Read(text, "t.g2o", none);
  EXPECT_EQ(n.loop_closures, 0);
  for (std::size_t i = 0; i < n.graph.size(); ++i) EXPECT_FALSE(n.graph.at(i).loop_closure()) << i;
}

TEST(GraphIoTest, IgnoresAByteOrderMark) {
  const GraphFile g = Read("\xEF\xBB\xBFVERTEX_SE2 0 0 0 0\n");
  EXPECT_EQ(g.values.size(), 1u);
}

TEST(GraphIoTest, FixLinesMayNameSeveralIdsAndComeBeforeTheVertices) {
  const GraphFile g = Read("FIX 2 0\nVERTEX_SE2 0 0 0 0\nVERTEX_SE2 2 1 0 0\n" + Edge(0, 2, 1, 0, 0));
  EXPECT_EQ(g.graph.fixed(), (std::set<Key>{0, 2}));
}

TEST(GraphIoTest, ReadsSE3AndNormalisesQuaternions) {
  std::string info6;
  for (int i = 0; i < 6; ++i)
    for (int j = i; j < 6; ++j) info6 += i == j ? " 1" : " 0";
  const GraphFile g = Read(
      "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\n"
      "VERTEX_SE3:QUAT 1 1 2 3 0 0 0 1.0000001\n"
      "VERTEX_SE3:QUAT 2 1 2 3 0 0 0.6 0.8\n"
      "VERTEX_SE3:QUAT 3 1 2 3 0 0 0 2\n"
      "EDGE_SE3:QUAT 0 1 1 2 3 0 0 0 1" +
      info6 +
      "\n"
      "EDGE_SE3:QUAT 1 2 0 0 0 0 0 0.6 0.8" +
      info6 +
      "\n"
      "EDGE_SE3:QUAT 2 3 0 0 0 0 0 0 1" +
      info6 + "\n");
  EXPECT_EQ(g.values.size(), 4u);
  EXPECT_EQ(g.graph.size(), 3u);
  for (Key k = 0; k < 4; ++k) EXPECT_NEAR(g.values.At<SE3d>(k).quaternion().norm(), 1.0, 1e-15);
  EXPECT_NEAR(g.values.Params(3)[6], 1.0, 1e-15);
  EXPECT_NEAR(g.values.Params(2)[5], 0.6, 1e-15);
  EXPECT_EQ(g.values.At<SE3d>(1).translation(), Eigen::Vector3d(1, 2, 3));
  // Only the quaternion far from unit length (line 4) is reported.
  ASSERT_EQ(g.warnings.size(), 1u);
  EXPECT_CONTAINS(g.warnings[0],
                  "t.g2o: normalised quaternions that were far from unit length on 1 line VERTEX_SE3:QUAT (first at "
                  "line 4)");
  EXPECT_CONTAINS(g.warnings[0], "first at line 4");
}

TEST(GraphIoTest, ZeroQuaternionIsAnError) {
  EXPECT_EQ(ReadError("VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nVERTEX_SE3:QUAT 7 1 2 3 0 0 0 0\n"),
            "t.g2o:2: VERTEX_SE3:QUAT quaternion (qx qy qz qw) is zero; a rotation needs a unit quaternion; "
            "fix the "
            "line");
}

TEST(GraphIoTest, ReadsPoint2Landmarks) {
  const GraphFile g = Read(
      "VERTEX_SE2 0 0 0 0\n"
      "VERTEX_XY 100 2 3\n"
      "EDGE_SE2_XY 0 100 2 3 1 0 1\n"
      "EDGE_PRIOR_SE2 0 0 0 0 1 0 0 1 0 1\n");
  EXPECT_EQ(g.values.TypeOf(100), VarType::kPoint2);
  EXPECT_EQ(g.values.At<Eigen::Vector2d>(100), Eigen::Vector2d(2, 3));
  ASSERT_EQ(g.graph.size(), 2u);
  EXPECT_EQ(g.graph.at(0).type_name(), "PosePoint2");
  EXPECT_EQ(g.graph.at(1).type_name(), "PriorSE2");
}

TEST(GraphIoTest, ReadsPoint3Vertices) {
  const GraphFile g = Read(
      "PARAMS_SE3OFFSET 0 0 0 0 0 0 0 1\n"
      "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\n"
      "VERTEX_TRACKXYZ 5 1 2 3\n"
      "EDGE_SE3_TRACKXYZ 0 5 0 1 2 3 1 0 0 1 0 1\n");
  EXPECT_EQ(g.values.TypeOf(5), VarType::kPoint3);
  EXPECT_EQ(g.values.At<Eigen::Vector3d>(5), Eigen::Vector3d(1, 2, 3));
  EXPECT_EQ(g.graph.size(), 1u);
}

// ---------------------------------------------------------------------------------------------
// Errors

TEST(GraphIoTest, UnknownTagNamesFileLineTagAndKnownTags) {
  const std::string m = ReadError("VERTEX_SE2 0 0 0 0\nEDGE_FANCY 0 1 2\n");
  EXPECT_CONTAINS(m, "t.g2o:2: unknown tag 'EDGE_FANCY'; known tags: ");
  EXPECT_CONTAINS(m, "VERTEX_SE2");
  EXPECT_CONTAINS(m, "VERTEX_SE3:QUAT");
  EXPECT_CONTAINS(m, "EDGE_SE2");
  EXPECT_CONTAINS(m, "EDGE_SE3:QUAT");
  EXPECT_CONTAINS(m, "FIX");
  EXPECT_CONTAINS(m, "load the plugin that defines it");
}

TEST(GraphIoTest, TooFewAndTooManyFields) {
  EXPECT_EQ(ReadError("VERTEX_SE2 0 0 0\n"),
            "t.g2o:1: too few fields: VERTEX_SE2 needs 4 after the tag (id x y theta), found 3; fix or remove the "
            "line");
  EXPECT_EQ(ReadError("VERTEX_SE2 0 0 0 0 0\n"),
            "t.g2o:1: too many fields: VERTEX_SE2 needs 4 after the tag (id x y theta), found 5; fix or remove the "
            "line");
  EXPECT_EQ(ReadError("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 0 0 0\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0\n"),
            "t.g2o:3: too few fields: EDGE_SE2 needs 11 after the tag (id1 id2 x y theta I11 I12 I13 I22 I23 I33), "
            "found 10; fix or remove the line");
  EXPECT_CONTAINS(ReadError("VERTEX_SE3:QUAT 0 0 0 0 0 0 1\n"),
                  "t.g2o:1: too few fields: VERTEX_SE3:QUAT needs 8 after the tag (id x y z qx qy qz qw), found 7");
  EXPECT_CONTAINS(ReadError("VERTEX_XY 0 0 0 0\n"), "t.g2o:1: too many fields: VERTEX_XY needs 3");
  EXPECT_CONTAINS(ReadError("VERTEX_TRACKXYZ 0 0 0\n"), "t.g2o:1: too few fields: VERTEX_TRACKXYZ needs 4");
  EXPECT_EQ(ReadError("VERTEX_SE2 0 0 0 0\nFIX\n"),
            "t.g2o:2: FIX needs at least one id after the tag (FIX id [id ...]); fix or remove the line");
}

TEST(GraphIoTest, NonNumbersNaNAndInf) {
  EXPECT_EQ(ReadError("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 0 abc 0\n"),
            "t.g2o:2: VERTEX_SE2 field 3 ('abc') is not a number; fix or remove the line");
  EXPECT_CONTAINS(ReadError("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 0 0 0\nEDGE_SE2 0 1 1 nan 0 1 0 0 1 0 1\n"),
                  "t.g2o:3: EDGE_SE2 field 4 ('nan') is NaN");
  EXPECT_CONTAINS(ReadError("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 0 0 0\nEDGE_SE2 0 1 1 0 0 inf 0 0 1 0 1\n"),
                  "t.g2o:3: EDGE_SE2 field 6 ('inf') is inf");
  EXPECT_CONTAINS(ReadError("VERTEX_SE2 x 0 0 0\n"), "t.g2o:1: VERTEX_SE2 field 1 ('x') is not an id");
}

TEST(GraphIoTest, NonPositiveDefiniteInformationIsAnErrorUnlessRepaired) {
  const std::string text =
      "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nVERTEX_SE2 2 2 0 0\n"
      "EDGE_SE2 0 1 1 0 0 1 0 0 -0.5 0 1\n"
      "EDGE_SE2 1 2 1 0 0 1 0 0 1 0 1\n"
      "EDGE_SE2 0 2 2 0 0 1 3 0 1 0 1\n";
  EXPECT_EQ(ReadError(text),
            "t.g2o:4: EDGE_SE2: information matrix is not positive definite (smallest eigenvalue -0.5, largest 1); "
            "fix the file or pass --repair-information nearest-pd|isotropic");
  for (InformationRepair r : {InformationRepair::kNearestPD, InformationRepair::kIsotropic}) {
    const GraphFile g = Read(text, "t.g2o", Repair(r));
    EXPECT_EQ(g.repaired_informations, 2);
    EXPECT_EQ(g.graph.size(), 3u);
    ASSERT_EQ(g.warnings.size(), 1u);
    EXPECT_CONTAINS(g.warnings[0],
                    "t.g2o: repaired 2 information matrices that were not positive definite (first "
                    "at line 4) with '" +
                        std::string(ToString(r)) + "'");
  }
  const GraphFile iso = Read(text, "t.g2o", Repair(InformationRepair::kIsotropic));
  EXPECT_LT((iso.graph.at(0).noise().Information() - (1.5 / 3) * Eigen::Matrix3d::Identity()).norm(), 1e-12);
}

TEST(GraphIoTest, EdgeToAnIdWithoutVertexLineIsAnErrorWhenTheFileHasVertices) {
  const std::string text = "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\n" + Edge(0, 1, 1, 0, 0) + Edge(1, 7, 1, 0, 0);
  EXPECT_EQ(ReadError(text),
            "t.g2o:4: EDGE_SE2 uses id 7, which has no vertex line, though the file has 2 vertex lines; add the "
            "missing vertices, or initialise them from the edges (tether optimize --allow-partial-vertices, "
            "ReadOptions::allow_partial_vertices)");
  // Several missing: the first edge line is named, and the count.
  const std::string m = ReadError("VERTEX_SE2 0 0 0 0\n" + Edge(0, 1, 1, 0, 0) + Edge(1, 2, 1, 0, 0));
  EXPECT_CONTAINS(m,
                  "t.g2o:2: EDGE_SE2 uses id 1, which has no vertex line, though the file has 1 vertex line (2 "
                  "ids lack one)");
}

TEST(GraphIoTest, AllowPartialVerticesInitialisesTheMissingOnesFromEdges) {
  const std::string text = "VERTEX_SE2 0 1 2 0.5\n" + Edge(0, 1, 1, 0, 0.1) + Edge(1, 2, 0.5, 0.5, -0.2);
  const GraphFile g = Read(text, "t.g2o", Partial());
  EXPECT_EQ(g.initialised_by_spanning_tree, 2);
  EXPECT_EQ(g.values.keys(), (std::vector<Key>{0, 1, 2}));
  const SE2d x0(1, 2, 0.5);
  ExpectSE2Near(g.values.At<SE2d>(0), x0, 0);
  ExpectSE2Near(g.values.At<SE2d>(1), x0 * SE2d(1, 0, 0.1));
  ExpectSE2Near(g.values.At<SE2d>(2), x0 * SE2d(1, 0, 0.1) * SE2d(0.5, 0.5, -0.2));
}

TEST(GraphIoTest, AnIdWithTwoTypesIsAnError) {
  EXPECT_EQ(ReadError("VERTEX_SE2 0 0 0 0\nVERTEX_XY 1 0 0\n" + Edge(0, 1, 1, 0, 0)),
            "t.g2o:3: id 1 is used here as SE2 (EDGE_SE2), but line 2 (VERTEX_XY) made it Point2; one id names one "
            "variable of one type, renumber one of them");
  EXPECT_CONTAINS(ReadError(Edge(0, 1, 1, 0, 0) + "EDGE_SE2_XY 0 1 1 1 1 0 1\n"),
                  "t.g2o:2: id 1 is used here as Point2 (EDGE_SE2_XY), but line 1 (EDGE_SE2) made it SE2");
  EXPECT_CONTAINS(ReadError(Edge(0, 1, 1, 0, 0) + "VERTEX_SE3:QUAT 1 0 0 0 0 0 0 1\n"),
                  "t.g2o:2: id 1 is used here as SE3 (VERTEX_SE3:QUAT), but line 1 (EDGE_SE2) made it SE2");
}

TEST(GraphIoTest, DuplicateVertexNamesBothLines) {
  EXPECT_EQ(ReadError("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 5 0 0 0\n# c\nVERTEX_SE2 5 1 1 1\n"),
            "t.g2o:4: duplicate vertex id 5: line 2 defines it already; remove one of the two lines");
}

TEST(GraphIoTest, FixOfAnUnknownIdIsAnError) {
  EXPECT_EQ(ReadError("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 0 0 0\n" + Edge(0, 1, 1, 0, 0) + "FIX 0 9\n"),
            "t.g2o:4: FIX names id 9, which no vertex or edge uses; remove it from the FIX line or add its vertex");
}

TEST(GraphIoTest, EmptyFilesAreAnError) {
  EXPECT_EQ(ReadError(""), "t.g2o: no vertices or edges found; is this a g2o or TORO graph file?");
  EXPECT_EQ(ReadError("# only a comment\n\n   \n"),
            "t.g2o: no vertices or edges found; is this a g2o or TORO graph file?");
}

TEST(GraphIoTest, SelfLoopIsAnError) {
  EXPECT_EQ(ReadError("VERTEX_SE2 3 0 0 0\n" + Edge(3, 3, 1, 0, 0)),
            "t.g2o:2: EDGE_SE2 connects id 3 to itself; fix or remove the line");
}

TEST(GraphIoTest, DisconnectedGraphListsThePieces) {
  const std::string text =
      "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 0 0 0\nVERTEX_SE2 2 0 0 0\nVERTEX_SE2 5 0 0 0\n"
      "VERTEX_SE2 6 0 0 0\nVERTEX_SE2 9 0 0 0\nVERTEX_SE2 40 0 0 0\nVERTEX_SE2 41 0 0 0\n"
      "VERTEX_SE2 42 0 0 0\nVERTEX_SE2 43 0 0 0\n" +
      Edge(0, 1, 1, 0, 0) + Edge(1, 2, 1, 0, 0) + Edge(5, 6, 1, 0, 0) + Edge(40, 41, 1, 0, 0) + Edge(41, 42, 1, 0, 0) +
      Edge(43, 42, 1, 0, 0);
  EXPECT_EQ(ReadError(text),
            "t.g2o: the graph falls into 4 disconnected pieces: 4 variables from id 40, 3 variables from id 0, 2 "
            "variables from id 5, 1 variable from id 9; nothing ties the pieces to each other, so their relative "
            "placement is undetermined. Add edges that link them, or split the file into one graph per piece");
}

TEST(GraphIoTest, DisconnectedGraphListsAtMostFivePieces) {
  std::string text;
  for (Key p = 0; p < 7; ++p) text += Edge(10 * p, 10 * p + 1, 1, 0, 0);
  const std::string m = ReadError(text);
  EXPECT_CONTAINS(m,
                  "t.g2o: the graph falls into 7 disconnected pieces: 2 variables from id 0, 2 variables from id "
                  "10, 2 variables from id 20, 2 variables from id 30, 2 variables from id 40, and 2 more; ");
  EXPECT_EQ(m.find("id 50"), std::string::npos) << m;
}

// ---------------------------------------------------------------------------------------------
// Edges-only files and the spanning tree

TEST(GraphIoTest, EdgesOnlyFileIsInitialisedByComposingAlongASpanningTree) {
  const SE2d z01(1, 0.1, 0.2), z12(0.8, -0.3, 0.5), z23(1.2, 0.4, -0.1), z30(-2, 1, 2.5);
  // Written out of key order on purpose; key 0 is the anchor (lowest id).
  const std::string text = Edge(1, 2, z12.x(), z12.y(), z12.theta()) + Edge(0, 1, z01.x(), z01.y(), z01.theta()) +
                           Edge(2, 3, z23.x(), z23.y(), z23.theta()) + Edge(3, 0, z30.x(), z30.y(), z30.theta());
  const GraphFile g = Read(text);
  EXPECT_EQ(g.initialised_by_spanning_tree, 4);  // the anchor and the three others
  EXPECT_EQ(g.values.keys(), (std::vector<Key>{0, 1, 2, 3}));
  ExpectSE2Near(g.values.At<SE2d>(0), SE2d(), 0);
  // Breadth first from 0: 1 through edge 0-1, 3 through edge 3-0 (inverted), 2 through 1-2.
  ExpectSE2Near(g.values.At<SE2d>(1), z01);
  ExpectSE2Near(g.values.At<SE2d>(3), z30.Inverse());
  ExpectSE2Near(g.values.At<SE2d>(2), z01 * z12);
  // The tree edges are satisfied exactly.
  EXPECT_NEAR(g.graph.at(0).Chi2(g.values), 0, 1e-20);
  EXPECT_NEAR(g.graph.at(1).Chi2(g.values), 0, 1e-20);
  EXPECT_NEAR(g.graph.at(3).Chi2(g.values), 0, 1e-20);
}

TEST(GraphIoTest, EdgesOnlySE3File) {
  std::string info6;
  for (int i = 0; i < 6; ++i)
    for (int j = i; j < 6; ++j) info6 += i == j ? " 1" : " 0";
  const SE3d z01(Eigen::Quaterniond(0.9, 0.1, 0.2, 0.3), Eigen::Vector3d(1, 2, 3));
  const SE3d z12(Eigen::Quaterniond(0.5, -0.5, 0.5, 0.5), Eigen::Vector3d(-1, 0.5, 0));
  const auto line = [&](Key i, Key j, const SE3d& z) {
    double p[7];
    z.ToParams(p);
    std::string s = "EDGE_SE3:QUAT " + std::to_string(i) + " " + std::to_string(j);
    for (double v : p) s += " " + FormatDouble(v);
    return s + info6 + "\n";
  };
  const GraphFile g = Read(line(5, 6, z01) + line(6, 7, z12));
  EXPECT_EQ(g.initialised_by_spanning_tree, 3);
  ExpectSE3Near(g.values.At<SE3d>(5), SE3d());
  ExpectSE3Near(g.values.At<SE3d>(6), z01);
  ExpectSE3Near(g.values.At<SE3d>(7), z01 * z12);
}

TEST(GraphIoTest, HugeIdsCostNoMemoryProportionalToTheId) {
  const GraphFile g = Read("VERTEX_SE2 4000000000 1 2 0\nVERTEX_SE2 18446744073709551615 3 4 0\nVERTEX_SE2 0 0 0 0\n" +
                           Edge(4000000000, 18446744073709551615u, 2, 2, 0) + Edge(0, 4000000000, 1, 2, 0) +
                           "FIX 18446744073709551615\n");
  EXPECT_EQ(g.values.size(), 3u);
  ExpectSE2Near(g.values.At<SE2d>(18446744073709551615u), SE2d(3, 4, 0), 0);
  EXPECT_TRUE(g.graph.IsFixed(18446744073709551615u));
  EXPECT_EQ(g.graph.at(0).keys(), (std::vector<Key>{4000000000, 18446744073709551615u}));
  // Edges only, with huge ids: the spanning tree uses hash maps too.
  const GraphFile e = Read(Edge(4000000000, 18446744073709551615u, 2, 2, 0) + Edge(3000000000, 4000000000, 1, 0, 0));
  EXPECT_EQ(e.initialised_by_spanning_tree, 3);
  ExpectSE2Near(e.values.At<SE2d>(3000000000), SE2d(), 0);
  ExpectSE2Near(e.values.At<SE2d>(18446744073709551615u), SE2d(3, 2, 0));
  // Write and read back: ids survive as they are.
  std::ostringstream out;
  WriteG2o(out, g.values, g.graph, DefaultRegistry());
  EXPECT_CONTAINS(out.str(), "VERTEX_SE2 18446744073709551615 3 4 0\n");
  EXPECT_CONTAINS(out.str(), "FIX 18446744073709551615\n");
  ExpectSameGraph(g, Read(out.str()), 0);
}

TEST(GraphIoTest, InitializeSpanningTreeStartsFromExistingValues) {
  FactorGraph graph;
  graph.Add(std::make_unique<BetweenSE2>(10, 11, SE2d(1, 0, 0.5), SqrtInformation::Identity(3)));
  graph.Add(std::make_unique<BetweenSE2>(12, 11, SE2d(0, 1, -0.5), SqrtInformation::Identity(3)));
  graph.Add(std::make_unique<PosePoint2>(12, 20, Eigen::Vector2d(2, 0), SqrtInformation::Identity(2)));
  graph.Add(std::make_unique<PriorSE2>(10, SE2d(), SqrtInformation::Identity(3)));
  Values values;
  const SE2d x11(5, 5, 1.0);
  values.Insert(11, x11);
  EXPECT_EQ(InitializeSpanningTree(graph, &values), 3);
  EXPECT_EQ(values.keys(), (std::vector<Key>{11, 10, 12, 20}));  // new keys appended in key order
  ExpectSE2Near(values.At<SE2d>(10), x11 * SE2d(1, 0, 0.5).Inverse());
  ExpectSE2Near(values.At<SE2d>(12), x11 * SE2d(0, 1, -0.5).Inverse());
  const Eigen::Vector2d l = values.At<SE2d>(12) * Eigen::Vector2d(2, 0);
  EXPECT_LT((values.At<Eigen::Vector2d>(20) - l).norm(), 1e-12);
  // Nothing missing: nothing to do.
  EXPECT_EQ(InitializeSpanningTree(graph, &values), 0);
}

TEST(GraphIoTest, InitializeSpanningTreeNamesAnUnreachableKeyAndChangesNothing) {
  FactorGraph graph;
  graph.Add(std::make_unique<BetweenSE2>(0, 1, SE2d(1, 0, 0), SqrtInformation::Identity(3)));
  graph.Add(std::make_unique<PriorSE2>(5, SE2d(), SqrtInformation::Identity(3)));
  graph.Add(std::make_unique<BetweenSE2>(7, 8, SE2d(1, 0, 0), SqrtInformation::Identity(3)));
  Values values;
  const std::string m = ErrorOf<InvalidArgument>([&] { InitializeSpanningTree(graph, &values); });
  EXPECT_CONTAINS(m, "cannot give id 5 an initial value (nor 2 other ids)");
  EXPECT_CONTAINS(m, "give it an initial value (a vertex line) or add edges that link it");
  EXPECT_TRUE(values.empty());
}

TEST(GraphIoTest, ConnectedPieces) {
  FactorGraph graph;
  graph.Add(std::make_unique<BetweenSE2>(9, 3, SE2d(), SqrtInformation::Identity(3)));
  graph.Add(std::make_unique<BetweenSE2>(3, 4, SE2d(), SqrtInformation::Identity(3)));
  graph.Add(std::make_unique<PriorSE2>(1, SE2d(), SqrtInformation::Identity(3)));  // unary: links nothing
  graph.Add(std::make_unique<BetweenSE2>(100, 7, SE2d(), SqrtInformation::Identity(3)));
  Values values;
  values.Insert(50, SE2d());
  values.Insert(3, SE2d());
  const std::vector<std::vector<Key>> pieces = ConnectedPieces(values, graph);
  EXPECT_EQ(pieces, (std::vector<std::vector<Key>>{{1}, {3, 4, 9}, {7, 100}, {50}}));
  EXPECT_TRUE(ConnectedPieces(Values(), FactorGraph()).empty());
}

// ---------------------------------------------------------------------------------------------
// TORO

TEST(GraphIoTest, ToroInformationIsInToroOrder) {
  const GraphFile g = Read(
      "VERTEX2 0 0 0 0\n"
      "VERTEX2 1 1 0 0\n"
      "EDGE2 0 1 1 0.5 0.25 10 1 20 30 2 3\n",
      "w.graph");
  ASSERT_EQ(g.graph.size(), 1u);
  EXPECT_EQ(g.graph.at(0).type_name(), "BetweenSE2");
  EXPECT_EQ(g.graph.at(0).Measurement(), (std::vector<double>{1, 0.5, 0.25}));
  Eigen::Matrix3d want;  // I11 I12 I22 I33 I13 I23
  want << 10, 1, 2, 1, 20, 3, 2, 3, 30;
  EXPECT_LT((g.graph.at(0).noise().Information() - want).norm(), 1e-12);
}

TEST(GraphIoTest, ToroEquivLinesAreIgnoredWithAWarning) {
  const GraphFile g =
      Read("VERTEX2 0 0 0 0\nVERTEX2 1 1 0 0\nEDGE2 0 1 1 0 0 1 0 1 1 0 0\nEQUIV 0 1\nEQUIV 1 0\n", "w.graph");
  EXPECT_EQ(g.values.size(), 2u);
  ASSERT_EQ(g.warnings.size(), 1u);
  EXPECT_CONTAINS(g.warnings[0],
                  "w.graph: ignored 2 EQUIV lines (first at line 4): TORO's EQUIV says two ids are "
                  "the same pose; tether does not merge them");
}

TEST(GraphIoTest, ToroIsDetectedByTagsAndErrorsUseToroLayouts) {
  const std::string text = "VERTEX2 0 0 0 0\nVERTEX2 1 1 0 0\nEDGE2 0 1 1 0 0 1 0 1 1 0 0\n";
  EXPECT_EQ(Read(text, "w.txt").graph.size(), 1u);
  EXPECT_EQ(Read(text, "w.txt", Format(FileFormat::kToro)).graph.size(), 1u);
  EXPECT_EQ(ReadError("EDGE2 0 1 1 0 0 1 0 1 1 0\n", "w.graph"),
            "w.graph:1: too few fields: EDGE2 needs 11 after the tag (id1 id2 dx dy dtheta I11 I12 I22 I33 "
            "I13 I23, "
            "TORO's order), found 10; fix or remove the line");
  EXPECT_CONTAINS(ReadError("EDGE2 0 1 1 0 0 1 0 -1 1 0 0\n", "w.graph"),
                  "w.graph:1: EDGE2: information matrix is not positive definite (smallest eigenvalue -1,");
  EXPECT_EQ(
      Read("EDGE2 0 1 1 0 0 1 0 -1 1 0 0\n", "w.graph", Repair(InformationRepair::kNearestPD)).repaired_informations,
      1);
}

TEST(GraphIoTest, ForcedG2oFormatRejectsToroTagsWithAHint) {
  const std::string m = ReadError("VERTEX2 0 0 0 0\n", "w.graph", Format(FileFormat::kG2o));
  EXPECT_CONTAINS(m, "w.graph:1: unknown tag 'VERTEX2'");
  EXPECT_CONTAINS(m, "it is a TORO tag: read the file as TORO");
}

TEST(GraphIoTest, APluginTagNamedLikeAToroTagWinsOutsideTorofiles) {
  Registry r;
  RegisterBuiltinFactors(r);
  FactorType t = *r.FindByName("BetweenSE2");
  r.Remove("BetweenSE2");
  t.tag = "EDGE2";
  t.owner = "plugin";
  r.Register(t);
  // g2o layout (upper triangle row by row) in a .g2o file ...
  const GraphFile g = Read("EDGE2 0 1 1 0 0 10 1 2 20 3 30\n", "x.g2o", {}, r);
  Eigen::Matrix3d upper;
  upper << 10, 1, 2, 1, 20, 3, 2, 3, 30;
  EXPECT_LT((g.graph.at(0).noise().Information() - upper).norm(), 1e-12);
  // ... TORO's order in a .graph file.
  const GraphFile h = Read("EDGE2 0 1 1 0 0 10 1 20 30 2 3\n", "x.graph", {}, r);
  EXPECT_LT((h.graph.at(0).noise().Information() - upper).norm(), 1e-12);
}

// ---------------------------------------------------------------------------------------------
// Writing

TEST(GraphIoTest, WritesVerticesThenFixThenEdges) {
  Values values;
  values.Insert(3, SE2d(1, 2, 0.5));
  values.Insert(1, Eigen::Vector2d(0.1, -0.2));
  values.Insert(7, SE3d(Eigen::Quaterniond(1, 0, 0, 0), Eigen::Vector3d(1, 2, 3)));
  values.Insert(2, Eigen::Vector3d(4, 5, 6));
  FactorGraph graph;
  graph.Add(std::make_unique<PosePoint2>(3, 1, Eigen::Vector2d(0.5, 0.25), SqrtInformation::Identity(2)));
  graph.Fix(7);
  graph.Fix(3);
  std::ostringstream out;
  WriteG2o(out, values, graph, DefaultRegistry());
  EXPECT_EQ(out.str(),
            "VERTEX_SE2 3 1 2 0.5\n"
            "VERTEX_XY 1 0.1 -0.2\n"
            "VERTEX_SE3:QUAT 7 1 2 3 0 0 0 1\n"
            "VERTEX_TRACKXYZ 2 4 5 6\n"
            "FIX 3\n"
            "FIX 7\n"
            "EDGE_SE2_XY 3 1 0.5 0.25 1 0 1\n");
}

TEST(GraphIoTest, WritingATaglessFactorNamesIt) {
  // A registry in which PosePoint3 has no file form.
  Registry r;
  RegisterBuiltinFactors(r);
  FactorType t = *r.FindByName("PosePoint3");
  r.Remove("PosePoint3");
  t.tag.clear();
  t.read = nullptr;
  t.write = nullptr;
  t.preamble.clear();
  r.Register(t);
  Values values;
  FactorGraph graph;
  graph.Add(std::make_unique<PosePoint2>(3, 1, Eigen::Vector2d(0.5, 0.25), SqrtInformation::Identity(2)));
  graph.Add(std::make_unique<PosePoint3>(3, 1, Eigen::Vector3d(0.5, 0.25, 1), SqrtInformation::Identity(3)));
  std::ostringstream out;
  EXPECT_CONTAINS(ErrorOf<InvalidArgument>([&] { WriteG2o(out, values, graph, r); }),
                  "factor #1: cannot write a factor of type 'PosePoint3': it has no g2o tag");
}

TEST(GraphIoTest, RoundTrip2D) {
  const std::string text =
      "VERTEX_SE2 0 0 0 0\n"
      "VERTEX_SE2 1 0.3333333333333333 -1e-9 3.1\n"
      "VERTEX_SE2 2 123456.789 2.5 -3.0999\n"
      "VERTEX_XY 10 2.2 -0.7\n"
      "EDGE_SE2 0 1 0.3333333333333333 0 3.1 10 1 2 20 3 30\n"
      "EDGE_SE2 1 2 1.1 0.1 0.2 500 0 0 500 0 5000\n"
      "EDGE_SE2_XY 2 10 2 0.5 4 1 9\n"
      "EDGE_PRIOR_SE2 0 0 0 0 1e6 0 0 1e6 0 1e8\n"
      "FIX 0\n";
  const GraphFile a = Read(text);
  TempDir dir;
  const std::string path = dir.File("round.g2o");
  WriteG2oFile(path, a.values, a.graph, DefaultRegistry());
  EXPECT_EQ(dir.Entries(), std::vector<std::string>{"round.g2o"});  // no temporary left behind
  const GraphFile b = ReadGraphFile(path, DefaultRegistry());
  ExpectSameGraph(a, b, 1e-12);
  // Vertices and measurements come back bit for bit.
  for (Key k : a.values.keys())
    for (int i = 0; i < AmbientDim(a.values.TypeOf(k)); ++i) EXPECT_EQ(a.values.Params(k)[i], b.values.Params(k)[i]);
  for (std::size_t i = 0; i < a.graph.size(); ++i) EXPECT_EQ(a.graph.at(i).Measurement(), b.graph.at(i).Measurement());
  // Overwriting an existing file works too.
  WriteG2oFile(path, b.values, b.graph, DefaultRegistry());
  ExpectSameGraph(a, ReadGraphFile(path, DefaultRegistry()), 1e-12);
}

TEST(GraphIoTest, RoundTrip3D) {
  Values values;
  FactorGraph graph;
  std::srand(7);
  SE3d x;
  for (Key k = 0; k < 5; ++k) {
    values.Insert(k, x);
    const Eigen::Vector4d q = Eigen::Vector4d::Random();
    const SE3d z(Eigen::Quaterniond(q[3], q[0], q[1], q[2]), Eigen::Vector3d::Random() * 3);
    if (k + 1 < 5) {
      const Eigen::Matrix<double, 6, 6> a = Eigen::Matrix<double, 6, 6>::Random();
      const Eigen::MatrixXd omega = a * a.transpose() + Eigen::MatrixXd::Identity(6, 6);
      graph.Add(std::make_unique<BetweenSE3>(k, k + 1, z, SqrtInformation::FromInformation(omega)));
    }
    x = x * z;
  }
  graph.Fix(0);
  TempDir dir;
  const std::string path = dir.File("round3.g2o");
  WriteG2oFile(path, values, graph, DefaultRegistry());
  GraphFile a;
  a.values = values;
  a.graph = graph;
  ExpectSameGraph(a, ReadGraphFile(path, DefaultRegistry()), 1e-12);
}

TEST(GraphIoTest, WriteFailuresThrowIoErrorNamingThePathAndLeaveNothingBehind) {
  Values values;
  values.Insert(0, SE2d());
  FactorGraph graph;
  TempDir dir;
  const std::string missing = dir.File("no/such/folder/out.g2o");
  EXPECT_CONTAINS(ErrorOf<IoError>([&] { WriteG2oFile(missing, values, graph, DefaultRegistry()); }),
                  "cannot write the g2o graph '" + missing + "': its folder");
  // The target is a folder: refused before anything is written.
  fs::create_directories(dir.File("a_folder"));
  const std::string m = ErrorOf<IoError>([&] { WriteG2oFile(dir.File("a_folder"), values, graph, DefaultRegistry()); });
  EXPECT_CONTAINS(m, "cannot write the g2o graph '" + dir.File("a_folder") + "': it is a folder");
  EXPECT_EQ(dir.Entries(), std::vector<std::string>{"a_folder"});
  // A factor that cannot be written: the exception passes through, no file appears.
  FactorGraph bad;
  bad.Add(std::make_unique<PosePoint3>(0, 1, Eigen::Vector3d(0.5, 0.25, 1), SqrtInformation::Identity(3)));
  EXPECT_THROW(WriteG2oFile(dir.File("bad.g2o"), values, bad, DefaultRegistry()), InvalidArgument);
  EXPECT_EQ(dir.Entries(), std::vector<std::string>{"a_folder"});
}

TEST(GraphIoTest, ReadFailuresThrowIoErrorNamingThePath) {
  TempDir dir;
  EXPECT_CONTAINS(ErrorOf<IoError>([&] { ReadGraphFile(dir.File("absent.g2o"), DefaultRegistry()); }),
                  dir.File("absent.g2o") + ": cannot open: ");
  fs::create_directories(dir.File("folder.g2o"));
  EXPECT_CONTAINS(ErrorOf<IoError>([&] { ReadGraphFile(dir.File("folder.g2o"), DefaultRegistry()); }),
                  dir.File("folder.g2o") + ": is a directory");
}

TEST(GraphIoTest, ReadGraphFileUsesThePathInMessagesAndDetectsToroByName) {
  TempDir dir;
  dir.Write("bad.g2o", "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 0 0 q\n");
  EXPECT_EQ(ErrorOf<ParseError>([&] { ReadGraphFile(dir.File("bad.g2o"), DefaultRegistry()); }),
            dir.File("bad.g2o") + ":2: VERTEX_SE2 field 4 ('q') is not a number; fix or remove the line");
  dir.Write("t.graph", "VERTEX2 0 0 0 0\nVERTEX2 1 1 0 0\nEDGE2 0 1 1 0 0 10 1 20 30 2 3\n");
  const GraphFile g = ReadGraphFile(dir.File("t.graph"), DefaultRegistry());
  EXPECT_NEAR(g.graph.at(0).noise().Information()(0, 2), 2, 1e-12);
}

// ---------------------------------------------------------------------------------------------
// The public datasets (../shared/datasets); skipped where absent.

struct DatasetCase {
  const char* file;
  std::size_t vertices;
  std::size_t edges;
  bool edges_only;
};

void PrintTo(const DatasetCase& c, std::ostream* os) { *os << c.file; }

class G2oDatasetTest : public ::testing::TestWithParam<DatasetCase> {};

TEST_P(G2oDatasetTest, CountsMatchTheTable) {
  const std::string folder = std::string(TETHER_DATASETS_DIR) + "/g2o";
  if (!fs::is_directory(folder)) GTEST_SKIP() << "dataset folder " << folder << " absent";
  const DatasetCase& c = GetParam();
  const std::string path = folder + "/" + c.file;
  if (!fs::exists(path)) GTEST_SKIP() << "dataset " << path << " absent";
  const GraphFile g = ReadGraphFile(path, DefaultRegistry());
  EXPECT_EQ(g.values.size(), c.vertices);
  EXPECT_EQ(g.graph.size(), c.edges);
  EXPECT_EQ(g.initialised_by_spanning_tree, c.edges_only ? static_cast<int>(c.vertices) : 0);
  EXPECT_EQ(g.repaired_informations, 0);
  EXPECT_TRUE(g.warnings.empty()) << g.warnings.front();
  EXPECT_TRUE(g.graph.fixed().empty());
  EXPECT_EQ(ConnectedPieces(g.values, g.graph).size(), 1u);
  EXPECT_TRUE(std::isfinite(g.graph.Chi2(g.values)));
  // With repair on, nothing needs repairing either (every matrix is positive definite).
  EXPECT_EQ(ReadGraphFile(path, DefaultRegistry(), Repair(InformationRepair::kNearestPD)).repaired_informations, 0);
}

INSTANTIATE_TEST_SUITE_P(
    Datasets, G2oDatasetTest,
    ::testing::Values(DatasetCase{"intel.g2o", 1728, 2512, false}, DatasetCase{"MIT.g2o", 808, 827, false},
                      DatasetCase{"CSAIL.g2o", 1045, 1172, true}, DatasetCase{"manhattan.g2o", 3500, 5453, true},
                      DatasetCase{"ais2klinik.g2o", 15115, 16727, false}, DatasetCase{"kitti_00.g2o", 4541, 4677, true},
                      DatasetCase{"sphere2500.g2o", 2500, 4949, false},
                      DatasetCase{"parking-garage.g2o", 1661, 6275, false},
                      DatasetCase{"smallGrid3D.g2o", 125, 297, false}, DatasetCase{"tinyGrid3D.g2o", 9, 11, false},
                      DatasetCase{"input_M3500_g2o.g2o", 3500, 5453, false}),
    [](const ::testing::TestParamInfo<DatasetCase>& info) {
      std::string name = info.param.file;
      name = name.substr(0, name.find('.'));
      for (char& ch : name)
        if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
      return name;
    });

TEST(G2oDatasetFolderTest, EveryFileInTheFolderIsInTheTable) {
  const std::string folder = std::string(TETHER_DATASETS_DIR) + "/g2o";
  if (!fs::is_directory(folder)) GTEST_SKIP() << "dataset folder " << folder << " absent";
  const std::set<std::string> known = {"intel.g2o",       "MIT.g2o",        "CSAIL.g2o",          "manhattan.g2o",
                                       "ais2klinik.g2o",  "kitti_00.g2o",   "sphere2500.g2o",     "parking-garage.g2o",
                                       "smallGrid3D.g2o", "tinyGrid3D.g2o", "input_M3500_g2o.g2o"};
  for (const auto& e : fs::directory_iterator(folder)) {
    if (e.path().extension() != ".g2o") continue;
    EXPECT_TRUE(known.count(e.path().filename().string())) << e.path() << " has no expected counts in this test";
  }
}

TEST(G2oDatasetFolderTest, ReadWriteReadKeepsIntel) {
  const std::string path = std::string(TETHER_DATASETS_DIR) + "/g2o/intel.g2o";
  if (!fs::exists(path)) GTEST_SKIP() << "dataset " << path << " absent";
  const GraphFile a = ReadGraphFile(path, DefaultRegistry());
  TempDir dir;
  WriteG2oFile(dir.File("intel.g2o"), a.values, a.graph, DefaultRegistry());
  ExpectSameGraph(a, ReadGraphFile(dir.File("intel.g2o"), DefaultRegistry()), 1e-9);
  // Line for line, every number written is the number of the original file (intel has no
  // angle outside (-pi, pi] and no quaternion to normalise).
  std::ifstream original(path), written(dir.File("intel.g2o"));
  std::string x, y;
  long line = 0;
  while (std::getline(original, x)) {
    ++line;
    if (x.find_first_not_of(" \t\r") == std::string::npos) continue;
    ASSERT_TRUE(std::getline(written, y)) << "written file ends before line " << line;
    std::istringstream sx(x), sy(y);
    std::string tx, ty;
    sx >> tx;
    sy >> ty;
    ASSERT_EQ(tx, ty) << "line " << line;
    for (double u, v; sx >> u;) {
      ASSERT_TRUE(sy >> v) << "line " << line;
      EXPECT_EQ(u, v) << "line " << line << ": " << x << " / " << y;
    }
    EXPECT_FALSE(sy >> ty) << "line " << line;
  }
  EXPECT_FALSE(std::getline(written, y));
}

TEST(ToroDatasetTest, ReadsW100) {
  const std::string path = std::string(TETHER_DATASETS_DIR) + "/landmarks/w100.graph";
  if (!fs::exists(path)) GTEST_SKIP() << "dataset " << path << " absent";
  const GraphFile g = ReadGraphFile(path, DefaultRegistry());
  EXPECT_EQ(g.values.size(), 100u);
  EXPECT_EQ(g.graph.size(), 300u);
  ASSERT_EQ(g.warnings.size(), 1u);
  EXPECT_CONTAINS(g.warnings[0], "ignored 40 EQUIV lines (first at line 401)");
  EXPECT_EQ(g.initialised_by_spanning_tree, 0);
  EXPECT_TRUE(std::isfinite(g.graph.Chi2(g.values)));
}

}  // namespace
}  // namespace tether
