#pragma once
// The latencies of a sequence of updates (`tether replay --plot`): their statistics, and an
// SVG picture of them.
//
// The picture: x is the step each update was made at, y its latency in milliseconds (a log
// axis by default: skipped updates take microseconds, loop closures hundreds of
// milliseconds); one <path class="latencies"> with one vertex per update, in order; dashed
// horizontal lines at the mean, the p99 and the max, labelled with their values at the right;
// both axes with ticks and labels; the title above. Coordinates are rounded to 0.01 pixel and
// written as relative path commands, so 100k updates make a file of about a megabyte.
#include <cstddef>
#include <string>
#include <vector>

namespace tether {

/// Mean, p99 and max of latencies (seconds). p99 is the nearest rank: the smallest latency
/// that at least 99% of them do not exceed. All 0 for no latencies.
struct LatencyStats {
  double sum = 0, mean = 0, p99 = 0, max = 0;
};
LatencyStats ComputeLatencyStats(const std::vector<double>& seconds);

struct LatencyPlotOptions {
  /// Drawn above the plot (nothing when empty).
  std::string title;
  /// The picture's size in pixels: width in [300, 20000], height in [200, 20000].
  int width_px = 960;
  int height_px = 440;
  /// A log-scale latency axis (decades); false: linear from 0.
  bool log_y = true;

  /// True when the options can be used; otherwise says why (when `why` is not null).
  bool IsValid(std::string* why) const;
};

/// The SVG document (starting "<svg", ending "</svg>\n") of update k made at steps[k] taking
/// seconds[k]. Throws InvalidArgument for invalid options or lists of different lengths.
/// Latencies that are not finite are left out of the path; on the log axis, latencies at or
/// below zero are drawn at the bottom of the axis.
std::string RenderLatencySvg(const std::vector<std::size_t>& steps, const std::vector<double>& seconds,
                             const LatencyPlotOptions& options = {});

/// Writes RenderLatencySvg's output to `path` through a temporary file renamed into place.
/// Throws IoError naming `path` when it cannot be written.
void WriteLatencySvgFile(const std::string& path, const std::vector<std::size_t>& steps,
                         const std::vector<double>& seconds, const LatencyPlotOptions& options = {});

}  // namespace tether
