#include "tether/tools/latency_plot.h"

#include <algorithm>
#include <cmath>

#include "tether/core/error.h"
#include "tether/core/output_file.h"
#include "tether/core/svg_writer.h"

namespace tether {
namespace {

using svg::Escape;
using svg::Num;
using svg::Pt;

constexpr double kLeft = 70.0;    // y tick labels and the y axis label
constexpr double kRight = 150.0;  // the statistics' labels
constexpr double kTop = 16.0;     // above the plot area
constexpr double kTitle = 28.0;   // the title band, where there is a title
constexpr double kBottom = 48.0;  // x tick labels and the x axis label
constexpr double kTickLength = 5.0;
constexpr const char* kSeriesColour = "#1f5fbf";
constexpr const char* kGridColour = "#e4e4e4";

struct StatLine {
  const char* name;
  double seconds;
  const char* colour;
};

// The latency axis: milliseconds to a fraction of the plot height (0 bottom, 1 top).
struct YAxis {
  bool log = true;
  double lo = 0, hi = 1;  // log: decades (exponents of ten); linear: milliseconds
  double operator()(double ms) const {
    if (!log) return (ms - lo) / (hi - lo);
    const double e = ms > 0 ? std::log10(ms) : lo;
    return (std::clamp(e, lo, hi) - lo) / (hi - lo);
  }
};

YAxis FitYAxis(const std::vector<double>& seconds, bool log) {
  double min_ms = HUGE_VAL, max_ms = 0;
  for (double s : seconds) {
    if (!std::isfinite(s)) continue;
    const double ms = 1e3 * s;
    if (ms > 0) min_ms = std::min(min_ms, ms);
    max_ms = std::max(max_ms, ms);
  }
  YAxis y;
  y.log = log;
  if (log) {
    if (!(min_ms <= max_ms)) min_ms = max_ms = 1.0;  // nothing positive: one decade at 1 ms
    y.lo = std::floor(std::log10(min_ms));
    y.hi = std::ceil(std::log10(max_ms));
    if (y.hi <= y.lo) y.hi = y.lo + 1;
  } else {
    y.lo = 0;
    y.hi = max_ms > 0 ? max_ms * 1.05 : 1.0;
  }
  return y;
}

// Latency tick values in milliseconds: each decade (log), or round steps from 0 (linear).
std::vector<double> YTicks(const YAxis& y) {
  std::vector<double> ticks;
  if (y.log) {
    for (double e = y.lo; e <= y.hi + 0.5; e += 1) ticks.push_back(std::pow(10.0, e));
    return ticks;
  }
  const double step = svg::NiceLength(y.hi / 5.0);
  for (double v = 0; v <= y.hi; v += step) ticks.push_back(v);
  return ticks;
}

}  // namespace

LatencyStats ComputeLatencyStats(const std::vector<double>& seconds) {
  LatencyStats st;
  if (seconds.empty()) return st;
  std::vector<double> sorted = seconds;
  std::sort(sorted.begin(), sorted.end());
  for (double s : seconds) st.sum += s;
  const double n = static_cast<double>(sorted.size());
  st.mean = st.sum / n;
  st.p99 = sorted[static_cast<std::size_t>(std::ceil(0.99 * n)) - 1];
  st.max = sorted.back();
  return st;
}

bool LatencyPlotOptions::IsValid(std::string* why) const {
  std::string reason;
  if (width_px < 300 || width_px > 20000) {
    reason = "LatencyPlotOptions.width_px must be in [300, 20000] (got " + std::to_string(width_px) + ")";
  } else if (height_px < 200 || height_px > 20000) {
    reason = "LatencyPlotOptions.height_px must be in [200, 20000] (got " + std::to_string(height_px) + ")";
  }
  if (why != nullptr) *why = reason;
  return reason.empty();
}

std::string RenderLatencySvg(const std::vector<std::size_t>& steps, const std::vector<double>& seconds,
                             const LatencyPlotOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("RenderLatencySvg: " + why);
  if (steps.size() != seconds.size()) {
    throw InvalidArgument("RenderLatencySvg: " + std::to_string(steps.size()) + " steps but " +
                          std::to_string(seconds.size()) + " latencies; give one step per latency");
  }
  const double width = options.width_px, height = options.height_px;
  const double top = kTop + (options.title.empty() ? 0.0 : kTitle);
  const double plot_w = width - kLeft - kRight, plot_h = height - top - kBottom;
  const double bottom = top + plot_h;

  // The step axis: from the first to the last step (a single step in the middle).
  double x_lo = 0, x_hi = 1;
  if (!steps.empty()) {
    x_lo = static_cast<double>(*std::min_element(steps.begin(), steps.end()));
    x_hi = static_cast<double>(*std::max_element(steps.begin(), steps.end()));
    if (x_hi <= x_lo) x_lo -= 1, x_hi += 1;
  }
  const YAxis y = FitYAxis(seconds, options.log_y);
  auto px = [&](double step, double ms) {
    return Pt{kLeft + (step - x_lo) / (x_hi - x_lo) * plot_w, bottom - y(ms) * plot_h};
  };

  std::string s;
  s.reserve(4096 + 12 * seconds.size());
  s += "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + Num(width) + "\" height=\"" + Num(height) +
       "\" viewBox=\"0 0 " + Num(width) + " " + Num(height) + "\" font-family=\"sans-serif\" font-size=\"12\">\n";
  if (!options.title.empty()) s += "<title>" + Escape(options.title) + "</title>\n";
  s += "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  if (!options.title.empty()) {
    s += "<text x=\"" + Num(0.5 * width) + "\" y=\"" + Num(kTop + 0.6 * kTitle) +
         "\" text-anchor=\"middle\" font-size=\"15\">" + Escape(options.title) + "</text>\n";
  }

  // Grid lines and tick labels of the latency axis.
  s += "<g class=\"y-axis\">\n";
  for (double ms : YTicks(y)) {
    const double yy = bottom - y(ms) * plot_h;
    s += "<line x1=\"" + Num(kLeft) + "\" y1=\"" + Num(yy) + "\" x2=\"" + Num(kLeft + plot_w) + "\" y2=\"" + Num(yy) +
         "\" stroke=\"" + kGridColour + "\"/>\n";
    s += "<text x=\"" + Num(kLeft - kTickLength - 3) + "\" y=\"" + Num(yy + 4) + "\" text-anchor=\"end\">" +
         svg::Label(ms, 4) + "</text>\n";
  }
  s += "<text transform=\"translate(" + Num(16) + " " + Num(top + 0.5 * plot_h) +
       ") rotate(-90)\" text-anchor=\"middle\">update latency [ms]" + (y.log ? " (log scale)" : "") + "</text>\n";
  s += "</g>\n";

  // Ticks and labels of the step axis.
  s += "<g class=\"x-axis\">\n";
  const double x_step = std::max(1.0, svg::NiceLength((x_hi - x_lo) / 6.0));
  for (double v = std::ceil(x_lo / x_step) * x_step; v <= x_hi; v += x_step) {
    const double xx = kLeft + (v - x_lo) / (x_hi - x_lo) * plot_w;
    s += "<line x1=\"" + Num(xx) + "\" y1=\"" + Num(bottom) + "\" x2=\"" + Num(xx) + "\" y2=\"" +
         Num(bottom + kTickLength) + "\" stroke=\"black\"/>\n";
    s += "<text x=\"" + Num(xx) + "\" y=\"" + Num(bottom + kTickLength + 13) + "\" text-anchor=\"middle\">" +
         svg::Label(v, 9) + "</text>\n";
  }
  s += "<text x=\"" + Num(kLeft + 0.5 * plot_w) + "\" y=\"" + Num(height - 8) +
       "\" text-anchor=\"middle\">step (poses added)</text>\n";
  s += "</g>\n";
  s += "<rect class=\"frame\" x=\"" + Num(kLeft) + "\" y=\"" + Num(top) + "\" width=\"" + Num(plot_w) + "\" height=\"" +
       Num(plot_h) + "\" fill=\"none\" stroke=\"black\"/>\n";

  // The latencies: one vertex per update.
  svg::PathData d;
  bool started = false;
  for (std::size_t k = 0; k < seconds.size(); ++k) {
    if (!std::isfinite(seconds[k])) continue;
    const Pt p = px(static_cast<double>(steps[k]), 1e3 * seconds[k]);
    if (!started) {
      d.MoveTo(p);
      started = true;
    } else {
      d.LineTo(p);
    }
  }
  if (!d.empty()) {
    s += "<path class=\"latencies\" fill=\"none\" stroke=\"" + std::string(kSeriesColour) +
         "\" stroke-width=\"0.7\" stroke-linejoin=\"round\" d=\"" + d.str() + "\"/>\n";
  }

  // Mean, p99 and max: dashed lines across the plot, their values at the right.
  const LatencyStats st = ComputeLatencyStats(seconds);
  if (!seconds.empty()) {
    s += "<g class=\"statistics\">\n";
    const StatLine lines[] = {{"mean", st.mean, "#2ca02c"}, {"p99", st.p99, "#ff7f0e"}, {"max", st.max, "#d62728"}};
    double last_label_y = -HUGE_VAL;
    for (const StatLine& l : lines) {
      const double yy = bottom - y(1e3 * l.seconds) * plot_h;
      s += "<line class=\"" + std::string(l.name) + "\" x1=\"" + Num(kLeft) + "\" y1=\"" + Num(yy) + "\" x2=\"" +
           Num(kLeft + plot_w) + "\" y2=\"" + Num(yy) + "\" stroke=\"" + l.colour +
           "\" stroke-width=\"1.2\" stroke-dasharray=\"6 4\"/>\n";
      // Labels go upwards in order mean, p99, max; keep them 14 px apart where the lines are close.
      double label_y = yy + 4;
      if (last_label_y != -HUGE_VAL) label_y = std::min(label_y, last_label_y - 14);
      last_label_y = label_y;
      s += "<text x=\"" + Num(kLeft + plot_w + 6) + "\" y=\"" + Num(label_y) + "\" fill=\"" + l.colour + "\">" +
           l.name + " " + svg::Label(1e3 * l.seconds, 4) + " ms</text>\n";
    }
    s += "</g>\n";
  }
  s += "</svg>\n";
  return s;
}

void WriteLatencySvgFile(const std::string& path, const std::vector<std::size_t>& steps,
                         const std::vector<double>& seconds, const LatencyPlotOptions& options) {
  WriteTextFile(path, RenderLatencySvg(steps, seconds, options), "latency plot");
}

}  // namespace tether
