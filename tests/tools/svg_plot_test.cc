#include "tether/core/svg_plot.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "tether/core/error.h"
#include "tether/factors/between_se2.h"
#include "tether/frontends/simulation/simulate.h"

namespace tether {
namespace {

// ---- helpers: a small look inside the SVG text ----

/// Every opened tag is closed, in order, and the document is one <svg> element.
::testing::AssertionResult WellFormed(const std::string& svg) {
  if (svg.rfind("<svg", 0) != 0) return ::testing::AssertionFailure() << "does not start with <svg";
  if (svg.size() < 7 || svg.compare(svg.size() - 7, 7, "</svg>\n") != 0)
    return ::testing::AssertionFailure() << "does not end with </svg>";
  std::vector<std::string> open;
  std::size_t pos = 0;
  int roots = 0;
  while ((pos = svg.find('<', pos)) != std::string::npos) {
    const std::size_t end = svg.find('>', pos);
    if (end == std::string::npos) return ::testing::AssertionFailure() << "unterminated tag at " << pos;
    const std::string tag = svg.substr(pos + 1, end - pos - 1);
    if (tag.find('<') != std::string::npos) return ::testing::AssertionFailure() << "'<' inside tag at " << pos;
    if (tag.empty()) return ::testing::AssertionFailure() << "empty tag at " << pos;
    const bool closing = tag[0] == '/';
    const bool self_closing = tag.back() == '/';
    std::string name = tag.substr(closing ? 1 : 0);
    name = name.substr(0, name.find_first_of(" /"));
    if (closing) {
      if (open.empty() || open.back() != name)
        return ::testing::AssertionFailure() << "</" << name << "> does not close the open element";
      open.pop_back();
    } else if (!self_closing) {
      if (open.empty()) ++roots;
      open.push_back(name);
    }
    pos = end + 1;
  }
  if (!open.empty()) return ::testing::AssertionFailure() << "<" << open.back() << "> never closed";
  if (roots != 1) return ::testing::AssertionFailure() << roots << " root elements";
  return ::testing::AssertionSuccess();
}

bool Contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

bool HasNonFinite(const std::string& svg) {
  std::string lower = svg;
  std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return std::tolower(c); });
  return Contains(lower, "nan") || Contains(lower, "inf");
}

std::size_t CountOf(const std::string& s, const std::string& part) {
  std::size_t n = 0;
  for (std::size_t p = s.find(part); p != std::string::npos; p = s.find(part, p + 1)) ++n;
  return n;
}

/// The d attribute of the <path> with the given class ("" when there is none).
std::string PathData(const std::string& svg, const std::string& cls) {
  const std::size_t p = svg.find("<path class=\"" + cls + "\"");
  if (p == std::string::npos) return "";
  const std::size_t d = svg.find(" d=\"", p);
  const std::size_t end = svg.find('"', d + 4);
  return svg.substr(d + 4, end - d - 4);
}

struct PathPoint {
  char command;  // 'M' (start of a subpath), 'L' (line to), 'Z' (close)
  double x, y;
};

/// Absolute points of path data made of M/m/L/l/z commands (implicit repetition allowed).
std::vector<PathPoint> ParsePath(const std::string& d) {
  std::vector<PathPoint> out;
  char cmd = 0;
  double x = 0, y = 0, sx = 0, sy = 0;
  const char* p = d.c_str();
  while (*p != '\0') {
    if (*p == ' ') {
      ++p;
    } else if (std::isalpha(static_cast<unsigned char>(*p))) {
      cmd = *p++;
      if (cmd == 'z' || cmd == 'Z') {
        x = sx;
        y = sy;
        out.push_back({'Z', x, y});
      }
    } else {
      char* end = nullptr;
      const double a = std::strtod(p, &end);
      const double b = std::strtod(end, &end);
      p = end;
      const bool relative = std::islower(static_cast<unsigned char>(cmd)) != 0;
      x = relative ? x + a : a;
      y = relative ? y + b : b;
      if (cmd == 'M' || cmd == 'm') {
        out.push_back({'M', x, y});
        sx = x;
        sy = y;
        cmd = cmd == 'M' ? 'L' : 'l';  // pairs after a move are lines
      } else {
        out.push_back({'L', x, y});
      }
    }
  }
  return out;
}

std::size_t Subpaths(const std::vector<PathPoint>& points) {
  return static_cast<std::size_t>(
      std::count_if(points.begin(), points.end(), [](const PathPoint& p) { return p.command == 'M'; }));
}

void AddOdometry(FactorGraph* graph, Key i, Key j) {
  graph->Add(std::make_unique<BetweenSE2>(i, j, SE2d(1, 0, 0), SqrtInformation::Identity(3)));
}

std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// ---- rendering ----

TEST(SvgPlotTest, ManhattanBeforeAndAfter) {
  SimulateOptions o;
  o.poses = 300;
  const SimulatedGraph g = Simulate(o);
  ASSERT_GT(g.loop_closures, 0);
  PlotOptions po;
  po.title = "manhattan 300";
  const std::string svg = RenderSvg(g.graph, &g.initial, &g.ground_truth, po);
  EXPECT_TRUE(WellFormed(svg));
  EXPECT_FALSE(HasNonFinite(svg));
  for (const char* cls : {"before", "after", "loop-closures"}) EXPECT_FALSE(PathData(svg, cls).empty()) << cls;
  EXPECT_TRUE(PathData(svg, "landmarks").empty());
  for (const char* label : {">before<", ">after<", ">loop closures<", ">manhattan 300<", " m</text>"})
    EXPECT_TRUE(Contains(svg, label)) << label;
  // One odometry chain: each trajectory is a single subpath through every pose.
  const std::vector<PathPoint> after = ParsePath(PathData(svg, "after"));
  EXPECT_EQ(Subpaths(after), 1u);
  EXPECT_EQ(after.size(), 300u);
  // One segment per loop closure.
  const std::vector<PathPoint> loops = ParsePath(PathData(svg, "loop-closures"));
  EXPECT_EQ(Subpaths(loops), static_cast<std::size_t>(g.loop_closures));
  EXPECT_EQ(loops.size(), 2u * g.loop_closures);
}

TEST(SvgPlotTest, EitherValuesMayBeMissing) {
  SimulateOptions o;
  o.poses = 50;
  const SimulatedGraph g = Simulate(o);

  const std::string only_after = RenderSvg(g.graph, nullptr, &g.ground_truth);
  EXPECT_TRUE(WellFormed(only_after));
  EXPECT_FALSE(PathData(only_after, "after").empty());
  EXPECT_TRUE(PathData(only_after, "before").empty());
  EXPECT_FALSE(Contains(only_after, ">before<"));

  const std::string only_before = RenderSvg(g.graph, &g.initial, nullptr);
  EXPECT_TRUE(WellFormed(only_before));
  EXPECT_FALSE(PathData(only_before, "before").empty());
  EXPECT_TRUE(PathData(only_before, "after").empty());
  EXPECT_FALSE(Contains(only_before, ">after<"));
  EXPECT_EQ(PathData(only_before, "loop-closures").empty(), g.loop_closures == 0);  // drawn for `before`

  const std::string neither = RenderSvg(g.graph, nullptr, nullptr);
  EXPECT_TRUE(WellFormed(neither));
  EXPECT_FALSE(HasNonFinite(neither));
  EXPECT_FALSE(Contains(neither, "<path class="));
}

TEST(SvgPlotTest, EqualScaleAndYAxisUp) {
  Values v;
  v.Insert(0, SE2d(0, 0, 0));
  v.Insert(1, SE2d(2, 0, 0));
  v.Insert(2, SE2d(2, 1, 0));
  v.Insert(3, SE2d(0, 1, 0));
  FactorGraph graph;
  for (Key k = 0; k < 3; ++k) AddOdometry(&graph, k, k + 1);
  for (int height : {0, 300, 900}) {
    PlotOptions po;
    po.height_px = height;
    const std::string svg = RenderSvg(graph, nullptr, &v, po);
    ASSERT_TRUE(WellFormed(svg));
    const std::vector<PathPoint> p = ParsePath(PathData(svg, "after"));
    ASSERT_EQ(p.size(), 4u);
    const double sx = (p[1].x - p[0].x) / 2.0;  // pixels per metre along x
    EXPECT_GT(sx, 10.0);
    EXPECT_NEAR(p[1].y, p[0].y, 0.011);
    EXPECT_NEAR(p[2].x, p[1].x, 0.011);
    EXPECT_NEAR(p[1].y - p[2].y, sx, 0.02);  // +1 m in y is sx pixels up
    EXPECT_NEAR(p[2].x - p[3].x, 2.0 * sx, 0.02);
    if (height > 0) {
      EXPECT_TRUE(Contains(svg, "height=\"" + std::to_string(height) + "\""));
    }
  }
}

TEST(SvgPlotTest, TrajectoryBreaksWhereNoOdometryJoinsPoses) {
  Values v;
  for (Key k = 0; k < 5; ++k) v.Insert(k, SE2d(static_cast<double>(k), 0.5 * k, 0));
  FactorGraph graph;
  AddOdometry(&graph, 0, 1);
  AddOdometry(&graph, 1, 2);
  AddOdometry(&graph, 3, 4);
  graph.Add(std::make_unique<BetweenSE2>(0, 4, SE2d(), SqrtInformation::Identity(3)));
  const std::string svg = RenderSvg(graph, nullptr, &v);
  const std::vector<PathPoint> p = ParsePath(PathData(svg, "after"));
  EXPECT_EQ(Subpaths(p), 2u);  // 0-1-2 and 3-4
  EXPECT_EQ(p.size(), 5u);
  const std::vector<PathPoint> loops = ParsePath(PathData(svg, "loop-closures"));
  ASSERT_EQ(loops.size(), 2u);
  EXPECT_NEAR(loops[0].x, p[0].x, 0.011);
  EXPECT_NEAR(loops[1].x, p[4].x, 0.011);

  // Without any odometry every pose is a dot (a zero-length line).
  const std::string dots = RenderSvg(FactorGraph(), nullptr, &v);
  const std::vector<PathPoint> d = ParsePath(PathData(dots, "after"));
  EXPECT_EQ(Subpaths(d), 5u);
  EXPECT_EQ(d.size(), 10u);
  EXPECT_TRUE(PathData(dots, "loop-closures").empty());
}

TEST(SvgPlotTest, SinglePose) {
  Values v;
  v.Insert(7, SE2d(3, -2, 1));
  const std::string svg = RenderSvg(FactorGraph(), &v, &v);
  EXPECT_TRUE(WellFormed(svg));
  EXPECT_FALSE(HasNonFinite(svg));
  EXPECT_FALSE(PathData(svg, "after").empty());
  EXPECT_TRUE(Contains(svg, "<circle class=\"start\""));
  // The pose is in the middle of the plot area.
  const std::vector<PathPoint> p = ParsePath(PathData(svg, "after"));
  ASSERT_EQ(p.size(), 2u);
  EXPECT_NEAR(p[0].x, 450.0, 1.0);
}

TEST(SvgPlotTest, Landmarks) {
  SimulateOptions o;
  o.world = SimWorld::kLandmarks;
  o.poses = 100;
  o.landmarks = 25;
  const SimulatedGraph g = Simulate(o);
  const std::string svg = RenderSvg(g.graph, &g.initial, &g.ground_truth);
  EXPECT_TRUE(WellFormed(svg));
  EXPECT_FALSE(HasNonFinite(svg));
  EXPECT_TRUE(Contains(svg, ">landmarks<"));
  // 25 closed squares of four corners each, for `after` and for `before`.
  for (const char* cls : {"landmarks", "landmarks-before"}) {
    const std::vector<PathPoint> sq = ParsePath(PathData(svg, cls));
    EXPECT_EQ(Subpaths(sq), 25u) << cls;
    EXPECT_EQ(sq.size(), 25u * 5u) << cls;
  }
  // Pose-landmark factors are not loop closures.
  EXPECT_TRUE(PathData(svg, "loop-closures").empty());

  PlotOptions po;
  po.draw_landmarks = false;
  const std::string bare = RenderSvg(g.graph, &g.initial, &g.ground_truth, po);
  EXPECT_TRUE(PathData(bare, "landmarks").empty());
  EXPECT_FALSE(Contains(bare, ">landmarks<"));
}

TEST(SvgPlotTest, SphereIsDrawnAsItsXYProjection) {
  SimulateOptions o;
  o.world = SimWorld::kSphere;
  o.poses = 100;
  const SimulatedGraph g = Simulate(o);
  const std::string svg = RenderSvg(g.graph, &g.initial, &g.ground_truth);
  EXPECT_TRUE(WellFormed(svg));
  EXPECT_FALSE(HasNonFinite(svg));
  EXPECT_EQ(ParsePath(PathData(svg, "after")).size(), 100u);
  EXPECT_FALSE(PathData(svg, "loop-closures").empty());
}

TEST(SvgPlotTest, NonFiniteValuesAreLeftOut) {
  Values v;
  for (Key k = 0; k < 6; ++k) v.Insert(k, SE2d(static_cast<double>(k), 0, 0));
  v.Params(2)[0] = std::numeric_limits<double>::quiet_NaN();
  v.Params(4)[1] = std::numeric_limits<double>::infinity();
  v.Insert(10, Eigen::Vector2d(std::numeric_limits<double>::quiet_NaN(), 1.0));
  v.Insert(11, Eigen::Vector2d(1.0, 1.0));
  FactorGraph graph;
  for (Key k = 0; k < 5; ++k) AddOdometry(&graph, k, k + 1);
  graph.Add(std::make_unique<BetweenSE2>(0, 2, SE2d(), SqrtInformation::Identity(3)));
  const std::string svg = RenderSvg(graph, &v, &v);
  EXPECT_TRUE(WellFormed(svg));
  EXPECT_FALSE(HasNonFinite(svg));
  // 0-1 joined; 3 and 5 lose their neighbours and become dots.
  const std::vector<PathPoint> p = ParsePath(PathData(svg, "after"));
  EXPECT_EQ(Subpaths(p), 3u);
  EXPECT_EQ(p.size(), 6u);
  EXPECT_EQ(Subpaths(ParsePath(PathData(svg, "landmarks"))), 1u);
  EXPECT_TRUE(PathData(svg, "loop-closures").empty());
}

TEST(SvgPlotTest, HundredThousandPosesStayFewElements) {
  const int n = 100000;
  Values v;
  FactorGraph graph;
  for (int i = 0; i < n; ++i) {
    const double a = 0.01 * i, r = 5.0 + 0.001 * i;
    v.Insert(Key(i), SE2d(r * std::cos(a), r * std::sin(a), a));
    if (i > 0) AddOdometry(&graph, Key(i - 1), Key(i));
    if (i >= 700 && i % 50 == 0) {
      graph.Add(std::make_unique<BetweenSE2>(Key(i - 628), Key(i), SE2d(), SqrtInformation::Identity(3)));
    }
  }
  const std::string svg = RenderSvg(graph, &v, &v);
  EXPECT_TRUE(WellFormed(svg));
  EXPECT_FALSE(HasNonFinite(svg));
  EXPECT_LE(CountOf(svg, "<path"), 6u);
  EXPECT_LT(svg.size(), 4u * 1000 * 1000);
  EXPECT_EQ(ParsePath(PathData(svg, "after")).size(), static_cast<std::size_t>(n));
}

TEST(SvgPlotTest, TextIsEscaped) {
  Values v;
  v.Insert(0, SE2d());
  PlotOptions po;
  po.title = "a<b & \"c\"";
  po.after_label = "x>y";
  const std::string svg = RenderSvg(FactorGraph(), nullptr, &v, po);
  EXPECT_TRUE(WellFormed(svg));
  EXPECT_TRUE(Contains(svg, ">a&lt;b &amp; &quot;c&quot;<"));
  EXPECT_TRUE(Contains(svg, ">x&gt;y<"));
}

TEST(SvgPlotTest, InvalidOptions) {
  EXPECT_TRUE(PlotOptions().IsValid(nullptr));
  PlotOptions po;
  po.width_px = 50;
  std::string why;
  EXPECT_FALSE(po.IsValid(&why));
  EXPECT_TRUE(Contains(why, "width_px")) << why;
  EXPECT_THROW(RenderSvg(FactorGraph(), nullptr, nullptr, po), InvalidArgument);
  po = PlotOptions();
  po.height_px = 20;
  EXPECT_FALSE(po.IsValid(&why));
  EXPECT_TRUE(Contains(why, "height_px")) << why;
}

// ---- files ----

TEST(SvgPlotTest, WriteFileRoundTrip) {
  SimulateOptions o;
  o.poses = 60;
  const SimulatedGraph g = Simulate(o);
  const std::string path = ::testing::TempDir() + "tether_svg_plot_test.svg";
  std::remove(path.c_str());
  WriteSvgFile(path, g.graph, &g.initial, &g.ground_truth);
  EXPECT_EQ(ReadFile(path), RenderSvg(g.graph, &g.initial, &g.ground_truth));
  EXPECT_FALSE(std::ifstream(path + ".tmp").good());  // the temporary was renamed away
  // Overwriting works too.
  WriteSvgFile(path, g.graph, nullptr, &g.ground_truth);
  EXPECT_EQ(ReadFile(path), RenderSvg(g.graph, nullptr, &g.ground_truth));
  std::remove(path.c_str());
}

TEST(SvgPlotTest, UnwritablePathThrowsIoErrorNamingIt) {
  Values v;
  v.Insert(0, SE2d());
  const std::string path = "/nonexistent-tether-directory/sub/plot.svg";
  try {
    WriteSvgFile(path, FactorGraph(), nullptr, &v);
    FAIL() << "expected an IoError";
  } catch (const IoError& e) {
    EXPECT_TRUE(Contains(e.what(), path)) << e.what();
  }
}

}  // namespace
}  // namespace tether
