// Measuring and drawing results: the absolute trajectory error and the SVG plot of a graph's
// trajectory, the same code `tether optimize --ground-truth --plot` uses.
#include <cmath>
#include <optional>

#include "common.h"
#include "tether/core/output_file.h"
#include "tether/core/svg_plot.h"
#include "tether/core/trajectory_error.h"
#include "tether/factors/builtin.h"
#include "tether/plugins/plugin_check.h"

namespace tether {
namespace python {

namespace {

AteAlignment AlignmentFrom(const std::string& s) {
  if (s == "rigid") return AteAlignment::kRigid;
  if (s == "none") return AteAlignment::kNone;
  throw InvalidArgument("unknown alignment '" + s + "'; use rigid or none");
}

std::string Render(const FactorGraph& graph, const Values* before, const Values* after, const Values* truth,
                   const PlotOptions& options) {
  const InUse::Scope graph_read(&graph, "FactorGraph", "plot_svg", InUse::Access::kRead);
  std::optional<InUse::Scope> reads[3];  // reading one Values twice is fine
  const Values* all[3] = {before, after, truth};
  for (int i = 0; i < 3; ++i) {
    if (all[i] != nullptr) reads[i].emplace(all[i], "Values", "plot_svg", InUse::Access::kRead);
  }
  py::gil_scoped_release release;
  return RenderSvg(graph, before, after, truth, options);
}

// The x and the y of the runs one after another, a NaN between two runs: one line for matplotlib.
std::pair<DoubleArray, DoubleArray> RunsXY(const std::vector<std::vector<svg::Pt>>& runs) {
  std::size_t n = 0;
  for (const auto& r : runs) n += r.size() + 1;
  const py::ssize_t size = static_cast<py::ssize_t>(n == 0 ? 0 : n - 1);
  DoubleArray x(size), y(size);
  double *px = x.mutable_data(), *py_ = y.mutable_data();
  for (std::size_t i = 0; i < runs.size(); ++i) {
    if (i > 0) *px++ = NAN, *py_++ = NAN;
    for (const svg::Pt& q : runs[i]) *px++ = q.x, *py_++ = q.y;
  }
  return {x, y};
}

// Draws the scene on a matplotlib Axes (a new figure where `ax` is None); the Axes.
py::object DrawWithMatplotlib(const PlotScene& scene, const PlotOptions& options, py::object ax) {
  using namespace pybind11::literals;
  if (ax.is_none()) {
    const py::module_ plt = py::module_::import("matplotlib.pyplot");
    const double w = options.width_px / 100.0;
    const double h = options.height_px > 0 ? options.height_px / 100.0 : 0.75 * w;
    ax = plt.attr("subplots")("figsize"_a = py::make_tuple(w, h)).cast<py::tuple>()[1];
  }
  const auto line = [&ax](const PlotLayer& l, double width, int z) {
    if (!l.present) return;
    const auto [x, y] = RunsXY(l.runs);
    ax.attr("plot")(x, y, "color"_a = l.colour, "linewidth"_a = width, "label"_a = l.label, "zorder"_a = z,
                    "solid_capstyle"_a = "round");
  };
  line(scene.truth, 4.0, 1);
  line(scene.before, 1.2, 2);
  line(scene.after, 1.2, 3);
  if (!scene.loop_closures.empty()) {
    std::vector<std::vector<svg::Pt>> segments;
    for (const auto& [a, b] : scene.loop_closures) segments.push_back({a, b});
    const auto [x, y] = RunsXY(segments);
    ax.attr("plot")(x, y, "color"_a = scene.loop_colour, "linewidth"_a = 0.5, "alpha"_a = 0.6,
                    "label"_a = "loop closures", "zorder"_a = 4);
  }
  for (const PlotLayer* l : {&scene.before, &scene.after}) {
    if (l->landmarks.empty()) continue;
    const auto [x, y] = RunsXY({l->landmarks});
    ax.attr("scatter")(x, y, "s"_a = 9, "marker"_a = "s", "color"_a = l->landmark_colour, "zorder"_a = 5,
                       "label"_a = l == &scene.after || scene.after.landmarks.empty() ? "landmarks" : "_nolegend_");
  }
  if (scene.has_start) {
    ax.attr("plot")(scene.start.x, scene.start.y, "marker"_a = "o", "markerfacecolor"_a = "none",
                    "color"_a = scene.start_colour, "label"_a = "start", "zorder"_a = 6);
  }
  ax.attr("set_aspect")("equal", "adjustable"_a = "datalim");
  if (!options.title.empty()) ax.attr("set_title")(options.title);
  ax.attr("legend")("loc"_a = "best", "fontsize"_a = "small");
  return ax;
}

bool HaveMatplotlib() {
  try {
    py::module_::import("matplotlib");
    return true;
  } catch (const py::error_already_set& e) {
    if (!e.matches(PyExc_ImportError)) throw;
    return false;
  }
}

py::object Plot(const FactorGraph& graph, const Values* before, const Values* after, const Values* truth,
                const PlotOptions& options, const py::object& ax, const std::string& path, const std::string& backend) {
  if (backend != "auto" && backend != "matplotlib" && backend != "svg") {
    throw InvalidArgument("unknown plot backend '" + backend + "'; use auto, matplotlib or svg");
  }
  const bool matplotlib = backend == "matplotlib" || (backend == "auto" && HaveMatplotlib());
  if (!matplotlib) {
    if (!ax.is_none()) {
      throw InvalidArgument(
          "an Axes (ax) needs matplotlib, which is not installed (Debian: apt-get install "
          "python3-matplotlib); without ax the plot is drawn as SVG");
    }
    const std::string svg = Render(graph, before, after, truth, options);
    if (!path.empty()) {
      OutputFile file(path, "plot");
      file.Stage(svg);
      file.Commit();
    }
    return py::str(svg);
  }
  if (backend == "matplotlib" && !HaveMatplotlib()) {
    throw InvalidArgument(
        "backend 'matplotlib': matplotlib is not installed (Debian: apt-get install "
        "python3-matplotlib); backend 'svg' draws the same picture as SVG");
  }
  PlotScene scene;
  {
    const InUse::Scope graph_read(&graph, "FactorGraph", "plot", InUse::Access::kRead);
    std::optional<InUse::Scope> reads[3];
    const Values* all[3] = {before, after, truth};
    for (int i = 0; i < 3; ++i) {
      if (all[i] != nullptr) reads[i].emplace(all[i], "Values", "plot", InUse::Access::kRead);
    }
    scene = BuildPlotScene(graph, before, after, truth, options);
  }
  py::object axes = DrawWithMatplotlib(scene, options, ax);
  if (!path.empty()) axes.attr("figure").attr("savefig")(path);
  return axes;
}

}  // namespace

void BindEvaluation(py::module_& m) {
  py::class_<TrajectoryError>(m, "TrajectoryError", "The absolute trajectory error (positions, metres).")
      .def_readonly("poses", &TrajectoryError::poses, "poses compared (keys that are poses in both)")
      .def_readonly("rmse", &TrajectoryError::rmse)
      .def_readonly("mean", &TrajectoryError::mean)
      .def_readonly("max", &TrajectoryError::max)
      .def("__repr__", [](const TrajectoryError& e) {
        return "TrajectoryError(poses=" + std::to_string(e.poses) + ", rmse=" + FormatMetres(e.rmse) +
               ", max=" + FormatMetres(e.max) + ")";
      });
  m.def(
      "absolute_trajectory_error",
      [](const Values& estimate, const Values& truth, const std::string& alignment) {
        const AteAlignment a = AlignmentFrom(alignment);
        const InUse::Scope e(&estimate, "Values", "absolute_trajectory_error", InUse::Access::kRead);
        const InUse::Scope t(&truth, "Values", "absolute_trajectory_error", InUse::Access::kRead);
        return AbsoluteTrajectoryError(estimate, truth, a);
      },
      py::arg("estimate"), py::arg("truth"), py::arg("alignment") = "rigid",
      "The ATE of the poses whose keys are in both: 'rigid' after the best rotation and translation (no "
      "scale), 'none' as they are. poses == 0 (NaN errors) where nothing could be compared.");

  py::class_<PlotOptions>(m, "PlotOptions", "What plot_svg draws (tether/core/svg_plot.h).")
      .def(py::init<>())
      .def_readwrite("title", &PlotOptions::title)
      .def_readwrite("width_px", &PlotOptions::width_px)
      .def_readwrite("height_px", &PlotOptions::height_px, "0: from the data's aspect ratio")
      .def_readwrite("before_label", &PlotOptions::before_label)
      .def_readwrite("after_label", &PlotOptions::after_label)
      .def_readwrite("truth_label", &PlotOptions::truth_label)
      .def_readwrite("show_ate", &PlotOptions::show_ate)
      .def_readwrite("draw_loop_closures", &PlotOptions::draw_loop_closures)
      .def_readwrite("draw_landmarks", &PlotOptions::draw_landmarks);
  m.def("plot_svg", &Render, py::arg("graph"), py::arg("before") = nullptr, py::arg("after") = nullptr,
        py::arg("truth") = nullptr, py::arg("options") = PlotOptions(),
        "An SVG document of the trajectory: `before` (the start, grey, its first pose marked as the start), "
        "`after` (the result, blue), `truth` (a green band), loop closures and landmarks. Any of the three may be "
        "None. Write it with open(path, 'w').write(...), or see write_svg.");
  m.def(
      "write_svg",
      [](const std::string& path, const FactorGraph& graph, const Values* before, const Values* after,
         const Values* truth, const PlotOptions& options) {
        const std::string svg = Render(graph, before, after, truth, options);
        OutputFile file(path, "plot");
        file.Stage(svg);
        file.Commit();
      },
      py::arg("path"), py::arg("graph"), py::arg("before") = nullptr, py::arg("after") = nullptr,
      py::arg("truth") = nullptr, py::arg("options") = PlotOptions(),
      "plot_svg written to `path` through a temporary file renamed into place (never half a file).");

  m.def("plot", &Plot, py::arg("graph"), py::arg("before") = nullptr, py::arg("after") = nullptr,
        py::arg("truth") = nullptr, py::arg("options") = PlotOptions(), py::arg("ax") = py::none(),
        py::arg("path") = "", py::arg("backend") = "auto",
        "The plotting helper: what plot_svg draws (the start grey, its first pose marked as the start, the result "
        "blue, the truth a green band, loop closures, landmarks, the ATE in the labels). With matplotlib (Debian's "
        "python3-matplotlib; backend 'auto' uses it where it is installed) it draws on `ax` (a new figure's Axes "
        "where None), saves to `path` where given, and returns the Axes; otherwise (backend 'svg') it returns the "
        "SVG text and writes it to `path` where given.");
  py::class_<FactorTypeCheck>(m, "FactorTypeCheck", "One factor type's Jacobian check at random points.")
      .def_readonly("type", &FactorTypeCheck::type)
      .def_readonly("trials", &FactorTypeCheck::trials)
      .def_readonly("failed", &FactorTypeCheck::failed, "trials whose Jacobians did not match")
      .def_readonly("refused", &FactorTypeCheck::refused, "trials whose measurement the type's factory refused")
      .def_readonly("largest", &FactorTypeCheck::largest, "the largest |analytic - numeric|")
      .def_readonly("first_failure", &FactorTypeCheck::first_failure)
      .def_property_readonly("ok", &FactorTypeCheck::ok)
      .def("__repr__", &FactorTypeCheck::Line);
  m.def(
      "check_factor_types",
      [](const std::vector<std::string>& type_names, int trials, std::uint64_t seed, double tolerance) {
        FactorTypeCheckOptions o;
        o.trials = trials;
        o.seed = seed;
        o.jacobian.absolute_tolerance = o.jacobian.relative_tolerance = tolerance;
        py::gil_scoped_release release;
        return CheckFactorTypes(DefaultRegistry(), type_names, o);
      },
      py::arg("type_names"), py::arg("trials") = 100, py::arg("seed") = 7, py::arg("tolerance") = 1e-6,
      "Checks the Jacobians of the named factor types (a loaded plugin's LoadedPlugin.type_names, or built-in "
      "ones) against central differences at random points, as `tether check-plugin` does.");
}
TETHER_PYTHON_PART(70, BindEvaluation);

}  // namespace python
}  // namespace tether
