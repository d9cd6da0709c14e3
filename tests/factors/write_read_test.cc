// Whatever tether writes, it reads back, bit for bit; what it cannot write faithfully it
// refuses. Also the messages for bad input: the information rule stated, tokens cut and escaped.
#include <gtest/gtest.h>

#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <sstream>
#include <string>

#include "tether/core/fields.h"
#include "tether/core/graph_io.h"
#include "tether/core/registry.h"
#include "tether/factors/between_se2.h"
#include "tether/factors/between_se3.h"
#include "tether/factors/builtin.h"

namespace tether {
namespace {

#define EXPECT_CONTAINS(text, part) EXPECT_NE(std::string(text).find(part), std::string::npos) << (text)

std::uint64_t Bits(double v) {
  std::uint64_t b;
  std::memcpy(&b, &v, sizeof b);
  return b;
}

double ParseDouble(const std::string& s) {
  double v = 0;
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  EXPECT_EQ(r.ec, std::errc()) << s;
  EXPECT_EQ(r.ptr, s.data() + s.size()) << s;
  return v;
}

GraphFile Read(const std::string& text, const std::string& name = "t.g2o") {
  std::istringstream in(text);
  return ReadGraph(in, name, DefaultRegistry());
}

std::string Write(const GraphFile& g) {
  std::ostringstream out;
  WriteG2o(out, g.values, g.graph, DefaultRegistry());
  return out.str();
}

template <class F>
std::string MessageOf(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

// The values the property runs over: random bit patterns (every finite double is as likely as
// any other), the ends of the range, subnormals and negative zero.
std::vector<double> HardDoubles() {
  std::vector<double> v = {0.0,
                           -0.0,
                           1.0,
                           10.0,
                           0.1,
                           1e155,
                           1.23456789e-170,
                           1e300,
                           -1e300,
                           1e-300,
                           std::numeric_limits<double>::max(),
                           std::numeric_limits<double>::lowest(),
                           std::numeric_limits<double>::min(),
                           std::numeric_limits<double>::denorm_min(),
                           -std::numeric_limits<double>::denorm_min(),
                           3 * std::numeric_limits<double>::denorm_min(),
                           std::numeric_limits<double>::min() / 3};
  std::mt19937_64 rng(7);
  while (v.size() < 20000) {
    const std::uint64_t b = rng();
    double d;
    std::memcpy(&d, &b, sizeof d);
    if (std::isfinite(d)) v.push_back(d);
  }
  return v;
}

TEST(WriteReadTest, EveryDoubleWrittenReadsBackBitIdentical) {
  for (double v : HardDoubles()) {
    std::string s;
    AppendDouble(&s, v);
    EXPECT_EQ(Bits(ParseDouble(s)), Bits(v)) << s;
  }
}

// Vertex values, measurements and information entries through a whole file: written, read
// back, and written again to the same bytes.
TEST(WriteReadTest, GraphFileRoundTripIsBitIdentical) {
  const std::vector<double> hard = HardDoubles();
  std::mt19937_64 rng(11);
  std::uniform_int_distribution<std::size_t> pick(0, hard.size() - 1);
  for (int trial = 0; trial < 200; ++trial) {
    Values values;
    FactorGraph graph;
    const double x = hard[pick(rng)], y = hard[pick(rng)];
    values.Insert(0, SE2d(x, y, 0.25));
    values.Insert(1, SE2d(hard[pick(rng)], -0.0, -1.5));
    // A diagonal information of any magnitude (1e-300 to 1e300, subnormal) and a signed-zero
    // off-diagonal entry.
    Eigen::Matrix3d info = Eigen::Matrix3d::Zero();
    for (int i = 0; i < 3; ++i) info(i, i) = std::abs(hard[pick(rng)]);
    if ((info.diagonal().array() <= 0).any()) continue;
    info(0, 1) = info(1, 0) = -0.0;
    SqrtInformation noise;
    std::string why;
    if (!SqrtInformation::TryFromInformation(info, &noise, &why)) continue;  // singular to working precision
    graph.Add(std::make_unique<BetweenSE2>(0, 1, SE2d(hard[pick(rng)], 1e-310, 3.0), noise));
    std::ostringstream first;
    WriteG2o(first, values, graph, DefaultRegistry());
    const GraphFile back = Read(first.str());
    const Eigen::MatrixXd read_info = back.graph.at(0).noise().Information();
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) EXPECT_EQ(Bits(read_info(i, j)), Bits(info(i, j))) << first.str();
    }
    for (Key k : {Key{0}, Key{1}}) {
      for (int i = 0; i < 3; ++i) EXPECT_EQ(Bits(back.values.Params(k)[i]), Bits(values.Params(k)[i]));
    }
    EXPECT_EQ(Write(back), first.str());
  }
}

TEST(WriteReadTest, InformationIsWrittenAsGivenWhateverItsMagnitude) {
  // The reported cases: 1e155 (its products overflow), 1.23456789e-170 (once written with one
  // digit), and a file's own plain numbers.
  for (const std::string entry : {"1e+155", "1.23456789e-170", "500", "0.050542"}) {
    const std::string text =
        "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 0 " + entry + " 0 0 " + entry + " 0 " + entry + "\n";
    const std::string written = Write(Read(text));
    EXPECT_EQ(written, text) << entry;
  }
  // Off-diagonal entries too, from a full matrix.
  const std::string full =
      "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 0 44.7 -3.25 0.125 51.9 1e-07 1234.5\n";
  EXPECT_EQ(Write(Read(full)), full);
  // Information built from sigmas is written as R^T R, exactly.
  FactorGraph graph;
  Values values;
  values.Insert(0, SE2d());
  values.Insert(1, SE2d(1, 0, 0));
  graph.Add(
      std::make_unique<BetweenSE2>(0, 1, SE2d(1, 0, 0), SqrtInformation::FromSigmas(Eigen::Vector3d(0.3, 0.3, 0.7))));
  std::ostringstream out;
  WriteG2o(out, values, graph, DefaultRegistry());
  const Eigen::MatrixXd r = graph.at(0).noise().R();
  const Eigen::MatrixXd expected = r.transpose() * r;
  const Eigen::MatrixXd read = Read(out.str()).graph.at(0).noise().Information();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) EXPECT_EQ(Bits(read(i, j)), Bits(expected(i, j)));
  }
}

TEST(WriteReadTest, IllConditionedInformationIsRefusedStatingTheRule) {
  // Positive definite on paper, condition 1e25: refused, and the message says why without
  // calling it "not positive definite".
  std::string text =
      "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nVERTEX_SE3:QUAT 1 1 0 0 0 0 0 1\nEDGE_SE3:QUAT 0 1 1 0 0 0 0 0 1";
  const double diag[6] = {1e25, 1e25, 1e25, 1, 1, 1};
  for (int i = 0; i < 6; ++i) {
    for (int j = i; j < 6; ++j) text += i == j ? " " + std::to_string(diag[i]) : " 0";
  }
  const std::string m = MessageOf([&] { Read(text + "\n"); });
  EXPECT_CONTAINS(m, "t.g2o:3: EDGE_SE3:QUAT: information matrix is singular to working precision");
  EXPECT_CONTAINS(m, "condition number 1e+25");
  EXPECT_CONTAINS(m, "tether's limit");
  EXPECT_CONTAINS(m, "--repair-information");
  EXPECT_EQ(m.find("not positive definite"), std::string::npos) << m;
  // Truly indefinite: said so, with the eigenvalue.
  const std::string indefinite =
      MessageOf([] { Read("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 0 1 0 0 -0.5 0 1\n"); });
  EXPECT_CONTAINS(indefinite,
                  "t.g2o:3: EDGE_SE2: information matrix is not positive definite (smallest eigenvalue -0.5");
}

TEST(WriteReadTest, OffendingTokensAreCutAndEscaped) {
  const std::string huge(10 * 1000 * 1000, '7');
  const std::string m = MessageOf([&] { Read("VERTEX_SE2 0 " + huge + "x 0 0\n"); });
  EXPECT_LT(m.size(), 300u) << m.substr(0, 400);
  EXPECT_CONTAINS(m, "(10000001 bytes)");
  const std::string binary = MessageOf([] { Read(std::string("VERTEX_SE2 0 \x01\x1b[2J\xff 0 0\n", 24)); });
  EXPECT_CONTAINS(binary, "'\\x01\\x1b[2J\\xff'");
  for (char c : binary) EXPECT_TRUE(c >= 0x20 && c < 0x7f) << static_cast<int>(c);
  const std::string tag = MessageOf([] { Read("\x07\x08TAG 1 2\n"); });
  EXPECT_CONTAINS(tag, "unknown tag '\\x07\\x08TAG'");
  EXPECT_EQ(QuoteToken("a'b\\c"), "'a\\x27b\\x5cc'");
}

TEST(WriteReadTest, EdgeQuaternionFarFromUnitLengthIsWarnedAbout) {
  const GraphFile g = Read(
      "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nVERTEX_SE3:QUAT 1 1 0 0 0 0 0 1\n"
      "EDGE_SE3:QUAT 0 1 1 0 0 0 0 0 1 1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 1 0 0 1 0 1\n"
      "EDGE_SE3:QUAT 0 1 1 0 0 0 0 0 2 1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 1 0 0 1 0 1\n");
  ASSERT_EQ(g.warnings.size(), 1u);
  EXPECT_CONTAINS(g.warnings[0],
                  "t.g2o: normalised quaternions that were far from unit length in 1 edge measurement "
                  "(first at line 4)");
}

TEST(WriteReadTest, LibraryRefusesWhatItCouldNotWriteOrUse) {
  FactorGraph graph;
  EXPECT_CONTAINS(MessageOf([&] { graph.Add(std::unique_ptr<Factor>()); }), "null pointer");
  EXPECT_EQ(graph.size(), 0u);
  EXPECT_CONTAINS(MessageOf([&] { InitializeSpanningTree(graph, nullptr); }), "null pointer");

  Values values;
  const double zero_quaternion[7] = {0, 0, 0, 0, 0, 0, 0};
  EXPECT_CONTAINS(MessageOf([&] { values.InsertParams(3, VarType::kSE3, zero_quaternion); }), "quaternion");
  EXPECT_TRUE(values.empty());
  // A non-finite value is left to the solvers, which name the factor and keys that use it.
  const double nan_quaternion[7] = {0, 0, 0, std::nan(""), 0, 0, 1};
  EXPECT_NO_THROW(values.InsertParams(3, VarType::kSE3, nan_quaternion));
  values.Erase(3);

  // An edge whose key has no value would make a file the reader refuses.
  values.Insert(0, SE2d());
  graph.Add(std::make_unique<BetweenSE2>(0, 1, SE2d(1, 0, 0), SqrtInformation::Identity(3)));
  std::ostringstream out;
  EXPECT_CONTAINS(MessageOf([&] { WriteG2o(out, values, graph, DefaultRegistry()); }),
                  "factor #0 (BetweenSE2): variable 1 has no value");
  // Edges alone (no values at all) are a file the reader completes: written.
  std::ostringstream edges_only;
  WriteG2o(edges_only, Values(), graph, DefaultRegistry());
  EXPECT_EQ(Read(edges_only.str()).graph.size(), 1u);
  // A value made non-finite after it was inserted is not written either.
  values.Insert(1, SE2d(1, 0, 0));
  values.Params(1)[0] = std::numeric_limits<double>::infinity();
  EXPECT_CONTAINS(MessageOf([&] { WriteG2o(out, values, graph, DefaultRegistry()); }), "not finite");
}

}  // namespace
}  // namespace tether
