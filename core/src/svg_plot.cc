#include "tether/core/svg_plot.h"

#include <algorithm>
#include <cmath>
#include <unordered_set>
#include <utility>
#include <vector>

#include "tether/core/error.h"
#include "tether/core/output_file.h"
#include "tether/core/svg_writer.h"
#include "tether/core/trajectory_error.h"

namespace tether {
namespace {

using svg::Escape;
using svg::NiceLength;
using svg::Num;
using svg::PathData;
using svg::Pt;

// Colours and sizes.
constexpr const char* kBeforeColour = "#b4b4b4";
constexpr const char* kAfterColour = "#1f5fbf";
constexpr const char* kLoopColour = "#d62728";
constexpr const char* kLandmarkColour = "#ff7f0e";
constexpr const char* kStartColour = "#2ca02c";
constexpr const char* kTruthColour = "#98df8a";
constexpr double kMargin = 16.0;        // around the plot area
constexpr double kTitleHeight = 28.0;   // band above the plot when there is a title
constexpr double kLegendHeight = 30.0;  // band below the plot
constexpr double kLandmarkSize = 4.0;   // side of a landmark square, pixels
/// Coordinates beyond this are treated like NaN (their differences would overflow).
constexpr double kHuge = 1e150;

bool Usable(const Pt& p) { return std::abs(p.x) < kHuge && std::abs(p.y) < kHuge; }  // false for NaN

bool Consecutive(Key a, Key b) { return (a > b ? a - b : b - a) == 1; }

/// Every variable layout starts with x, y (variable.h), so the projection is the first two.
Pt XY(const double* p) { return Pt{p[0], p[1]}; }

PlotLayer Extract(const Values& values, const FactorGraph& graph, const std::unordered_set<Key>& linked,
                  std::vector<std::pair<Pt, Pt>>* loops) {
  PlotLayer layer;
  layer.present = true;
  std::vector<std::pair<Key, Pt>> poses;
  poses.reserve(values.size());
  for (Key k : values.keys()) {
    const Pt p = XY(values.Params(k));
    if (!Usable(p)) continue;
    if (IsPose(values.TypeOf(k))) {
      poses.emplace_back(k, p);
    } else {
      layer.landmarks.push_back(p);
    }
  }
  std::sort(poses.begin(), poses.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const bool joined = i > 0 && poses[i].first == poses[i - 1].first + 1 && linked.count(poses[i - 1].first) != 0;
    if (!joined) layer.runs.emplace_back();
    layer.runs.back().push_back(poses[i].second);
  }
  if (loops != nullptr) {
    for (const auto& f : graph.factors()) {
      const std::vector<Key>& keys = f->keys();
      if (keys.size() != 2 || keys[0] == keys[1] || Consecutive(keys[0], keys[1])) continue;
      if (!values.Has(keys[0]) || !values.Has(keys[1])) continue;
      if (!IsPose(values.TypeOf(keys[0])) || !IsPose(values.TypeOf(keys[1]))) continue;
      const Pt a = XY(values.Params(keys[0])), b = XY(values.Params(keys[1]));
      if (Usable(a) && Usable(b)) loops->emplace_back(a, b);
    }
  }
  return layer;
}

/// World-to-pixel mapping with equal scale on both axes, y up.
struct Frame {
  double min_x = -1.0, max_y = 1.0;  // world corner drawn at (ox, oy)
  double scale = 1.0;                // pixels per metre
  double ox = 0.0, oy = 0.0;
  Pt operator()(const Pt& p) const { return Pt{ox + (p.x - min_x) * scale, oy + (max_y - p.y) * scale}; }
};

std::string LengthLabel(double metres) { return svg::Label(metres, 6) + " m"; }

void AppendPath(const PathData& d, const std::string& cls, const std::string& style, std::string* svg) {
  if (d.empty()) return;
  *svg += "<path class=\"" + cls + "\" " + style + " d=\"";
  *svg += d.str();
  *svg += "\"/>\n";
}

}  // namespace

bool PlotOptions::IsValid(std::string* why) const {
  std::string reason;
  if (width_px < 200 || width_px > 20000) {
    reason = "PlotOptions.width_px must be in [200, 20000] (got " + std::to_string(width_px) + ")";
  } else if (height_px != 0 && (height_px < 150 || height_px > 20000)) {
    reason = "PlotOptions.height_px must be 0 (automatic) or in [150, 20000] (got " + std::to_string(height_px) + ")";
  }
  if (why != nullptr) *why = reason;
  return reason.empty();
}

std::string RenderSvg(const FactorGraph& graph, const Values* before, const Values* after, const PlotOptions& options) {
  return RenderSvg(graph, before, after, nullptr, options);
}

PlotScene BuildPlotScene(const FactorGraph& graph, const Values* before, const Values* after, const Values* truth,
                         const PlotOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("RenderSvg: " + why);

  // Pairs (k, k+1) joined by a factor: the odometry that the trajectories follow.
  std::unordered_set<Key> linked;
  for (const auto& f : graph.factors()) {
    const std::vector<Key>& keys = f->keys();
    if (keys.size() == 2 && Consecutive(keys[0], keys[1])) linked.insert(std::min(keys[0], keys[1]));
  }
  PlotScene scene;
  const bool loops = options.draw_loop_closures;
  if (truth != nullptr) scene.truth = Extract(*truth, graph, linked, nullptr);
  scene.truth.landmarks.clear();
  if (before != nullptr) {
    scene.before = Extract(*before, graph, linked, loops && after == nullptr ? &scene.loop_closures : nullptr);
  }
  if (after != nullptr) scene.after = Extract(*after, graph, linked, loops ? &scene.loop_closures : nullptr);
  if (!options.draw_landmarks) {
    scene.before.landmarks.clear();
    scene.after.landmarks.clear();
  }
  // With a ground truth, each trajectory's ATE (rigid alignment; trajectory_error.h) follows its label.
  auto ate_label = [&](const Values* v, const std::string& text) {
    if (v == nullptr || truth == nullptr || !options.show_ate) return text;
    const TrajectoryError e = AbsoluteTrajectoryError(*v, *truth);
    return e.poses == 0 ? text : text + " (ATE " + FormatMetres(e.rmse) + ")";
  };
  scene.truth.label = options.truth_label;
  scene.before.label = ate_label(before, options.before_label);
  scene.after.label = ate_label(after, options.after_label);
  scene.truth.colour = kTruthColour;
  scene.before.colour = scene.before.landmark_colour = kBeforeColour;
  scene.after.colour = kAfterColour;
  scene.after.landmark_colour = kLandmarkColour;
  scene.loop_colour = kLoopColour;
  scene.start_colour = kStartColour;
  const PlotLayer& first = !scene.after.runs.empty() ? scene.after : scene.before;
  if (!first.runs.empty()) {
    scene.has_start = true;
    scene.start = first.runs[0][0];
  }
  return scene;
}

std::string RenderSvg(const FactorGraph& graph, const Values* before, const Values* after, const Values* truth,
                      const PlotOptions& options) {
  const PlotScene scene = BuildPlotScene(graph, before, after, truth, options);
  const PlotLayer &lb = scene.before, &la = scene.after, &lt = scene.truth;
  const std::vector<std::pair<Pt, Pt>>& loops = scene.loop_closures;

  // Bounds of everything drawn.
  double min_x = HUGE_VAL, max_x = -HUGE_VAL, min_y = HUGE_VAL, max_y = -HUGE_VAL;
  auto grow = [&](const Pt& p) {
    min_x = std::min(min_x, p.x);
    max_x = std::max(max_x, p.x);
    min_y = std::min(min_y, p.y);
    max_y = std::max(max_y, p.y);
  };
  for (const PlotLayer* l : {&lb, &la, &lt}) {
    for (const auto& run : l->runs)
      for (const Pt& p : run) grow(p);
    for (const Pt& p : l->landmarks) grow(p);
  }
  if (!(min_x <= max_x)) min_x = max_x = min_y = max_y = 0.0;  // nothing to draw
  double extent = std::max(max_x - min_x, max_y - min_y), pad = 0.04 * extent;
  if (!(extent > 0.0)) extent = 1.0, pad = 0.5;  // a single point: one metre around it
  min_x -= pad;
  max_x += pad;
  min_y -= pad;
  max_y += pad;
  const double dx = std::max(max_x - min_x, 1e-6 * extent), dy = std::max(max_y - min_y, 1e-6 * extent);

  // Layout: title band, plot area, legend band.
  const double width = options.width_px;
  const double top = kMargin + (options.title.empty() ? 0.0 : kTitleHeight);
  const double plot_w = width - 2.0 * kMargin;
  double plot_h;
  if (options.height_px > 0) {
    plot_h = std::max(10.0, options.height_px - top - kMargin - kLegendHeight);
  } else {
    plot_h = std::round(std::clamp(plot_w * dy / dx, 0.25 * plot_w, 1.5 * plot_w));
  }
  const double height = options.height_px > 0 ? options.height_px : top + plot_h + kMargin + kLegendHeight;

  Frame frame;
  frame.min_x = min_x;
  frame.max_y = max_y;
  frame.scale = std::min(plot_w / dx, plot_h / dy);
  frame.ox = kMargin + 0.5 * (plot_w - dx * frame.scale);
  frame.oy = top + 0.5 * (plot_h - dy * frame.scale);

  auto trajectory = [&](const PlotLayer& l) {
    PathData d;
    for (const auto& run : l.runs) {
      d.MoveTo(frame(run[0]));
      if (run.size() == 1) d.LineTo(frame(run[0]));  // zero length: a dot with round caps
      for (std::size_t i = 1; i < run.size(); ++i) d.LineTo(frame(run[i]));
    }
    return d;
  };
  auto squares = [&](const PlotLayer& l) {
    PathData d;
    for (const Pt& w : l.landmarks) {
      const Pt p = frame(w);
      d.MoveTo(Pt{p.x - 0.5 * kLandmarkSize, p.y - 0.5 * kLandmarkSize});
      d.LineTo(Pt{p.x + 0.5 * kLandmarkSize, p.y - 0.5 * kLandmarkSize});
      d.LineTo(Pt{p.x + 0.5 * kLandmarkSize, p.y + 0.5 * kLandmarkSize});
      d.LineTo(Pt{p.x - 0.5 * kLandmarkSize, p.y + 0.5 * kLandmarkSize});
      d.Close();
    }
    return d;
  };
  PathData loop_path;
  for (const auto& [a, b] : loops) {
    loop_path.MoveTo(frame(a));
    loop_path.LineTo(frame(b));
  }

  std::string svg;
  svg.reserve(4096);
  svg += "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + Num(width) + "\" height=\"" + Num(height) +
         "\" viewBox=\"0 0 " + Num(width) + " " + Num(height) + "\" font-family=\"sans-serif\">\n";
  if (!options.title.empty()) svg += "<title>" + Escape(options.title) + "</title>\n";
  svg += "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  svg += "<rect x=\"" + Num(kMargin) + "\" y=\"" + Num(top) + "\" width=\"" + Num(plot_w) + "\" height=\"" +
         Num(plot_h) + "\" fill=\"none\" stroke=\"#dddddd\"/>\n";
  if (!options.title.empty()) {
    svg += "<text x=\"" + Num(0.5 * width) + "\" y=\"" + Num(kMargin + 0.6 * kTitleHeight) +
           "\" text-anchor=\"middle\" font-size=\"15\">" + Escape(options.title) + "</text>\n";
  }
  const std::string line_style =
      "fill=\"none\" stroke-width=\"1.2\" stroke-linecap=\"round\" stroke-linejoin=\"round\"";
  AppendPath(trajectory(lt), "ground-truth",
             "stroke=\"" + std::string(kTruthColour) +
                 "\" fill=\"none\" stroke-width=\"4\" stroke-linecap=\"round\" stroke-linejoin=\"round\"",
             &svg);
  AppendPath(trajectory(lb), "before", "stroke=\"" + std::string(kBeforeColour) + "\" " + line_style, &svg);
  AppendPath(trajectory(la), "after", "stroke=\"" + std::string(kAfterColour) + "\" " + line_style, &svg);
  AppendPath(loop_path, "loop-closures",
             "fill=\"none\" stroke=\"" + std::string(kLoopColour) + "\" stroke-width=\"0.5\" stroke-opacity=\"0.6\"",
             &svg);
  AppendPath(squares(lb), "landmarks-before", "fill=\"" + std::string(kBeforeColour) + "\"", &svg);
  AppendPath(squares(la), "landmarks", "fill=\"" + std::string(kLandmarkColour) + "\"", &svg);
  if (scene.has_start) {
    const Pt s = frame(scene.start);
    svg += "<circle class=\"start\" cx=\"" + Num(s.x) + "\" cy=\"" + Num(s.y) + "\" r=\"3.5\" fill=\"none\" stroke=\"" +
           kStartColour + "\" stroke-width=\"1.5\"/>\n";
  }

  // Legend: a swatch and a label for each thing present, left to right.
  const double legend_y = top + plot_h + kMargin + 0.5 * kLegendHeight;
  double x = kMargin;
  svg += "<g class=\"legend\" font-size=\"12\">\n";
  auto label = [&](const std::string& text) {
    svg += "<text x=\"" + Num(x + 28.0) + "\" y=\"" + Num(legend_y + 4.0) + "\">" + Escape(text) + "</text>\n";
    x += 28.0 + 7.0 * static_cast<double>(text.size()) + 18.0;
  };
  auto line_item = [&](const char* colour, double stroke_width, const std::string& text) {
    svg += "<line x1=\"" + Num(x) + "\" y1=\"" + Num(legend_y) + "\" x2=\"" + Num(x + 22.0) + "\" y2=\"" +
           Num(legend_y) + "\" stroke=\"" + colour + "\" stroke-width=\"" + Num(stroke_width) + "\"/>\n";
    label(text);
  };
  if (lt.present) line_item(kTruthColour, 4.0, lt.label);
  if (lb.present) line_item(kBeforeColour, 2.0, lb.label);
  if (la.present) line_item(kAfterColour, 2.0, la.label);
  if (!loops.empty()) line_item(kLoopColour, 1.0, "loop closures");
  if (!la.landmarks.empty() || !lb.landmarks.empty()) {
    svg += "<rect x=\"" + Num(x + 9.0) + "\" y=\"" + Num(legend_y - 2.0) + "\" width=\"4\" height=\"4\" fill=\"" +
           (la.landmarks.empty() ? kBeforeColour : kLandmarkColour) + "\"/>\n";
    label("landmarks");
  }
  svg += "</g>\n";

  // Scale bar at the right of the legend band: a round length near a fifth of the plot width.
  const double bar_m = NiceLength(0.2 * plot_w / frame.scale);
  const double bar_px = bar_m * frame.scale;
  const double x1 = width - kMargin, x0 = x1 - bar_px;
  svg += "<g class=\"scale-bar\" stroke=\"black\" stroke-width=\"1\">\n";
  svg += "<path d=\"M" + Num(x0) + " " + Num(legend_y - 4.0) + "v8M" + Num(x0) + " " + Num(legend_y) + "H" + Num(x1) +
         "M" + Num(x1) + " " + Num(legend_y - 4.0) + "v8\"/>\n";
  svg += "<text x=\"" + Num(x0 - 6.0) + "\" y=\"" + Num(legend_y + 4.0) +
         "\" text-anchor=\"end\" font-size=\"12\" stroke=\"none\">" + LengthLabel(bar_m) + "</text>\n";
  svg += "</g>\n";
  svg += "</svg>\n";
  return svg;
}

void WriteSvgFile(const std::string& path, const FactorGraph& graph, const Values* before, const Values* after,
                  const PlotOptions& options) {
  WriteSvgFile(path, graph, before, after, nullptr, options);
}

void WriteSvgFile(const std::string& path, const FactorGraph& graph, const Values* before, const Values* after,
                  const Values* truth, const PlotOptions& options) {
  WriteTextFile(path, RenderSvg(graph, before, after, truth, options), "SVG plot");
}

}  // namespace tether
