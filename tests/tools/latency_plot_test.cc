// The latency picture of `tether replay --plot`: statistics, one vertex per update, the
// marked lines, and bad arguments.
#include "tether/tools/latency_plot.h"

#include <gtest/gtest.h>

#include <cctype>
#include <cmath>
#include <string>
#include <vector>

#include "tether/core/error.h"

namespace tether {
namespace {

// The numbers in the d attribute of the path with class `cls` ("" when there is none).
std::vector<double> PathNumbers(const std::string& svg, const std::string& cls) {
  const std::size_t at = svg.find("<path class=\"" + cls + "\"");
  if (at == std::string::npos) return {};
  const std::size_t d = svg.find(" d=\"", at) + 4;
  const std::string data = svg.substr(d, svg.find('"', d) - d);
  std::vector<double> numbers;
  std::size_t i = 0;
  while (i < data.size()) {
    const char c = data[i];
    if (c == '-' || c == '.' || std::isdigit(static_cast<unsigned char>(c))) {
      std::size_t used = 0;
      numbers.push_back(std::stod(data.substr(i), &used));
      i += used;
    } else {
      ++i;
    }
  }
  return numbers;
}

TEST(LatencyStatsTest, MeanNearestRankP99AndMax) {
  std::vector<double> s;
  for (int i = 1; i <= 200; ++i) s.push_back(i);
  const LatencyStats st = ComputeLatencyStats(s);
  EXPECT_DOUBLE_EQ(st.sum, 20100);
  EXPECT_DOUBLE_EQ(st.mean, 100.5);
  EXPECT_DOUBLE_EQ(st.p99, 198);  // the 198th of 200
  EXPECT_DOUBLE_EQ(st.max, 200);
  const LatencyStats none = ComputeLatencyStats({});
  EXPECT_EQ(none.mean, 0);
  EXPECT_EQ(none.max, 0);
}

TEST(LatencyPlotTest, OneVertexPerUpdateAndTheStatisticsMarked) {
  std::vector<std::size_t> steps;
  std::vector<double> seconds;
  for (std::size_t i = 0; i < 37; ++i) {
    steps.push_back(3 * i + 2);
    seconds.push_back(i % 5 == 0 ? 2e-2 : 1e-5 * static_cast<double>(i + 1));
  }
  LatencyPlotOptions o;
  o.title = "a < b";
  const std::string svg = RenderLatencySvg(steps, seconds, o);
  EXPECT_EQ(svg.rfind("<svg", 0), 0u);
  EXPECT_EQ(svg.substr(svg.size() - 7), "</svg>\n");
  EXPECT_EQ(PathNumbers(svg, "latencies").size(), 2 * steps.size());
  for (const char* mark : {"class=\"mean\"", "class=\"p99\"", "class=\"max\"", "max 20 ms", "step (poses added)",
                           "update latency [ms] (log scale)", "a &lt; b"}) {
    EXPECT_NE(svg.find(mark), std::string::npos) << mark;
  }
  // The highest latency is drawn at the top of the plot: the smallest y of the path.
  o.log_y = false;
  const std::string linear = RenderLatencySvg(steps, seconds, o);
  EXPECT_EQ(PathNumbers(linear, "latencies").size(), 2 * steps.size());
  EXPECT_NE(linear.find("update latency [ms]<"), std::string::npos);
}

TEST(LatencyPlotTest, NonFiniteLatenciesAreLeftOutAndNoUpdatesDrawNoPath) {
  const std::string svg = RenderLatencySvg({0, 1, 2, 3}, {1e-3, std::nan(""), 2e-3, 0.0});
  EXPECT_EQ(PathNumbers(svg, "latencies").size(), 6u);
  const std::string empty = RenderLatencySvg({}, {});
  EXPECT_EQ(empty.find("class=\"latencies\""), std::string::npos);
  EXPECT_EQ(empty.substr(empty.size() - 7), "</svg>\n");
}

TEST(LatencyPlotTest, BadArguments) {
  EXPECT_THROW(RenderLatencySvg({0, 1}, {1e-3}), InvalidArgument);
  LatencyPlotOptions o;
  o.width_px = 10;
  std::string why;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("width_px"), std::string::npos);
  EXPECT_THROW(RenderLatencySvg({}, {}, o), InvalidArgument);
  EXPECT_THROW(WriteLatencySvgFile("/nonexistent-folder/x.svg", {0}, {1e-3}), IoError);
}

}  // namespace
}  // namespace tether
