// ReadGraph reads its stream in blocks: lines cut by a block's end, CRLF line ends and a
// last line without '\n' must read exactly as a line-by-line reader would, with the same
// line numbers in messages.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <sstream>

#include "tether/core/error.h"
#include "tether/core/graph_io.h"
#include "tether/factors/builtin.h"
#include "tether/frontends/simulation/simulate.h"

namespace tether {
namespace {

std::string SimulatedText(int poses) {
  SimulateOptions o;
  o.world = SimWorld::kSphere;
  o.poses = poses;
  o.seed = 11;
  const SimulatedGraph sim = Simulate(o);
  std::ostringstream out;
  WriteG2o(out, sim.initial, sim.graph, DefaultRegistry());
  return out.str();
}

GraphFile Read(const std::string& text) {
  std::istringstream in(text);
  return ReadGraph(in, "mem.g2o", DefaultRegistry());
}

void ExpectSame(const GraphFile& a, const GraphFile& b) {
  ASSERT_EQ(a.graph.size(), b.graph.size());
  ASSERT_EQ(a.values.size(), b.values.size());
  for (Key k : a.values.keys()) {
    ASSERT_EQ(std::memcmp(a.values.Params(k), b.values.Params(k), sizeof(double) * AmbientDim(a.values.TypeOf(k))), 0);
  }
  EXPECT_EQ(a.graph.Chi2(a.values), b.graph.Chi2(b.values));
}

TEST(ReadBlocks, LinesAcrossBlockEndsCrlfAndNoFinalNewline) {
  const std::string text = SimulatedText(1500);
  ASSERT_GT(text.size(), 4u * 65536u);  // several blocks, so lines straddle block ends
  const GraphFile plain = Read(text);
  EXPECT_EQ(plain.values.size(), 1500u);

  std::string crlf;
  for (char c : text) {
    if (c == '\n') crlf += '\r';
    crlf += c;
  }
  ExpectSame(plain, Read(crlf));

  ASSERT_EQ(text.back(), '\n');
  ExpectSame(plain, Read(text.substr(0, text.size() - 1)));
}

TEST(ReadBlocks, ErrorsNameTheLineAfterManyBlocks) {
  std::string text = SimulatedText(1500);
  const long lines = static_cast<long>(std::count(text.begin(), text.end(), '\n'));
  text += "EDGE_SE3:QUAT 0 1 oops\n";
  try {
    Read(text);
    FAIL() << "no error";
  } catch (const ParseError& e) {
    EXPECT_NE(std::string(e.what()).find("mem.g2o:" + std::to_string(lines + 1) + ":"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace tether
