// Measuring and drawing results: the absolute trajectory error and the SVG plot of a graph's
// trajectory, the same code `tether optimize --ground-truth --plot` uses.
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

}  // namespace python
}  // namespace tether
