#pragma once
// SVG plots of a graph's trajectory before and after optimisation, and of the ground truth
// where it is known.
//
// What is drawn (3D variables as their x-y projection, y axis up, equal scale on both axes,
// bounds fitted to everything drawn with a small margin):
// - the `before` trajectory in light grey and the `after` trajectory in blue, each one <path>:
//   poses (SE2/SE3 variables) in key order, pose k joined to pose k+1 wherever a two-key
//   factor links them (odometry); a pose with no such neighbour is drawn as a dot;
// - loop closures, in thin red, one <path> of segments: two-key factors between poses whose
//   keys are not consecutive, at the positions of `after` (of `before` when `after` is null);
// - landmarks (Point2/Point3 variables) as small squares, orange for `after`, grey for
//   `before`, one <path> each;
// - the `truth` trajectory (optional), joined the same way, as a wide light-green band under
//   the others, so a result on the truth runs along its middle;
// - a green circle at the first pose, a legend of what is present, and a scale bar. With a
//   truth, the legend gives the absolute trajectory error of `before` and `after` against it
//   (RMSE of the positions after the best rigid alignment; trajectory_error.h).
// Either Values pointer may be null (then only the other is drawn). Variables whose
// coordinates are not finite are left out. Coordinates are written in pixels rounded to 0.01,
// as relative path commands, so 100k poses make a file of a few megabytes with a few elements.
#include <string>
#include <utility>
#include <vector>

#include "tether/core/factor_graph.h"
#include "tether/core/svg_writer.h"
#include "tether/core/values.h"

namespace tether {

struct PlotOptions {
  /// Drawn above the plot (nothing when empty).
  std::string title;
  /// Width of the picture in pixels, in [200, 20000].
  int width_px = 900;
  /// Height in pixels, in [150, 20000]; 0 chooses it from the data's aspect ratio.
  int height_px = 0;
  /// Legend labels.
  std::string before_label = "before";
  std::string after_label = "after";
  std::string truth_label = "ground truth";
  /// Append "(ATE x m)" to the before and after labels where a truth is drawn.
  bool show_ate = true;
  bool draw_loop_closures = true;
  bool draw_landmarks = true;

  /// True when the options can be used; otherwise says why (when `why` is not null).
  bool IsValid(std::string* why) const;
};

/// The SVG document (starting "<svg", ending "</svg>\n"). Throws InvalidArgument for invalid
/// options.
std::string RenderSvg(const FactorGraph& graph, const Values* before, const Values* after,
                      const PlotOptions& options = {});

/// The same with the ground truth drawn too (`truth` may be null).
std::string RenderSvg(const FactorGraph& graph, const Values* before, const Values* after, const Values* truth,
                      const PlotOptions& options = {});

/// What one set of values contributes to the picture, in world coordinates (metres).
struct PlotLayer {
  bool present = false;                    ///< the values were given
  std::vector<std::vector<svg::Pt>> runs;  ///< the trajectory: runs of poses joined by odometry
  std::vector<svg::Pt> landmarks;          ///< the other variables (none for the truth)
  std::string label;                       ///< the legend's text (with the ATE, as above)
  std::string colour;                      ///< "#rrggbb" of the trajectory
  std::string landmark_colour;             ///< "#rrggbb" of the landmarks
};

/// Everything a plot draws, in world coordinates: what RenderSvg draws, for any other
/// renderer (Python's tether.plot draws it with matplotlib).
struct PlotScene {
  PlotLayer truth, before, after;
  std::vector<std::pair<svg::Pt, svg::Pt>> loop_closures;  ///< the segments, as above
  std::string loop_colour, start_colour;
  bool has_start = false;
  svg::Pt start;  ///< the first pose drawn (of `after`, else of `before`)
};

/// The scene of RenderSvg's arguments. Throws InvalidArgument for invalid options.
PlotScene BuildPlotScene(const FactorGraph& graph, const Values* before, const Values* after, const Values* truth,
                         const PlotOptions& options = {});

/// Writes RenderSvg's output to `path`, through a temporary file renamed into place, so a
/// failure never leaves half a file. Throws IoError naming `path` when it cannot be written.
void WriteSvgFile(const std::string& path, const FactorGraph& graph, const Values* before, const Values* after,
                  const PlotOptions& options = {});

/// The same with the ground truth drawn too (`truth` may be null).
void WriteSvgFile(const std::string& path, const FactorGraph& graph, const Values* before, const Values* after,
                  const Values* truth, const PlotOptions& options = {});

}  // namespace tether
