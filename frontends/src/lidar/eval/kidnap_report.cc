#include "tether/frontends/lidar/eval/kidnap_report.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <sstream>

#include "tether/core/svg_writer.h"

namespace tether {
namespace lidar {

std::string KidnapCsv(const std::vector<KidnapRecord>& records, double first_stamp) {
  std::ostringstream c;
  c.precision(9);
  c << "# scan t trajectory matched cost filtered ratio overlap hit_fraction cost_rule broke detected relocated\n";
  for (const KidnapRecord& r : records) {
    c << r.scan + 1 << ' ' << r.stamp - first_stamp << ' ' << r.trajectory << ' ' << (r.matched ? 1 : 0) << ' '
      << r.cost << ' ' << r.filtered << ' ' << r.ratio << ' ' << r.overlap << ' ' << r.hit_fraction << ' '
      << (r.cost_rule ? 1 : 0) << ' ' << (r.broke ? 1 : 0) << ' ' << (r.detected ? 1 : 0) << ' '
      << (r.relocated ? 1 : 0) << '\n';
  }
  return c.str();
}

namespace {

constexpr double kWidth = 960, kLeft = 60, kRight = 20, kTop = 30, kPanel = 170, kGap = 30;

struct Panel {
  double top = 0, lo = 0, hi = 1;
  double Y(double v) const {
    const double u = (std::min(std::max(v, lo), hi) - lo) / (hi - lo);
    return top + kPanel * (1 - u);
  }
};

std::string Line(double x1, double y1, double x2, double y2, const std::string& style) {
  return "<line x1=\"" + svg::Num(x1) + "\" y1=\"" + svg::Num(y1) + "\" x2=\"" + svg::Num(x2) + "\" y2=\"" +
         svg::Num(y2) + "\" " + style + "/>\n";
}

std::string Text(double x, double y, const std::string& s, const std::string& style = "") {
  return "<text x=\"" + svg::Num(x) + "\" y=\"" + svg::Num(y) + "\" font-size=\"12\" " + style + ">" + svg::Escape(s) +
         "</text>\n";
}

}  // namespace

std::string KidnapSvg(const std::vector<KidnapRecord>& records, const KidnapOptions& options) {
  const double n = std::max<double>(2, static_cast<double>(records.size()));
  const auto x = [&](long scan) { return kLeft + (kWidth - kLeft - kRight) * static_cast<double>(scan) / (n - 1); };
  double max_cost = 0.5, max_ratio = options.threshold * 1.25;
  for (const KidnapRecord& r : records) {
    if (!r.matched) continue;
    max_cost = std::max(max_cost, r.cost);
    max_ratio = std::max(max_ratio, r.ratio);
  }
  const Panel cost{kTop, 0, std::min(1.0, max_cost * 1.1)};
  const Panel ratio{kTop + kPanel + kGap, 0.5, std::min(max_ratio * 1.05, 10.0)};
  const Panel hits{kTop + 2 * (kPanel + kGap), 0, 1};  // the overlap
  const double height = hits.top + kPanel + 40;
  std::string s = "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + svg::Num(kWidth) + "\" height=\"" +
                  svg::Num(height) +
                  "\" font-family=\"sans-serif\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  s += Text(kLeft, 18,
            "Kidnap detection: filter size " + std::to_string(options.filter_size) +
                ", T = " + svg::Label(options.threshold, 3));
  const auto frame = [&](const Panel& p, const std::string& label) {
    s += "<rect x=\"" + svg::Num(kLeft) + "\" y=\"" + svg::Num(p.top) + "\" width=\"" +
         svg::Num(kWidth - kLeft - kRight) + "\" height=\"" + svg::Num(kPanel) + "\" fill=\"none\" stroke=\"#888\"/>\n";
    s += Text(kLeft + 6, p.top + 14, label);
    s += Text(4, p.top + 10, svg::Label(p.hi, 3));
    s += Text(4, p.top + kPanel, svg::Label(p.lo, 3));
  };
  frame(cost, "match cost (grey) and filtered (blue)");
  frame(ratio, "filtered cost / the last filtered value before its window");
  frame(hits, "share of the points near the scan before's (overlap)");
  const auto path = [&](const Panel& p, const std::function<double(const KidnapRecord&)>& value,
                        const std::string& style) {
    svg::PathData d;
    bool pen = false;
    for (const KidnapRecord& r : records) {
      const double v = value(r);
      if (!r.matched || !std::isfinite(v)) {
        pen = false;
        continue;
      }
      const svg::Pt pt{x(r.scan), p.Y(v)};
      if (pen) {
        d.LineTo(pt);
      } else {
        d.MoveTo(pt);
      }
      pen = true;
    }
    if (!d.empty()) s += "<path d=\"" + d.str() + "\" fill=\"none\" " + style + "/>\n";
  };
  path(
      cost, [](const KidnapRecord& r) { return r.cost; }, "stroke=\"#aaa\" stroke-width=\"0.8\"");
  path(
      cost, [](const KidnapRecord& r) { return r.filtered; }, "stroke=\"#1f5fbf\" stroke-width=\"1.2\"");
  path(
      ratio, [](const KidnapRecord& r) { return r.ratio > 0 ? r.ratio : NAN; },
      "stroke=\"#1f5fbf\" stroke-width=\"1\"");
  path(
      hits, [](const KidnapRecord& r) { return r.overlap >= 0 ? r.overlap : NAN; },
      "stroke=\"#2a9d3a\" stroke-width=\"0.8\"");
  const double x0 = kLeft, x1 = kWidth - kRight;
  s += Line(x0, ratio.Y(options.threshold), x1, ratio.Y(options.threshold),
            "stroke=\"#d62728\" stroke-dasharray=\"6 4\"");
  s += Text(x1 - 60, ratio.Y(options.threshold) - 4, "T = " + svg::Label(options.threshold, 3), "fill=\"#d62728\"");
  s += Line(x0, hits.Y(options.max_overlap), x1, hits.Y(options.max_overlap),
            "stroke=\"#e08000\" stroke-dasharray=\"6 4\"");
  for (const KidnapRecord& r : records) {
    if (r.detected) {
      s += Line(x(r.scan), cost.top, x(r.scan), hits.top + kPanel, "stroke=\"#d62728\" stroke-width=\"1.5\"");
      s += Text(x(r.scan) + 3, cost.top + 28,
                (r.relocated ? "lost, found nearby at scan " : "kidnap declared at scan ") + std::to_string(r.scan + 1),
                "fill=\"#d62728\"");
    }
    if (r.broke) {
      s += Line(x(r.scan), hits.top + kPanel, x(r.scan), hits.top + kPanel - 8, "stroke=\"#e08000\"");
    }
  }
  s += Text(kLeft, height - 12, "scan 1 .. " + std::to_string(records.size()));
  s += "</svg>\n";
  return s;
}

}  // namespace lidar
}  // namespace tether
