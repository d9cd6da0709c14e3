// Solving: SolverOptions / SolverSummary, optimize() (GIL released, a Python iteration
// callback that can stop the solve), marginal covariances, the incremental smoother, the
// pipeline (read, initialise, optimise, write) and plugins.
#include <limits>
#include <optional>
#include <sstream>

#include "common.h"
#include "tether/core/graph_io.h"
#include "tether/factors/builtin.h"
#include "tether/plugins/plugin_loader.h"
#include "tether/solvers/covariance.h"
#include "tether/solvers/fixed_lag_smoother.h"
#include "tether/solvers/incremental_smoother.h"
#include "tether/solvers/initialize.h"
#include "tether/solvers/optimizer.h"
#include "tether/solvers/pipeline.h"

namespace tether {
namespace python {

namespace {

template <class E>
E EnumFrom(const std::string& s, const char* what, const std::string& names) {
  E e;
  if (!FromString(s, &e)) throw InvalidArgument("unknown " + std::string(what) + " '" + s + "'; use " + names);
  return e;
}

// An enum with a name table (tether/core/enum_names.h) from its name; the error lists the names.
template <class E, class = IfNamedEnum<E>>
E NamedFrom(const std::string& s, const char* what) {
  return EnumFrom<E>(s, what, EnumNameList<E>());
}

// The Python iteration callback as SolverOptions::keep_going: called with the GIL held;
// returning False (not None) stops the solve (status "stopped"); an exception it raises is
// kept and raised again by optimize().
bool CallPython(const py::object& fn, const IterationSummary& it) {
  py::gil_scoped_acquire gil;
  try {
    const py::object r = fn(it);
    return r.is_none() || r.cast<bool>();
  } catch (py::error_already_set&) {
    PendingPythonError::Keep();
    throw Error("the iteration callback raised an exception");
  } catch (const py::cast_error&) {
    throw InvalidArgument("the iteration callback must return None, True or False");
  }
}

SolverSummary OptimizeFromPython(const FactorGraph& graph, Values& values, SolverOptions options,
                                 const py::object& callback) {
  if (!callback.is_none()) {
    if (!PyCallable_Check(callback.ptr())) throw InvalidArgument("optimize: callback must be callable or None");
    options.keep_going = [&callback](const IterationSummary& it) { return CallPython(callback, it); };
  }
  InUse::Check(&values, "Values", InUse::Access::kWrite);
  // Python factors raise into this call's own slot, on this thread (PendingPythonError).
  if (options.num_threads > 1 && HasPythonFactor(graph)) options.num_threads = 1;
  const InUse::Scope reading(&graph, "FactorGraph", "optimize", InUse::Access::kRead);
  const InUse::Scope writing(&values, "Values", "optimize", InUse::Access::kWrite);
  return Guarded([&] {
    py::gil_scoped_release release;
    return Optimize(graph, &values, options);
  });
}

void BindOptions(py::module_& m) {
  py::class_<IterationSummary>(m, "IterationSummary", "One row of the iteration log (the CLI's table).")
      .def_readonly("iteration", &IterationSummary::iteration, "0 is the initial state")
      .def_readonly("chi2", &IterationSummary::chi2, "after this iteration (of the accepted state)")
      .def_readonly("relative_decrease", &IterationSummary::relative_decrease)
      .def_readonly("lambda_", &IterationSummary::lambda, "LM damping (0 for GN and dog-leg)")
      .def_readonly("trust_radius", &IterationSummary::trust_radius)
      .def_readonly("step_norm", &IterationSummary::step_norm)
      .def_readonly("seconds", &IterationSummary::seconds, "since the solve started")
      .def_readonly("accepted", &IterationSummary::accepted)
      .def_readonly("step_halvings", &IterationSummary::step_halvings)
      .def_readonly("reused_factorization", &IterationSummary::reused_factorization)
      .def_readonly("cg_iterations", &IterationSummary::cg_iterations)
      .def("__repr__",
           [](const IterationSummary& it) {
             std::ostringstream s;
             s << "IterationSummary(iteration=" << it.iteration << ", chi2=" << it.chi2
               << ", relative_decrease=" << it.relative_decrease << ", lambda_=" << it.lambda
               << ", step_norm=" << it.step_norm << ", seconds=" << it.seconds << ", accepted=" << it.accepted << ")";
             return s.str();
           })
      // `lambda` is a Python keyword: it.lambda_ or getattr(it, "lambda").
      .def_property_readonly("lambda", [](const IterationSummary& it) { return it.lambda; });

  py::class_<LevenbergMarquardtOptions>(m, "LevenbergMarquardtOptions")
      .def(py::init<>())
      .def_readwrite("initial_lambda", &LevenbergMarquardtOptions::initial_lambda)
      .def_readwrite("min_lambda", &LevenbergMarquardtOptions::min_lambda)
      .def_readwrite("max_step_halvings", &LevenbergMarquardtOptions::max_step_halvings)
      .def_readwrite("max_lambda", &LevenbergMarquardtOptions::max_lambda);
  py::class_<DogLegOptions>(m, "DogLegOptions")
      .def(py::init<>())
      .def_readwrite("initial_radius", &DogLegOptions::initial_radius)
      .def_readwrite("min_radius", &DogLegOptions::min_radius)
      .def_readwrite("max_radius", &DogLegOptions::max_radius)
      .def_readwrite("grow_above", &DogLegOptions::grow_above)
      .def_readwrite("shrink_below", &DogLegOptions::shrink_below)
      .def_readwrite("grow_factor", &DogLegOptions::grow_factor)
      .def_readwrite("shrink_factor", &DogLegOptions::shrink_factor);
  py::class_<LinearSolverOptions>(m, "LinearSolverOptions")
      .def(py::init<>())
      .def_readwrite("max_reuse_iterations", &LinearSolverOptions::max_reuse_iterations)
      .def_readwrite("iterative_tolerance", &LinearSolverOptions::iterative_tolerance)
      .def_readwrite("iterative_max_iterations", &LinearSolverOptions::iterative_max_iterations);

  py::class_<SolverOptions>(m, "SolverOptions", "The nonlinear solver's settings (docs/solvers.md); C++ defaults.")
      .def(py::init<>())
      .def_property(
          "algorithm", [](const SolverOptions& o) { return o.algorithm.name(); },
          [](SolverOptions& o, const std::string& s) {
            o.algorithm = EnumFrom<Algorithm>(s, "algorithm", AlgorithmNames());
          },
          "'lm' (default), 'gn', 'dogleg', 'ceres'")
      .def_property(
          "linear_solver", [](const SolverOptions& o) { return o.linear_solver.name(); },
          [](SolverOptions& o, const std::string& s) {
            o.linear_solver = EnumFrom<LinearSolverType>(s, "linear solver", LinearSolverNames());
          },
          "'auto' (default), 'block', 'cholmod', 'ldlt', 'qr', or a plugin's")
      .def_readwrite("max_iterations", &SolverOptions::max_iterations)
      .def_readwrite("function_tolerance", &SolverOptions::function_tolerance)
      .def_readwrite("gradient_tolerance", &SolverOptions::gradient_tolerance)
      .def_readwrite("parameter_tolerance", &SolverOptions::parameter_tolerance)
      .def_readwrite("max_seconds", &SolverOptions::max_seconds)
      .def_readwrite("num_threads", &SolverOptions::num_threads)
      .def_readwrite("lm", &SolverOptions::lm)
      .def_readwrite("dogleg", &SolverOptions::dogleg)
      .def_readwrite("linear", &SolverOptions::linear)
      .def(
          "is_valid",
          [](const SolverOptions& o) {
            std::string why;
            const bool ok = o.IsValid(&why);
            return py::make_tuple(ok, why);
          },
          "(ok, why)");

  py::class_<SolverSummary>(m, "SolverSummary", "What a solve did; str() is the C++ BriefReport line.")
      .def_property_readonly(
          "status", [](const SolverSummary& s) { return std::string(ToString(s.status)); },
          "'converged', 'max-iterations', 'time-limit', 'diverged', 'rank-deficient', 'invalid-input'")
      .def_readonly("message", &SolverSummary::message)
      .def_property_readonly("algorithm", [](const SolverSummary& s) { return s.algorithm.name(); })
      .def_property_readonly("linear_solver", [](const SolverSummary& s) { return s.linear_solver.name(); })
      .def_readonly("initial_chi2", &SolverSummary::initial_chi2)
      .def_readonly("final_chi2", &SolverSummary::final_chi2)
      .def_readonly("initial_cost", &SolverSummary::initial_cost)
      .def_readonly("final_cost", &SolverSummary::final_cost)
      .def_readonly("iterations", &SolverSummary::iterations)
      .def_readonly("accepted_iterations", &SolverSummary::accepted_iterations)
      .def_readonly("factorizations", &SolverSummary::factorizations)
      .def_readonly("linear_solver_iterations", &SolverSummary::linear_solver_iterations)
      .def_readonly("total_seconds", &SolverSummary::total_seconds)
      .def_readonly("setup_seconds", &SolverSummary::setup_seconds)
      .def_readonly("linearize_seconds", &SolverSummary::linearize_seconds)
      .def_readonly("factorize_seconds", &SolverSummary::factorize_seconds)
      .def_readonly("solve_seconds", &SolverSummary::solve_seconds)
      .def_readonly("last_factorize_seconds", &SolverSummary::last_factorize_seconds)
      .def_readonly("num_variables", &SolverSummary::num_variables)
      .def_readonly("num_fixed", &SolverSummary::num_fixed)
      .def_readonly("num_factors", &SolverSummary::num_factors)
      .def_readonly("num_residuals", &SolverSummary::num_residuals)
      .def_readonly("tangent_dim", &SolverSummary::tangent_dim)
      .def_readonly("gauge_fixed_automatically", &SolverSummary::gauge_fixed_automatically)
      .def_readonly("gauge_key", &SolverSummary::gauge_key)
      .def_readonly("settings", &SolverSummary::settings)
      .def_readonly("log", &SolverSummary::log)
      .def("is_solution_usable", &SolverSummary::IsSolutionUsable)
      .def("brief_report", &SolverSummary::BriefReport)
      .def("full_report", &SolverSummary::FullReport)
      .def("__str__",
           [](const SolverSummary& s) {
             std::ostringstream o;
             o << s;
             return o.str();
           })
      .def("__repr__", [](const SolverSummary& s) { return "<SolverSummary " + s.BriefReport() + ">"; });

  m.def("optimize", &OptimizeFromPython, py::arg("graph"), py::arg("values"), py::arg("options") = SolverOptions(),
        py::arg("callback") = py::none(),
        "Optimises values in place and returns the SolverSummary. The GIL is released while it runs. "
        "callback(IterationSummary), where given, is called after every iteration (and for iteration 0); "
        "returning False stops the solve with the values of that iteration (status 'stopped', the message "
        "says so). Exceptions raised by Python factors or the callback are raised again here.");
}

void BindMarginalsAndSmoother(py::module_& m) {
  py::class_<CovarianceOptions>(m, "CovarianceOptions")
      .def(py::init<>())
      .def_readwrite("linear_solver", &CovarianceOptions::linear_solver)
      .def_readwrite("num_threads", &CovarianceOptions::num_threads);
  py::class_<Marginals>(m, "Marginals",
                        "Marginal covariances at the given values (in tangent coordinates, the order of "
                        "box-plus). The graph and values must stay unchanged while it is used.")
      .def(py::init([](const FactorGraph& g, const Values& v, CovarianceOptions o) {
             if (o.num_threads > 1 && HasPythonFactor(g)) o.num_threads = 1;  // as optimize
             const InUse::Scope graph_read(&g, "FactorGraph", "Marginals", InUse::Access::kRead);
             const InUse::Scope values_read(&v, "Values", "Marginals", InUse::Access::kRead);
             return Guarded([&] {
               py::gil_scoped_release release;
               return std::make_unique<Marginals>(g, v, o);
             });
           }),
           py::arg("graph"), py::arg("values"), py::arg("options") = CovarianceOptions(), py::keep_alive<1, 2>(),
           py::keep_alive<1, 3>())
      .def("marginal", &Marginals::Marginal, py::arg("key"), "(tangent, tangent) covariance of one variable.")
      .def("joint_marginal", &Marginals::JointMarginal, py::arg("keys"), "The joint covariance, blocks in key order.")
      .def("marginals_of", &Marginals::MarginalsOf, py::arg("keys"))
      .def_property_readonly("free_keys", &Marginals::free_keys)
      .def_property_readonly("gauge_fixed_automatically", &Marginals::gauge_fixed_automatically)
      .def_property_readonly("gauge_key", &Marginals::gauge_key)
      .def("description", &Marginals::Description);

  py::class_<SmootherOptions>(m, "SmootherOptions", "The incremental smoother's settings (docs/smoother.md).")
      .def(py::init<>())
      .def_readwrite("relinearize_threshold", &SmootherOptions::relinearize_threshold)
      .def_readwrite("relinearize_sigmas", &SmootherOptions::relinearize_sigmas)
      .def_readwrite("iterate_ratio", &SmootherOptions::iterate_ratio)
      .def_readwrite("iterate_fraction", &SmootherOptions::iterate_fraction)
      .def_readwrite("rounds_per_update", &SmootherOptions::rounds_per_update)
      .def_readwrite("wildfire_threshold", &SmootherOptions::wildfire_threshold)
      .def_readwrite("iterate_share", &SmootherOptions::iterate_share)
      .def_readwrite("refine_new_values", &SmootherOptions::refine_new_values)
      .def_property(
          "factorization", [](const SmootherOptions& o) { return std::string(ToString(o.factorization)); },
          [](SmootherOptions& o, const std::string& s) {
            o.factorization = NamedFrom<SmootherFactorization>(s, "factorization");
          },
          "auto, left-looking or multifrontal")
      .def_property(
          "mode", [](const SmootherOptions& o) { return std::string(ToString(o.mode)); },
          [](SmootherOptions& o, const std::string& s) { o.mode = NamedFrom<SmootherMode>(s, "smoother mode"); },
          "factor (a Cholesky factor of the whole system) or local (each update over a region around it)")
      .def_readwrite("local_tolerance", &SmootherOptions::local_tolerance)
      .def_readwrite("local_hops", &SmootherOptions::local_hops)
      .def_readwrite("local_max_region", &SmootherOptions::local_max_region)
      .def_readwrite("local_batch_gap", &SmootherOptions::local_batch_gap)
      .def_readwrite("local_batch_share", &SmootherOptions::local_batch_share)
      .def_readwrite("local_batch_correction", &SmootherOptions::local_batch_correction)
      .def_readwrite("local_batch", &SmootherOptions::local_batch)
      .def_readwrite("compute_chi2", &SmootherOptions::compute_chi2)
      .def_readwrite("update", &SmootherOptions::update)
      .def_readwrite("finish", &SmootherOptions::finish)
      .def_readwrite("covariance", &SmootherOptions::covariance)
      .def_readwrite("marginal_from_factor", &SmootherOptions::marginal_from_factor);

  py::class_<SmootherUpdate>(m, "SmootherUpdate", "What one update did.")
      .def_readonly("factors_added", &SmootherUpdate::factors_added)
      .def_readonly("factors_removed", &SmootherUpdate::factors_removed)
      .def_readonly("variables_added", &SmootherUpdate::variables_added)
      .def_readonly("variables_removed", &SmootherUpdate::variables_removed)
      .def_readonly("marginalized", &SmootherUpdate::marginalized, "FixedLagSmoother: variables marginalised")
      .def_readonly("new_factor_ids", &SmootherUpdate::new_factor_ids, "handles of the added factors")
      .def_readonly("solved", &SmootherUpdate::solved)
      .def_readonly("structure_rebuilt", &SmootherUpdate::structure_rebuilt)
      .def_readonly("fell_back", &SmootherUpdate::fell_back)
      .def_property_readonly("status", [](const SmootherUpdate& u) { return std::string(ToString(u.status)); })
      .def_readonly("message", &SmootherUpdate::message)
      .def_readonly("iterations", &SmootherUpdate::iterations)
      .def_readonly("relinearized", &SmootherUpdate::relinearized)
      .def_readonly("chi2_before", &SmootherUpdate::chi2_before)
      .def_readonly("chi2_after", &SmootherUpdate::chi2_after)
      .def_readonly("seconds", &SmootherUpdate::seconds);

  py::class_<IncrementalSmoother>(m, "IncrementalSmoother",
                                  "Online smoothing: update(new factors, new values, removals), then estimate() "
                                  "and marginal(key); finish() runs a batch solve to convergence.")
      .def(py::init<const SmootherOptions&>(), py::arg("options") = SmootherOptions())
      .def(
          "update",
          [](IncrementalSmoother& s, const std::optional<FactorGraph>& factors, const std::optional<Values>& values,
             const std::vector<FactorId>& remove) {
            FactorGraph f = factors ? *factors : FactorGraph();
            Values v = values ? *values : Values();
            const InUse::Scope updating(&s, "IncrementalSmoother", "IncrementalSmoother.update", InUse::Access::kWrite);
            return Guarded([&] {
              py::gil_scoped_release release;
              return s.Update(std::move(f), std::move(v), remove);
            });
          },
          py::arg("new_factors") = py::none(), py::arg("new_values") = py::none(),
          py::arg("remove") = std::vector<FactorId>(),
          "Adds factors (their handles: SmootherUpdate.new_factor_ids), variables, and removes factors by handle.")
      .def("estimate", Reads(&IncrementalSmoother::Estimate, "IncrementalSmoother"), "A copy of the current estimate.")
      .def(
          "marginal",
          [](const IncrementalSmoother& s, Key k) {
            InUse::Check(&s, "IncrementalSmoother", InUse::Access::kRead);
            return Guarded([&] { return s.Marginal(k); });
          },
          py::arg("key"), "(tangent, tangent) covariance of one variable at the current estimate.")
      .def(
          "finish",
          [](IncrementalSmoother& s) {
            const InUse::Scope finishing(&s, "IncrementalSmoother", "IncrementalSmoother.finish",
                                         InUse::Access::kWrite);
            return Guarded([&] {
              py::gil_scoped_release release;
              return Values(s.Finish());
            });
          },
          "Solves the whole graph to convergence; returns the estimate.")
      .def_property_readonly("finish_summary", Reads(&IncrementalSmoother::finish_summary, "IncrementalSmoother"))
      .def("graph", Reads(&IncrementalSmoother::graph, "IncrementalSmoother"), "A copy of the smoother's graph.");

  py::class_<FixedLagOptions>(m, "FixedLagOptions", "The fixed-lag smoother's settings (docs/smoother.md).")
      .def(py::init<>())
      .def_readwrite("lag", &FixedLagOptions::lag, "marginalise what was added more than this long before")
      .def_readwrite("batch", &FixedLagOptions::batch, "marginalise once the oldest is older than lag * (1 + batch)")
      .def_readwrite("smoother", &FixedLagOptions::smoother, "the window's smoother")
      .def_readwrite("converge", &FixedLagOptions::converge, "the window's solve before each marginalisation");

  py::class_<FixedLagSmoother>(m, "FixedLagSmoother",
                               "The incremental smoother over a window of the latest variables; older ones are "
                               "marginalised into a prior, so memory and step time stay flat.")
      .def(py::init<const FixedLagOptions&>(), py::arg("options") = FixedLagOptions())
      .def(
          "update",
          [](FixedLagSmoother& s, const std::optional<FactorGraph>& factors, const std::optional<Values>& values,
             const std::vector<FactorId>& remove, std::optional<double> time) {
            FactorGraph f = factors ? *factors : FactorGraph();
            Values v = values ? *values : Values();
            const InUse::Scope updating(&s, "FixedLagSmoother", "FixedLagSmoother.update", InUse::Access::kWrite);
            return Guarded([&] {
              py::gil_scoped_release release;
              return s.Update(std::move(f), std::move(v), remove,
                              time ? *time : std::numeric_limits<double>::quiet_NaN());
            });
          },
          py::arg("new_factors") = py::none(), py::arg("new_values") = py::none(),
          py::arg("remove") = std::vector<FactorId>(), py::arg("time") = py::none(),
          "As IncrementalSmoother.update, at `time` (default: the number of earlier updates); then marginalises "
          "what is older than the lag.")
      .def("estimate", Reads(&FixedLagSmoother::Estimate, "FixedLagSmoother"), "A copy of the window's estimate.")
      .def(
          "marginal",
          [](const FixedLagSmoother& s, Key k) {
            InUse::Check(&s, "FixedLagSmoother", InUse::Access::kRead);
            return Guarded([&] { return s.Marginal(k); });
          },
          py::arg("key"), "(tangent, tangent) covariance of a variable in the window.")
      .def(
          "take_marginalized",
          [](FixedLagSmoother& s) {
            const InUse::Scope taking(&s, "FixedLagSmoother", "FixedLagSmoother.take_marginalized",
                                      InUse::Access::kWrite);
            return s.TakeMarginalized();
          },
          "The final estimates of the variables marginalised since the last call.")
      .def("was_marginalized", &FixedLagSmoother::WasMarginalized, py::arg("key"))
      .def_property_readonly("marginalized", &FixedLagSmoother::marginalized, "variables marginalised so far")
      .def(
          "finish",
          [](FixedLagSmoother& s) {
            const InUse::Scope finishing(&s, "FixedLagSmoother", "FixedLagSmoother.finish", InUse::Access::kWrite);
            return Guarded([&] {
              py::gil_scoped_release release;
              return Values(s.Finish());
            });
          },
          "Solves the window to convergence; returns its estimate.")
      .def("graph", Reads(&FixedLagSmoother::graph, "FixedLagSmoother"),
           "A copy of the window's factors and the marginal prior.");
}

void BindPipeline(py::module_& m) {
  m.def(
      "read_graph",
      [](const std::string& path, const std::string& format) {
        ReadOptions o;
        o.format = NamedFrom<FileFormat>(format, "file format");
        GraphFile f = Guarded([&] {
          py::gil_scoped_release release;
          return ReadGraphFile(path, DefaultRegistry(), o);
        });
        return py::make_tuple(std::move(f.graph), std::move(f.values));
      },
      py::arg("path"), py::arg("format") = "auto",
      "(graph, values) of a g2o, TORO or iSAM file (any registered factor types, plugins' included). "
      "Raises ParseError naming file and line for a bad line.");
  m.def(
      "write_g2o",
      [](const std::string& path, const FactorGraph& g, const Values& v) {
        const InUse::Scope graph_read(&g, "FactorGraph", "write_g2o", InUse::Access::kRead);
        const InUse::Scope values_read(&v, "Values", "write_g2o", InUse::Access::kRead);
        py::gil_scoped_release release;
        WriteG2oFile(path, v, g, DefaultRegistry());
      },
      py::arg("path"), py::arg("graph"), py::arg("values"), "Writes the graph as a g2o file (atomically).");

  py::class_<InitSummary>(m, "InitSummary")
      .def_property_readonly("method", [](const InitSummary& s) { return std::string(ToString(s.method)); })
      .def_readonly("seconds", &InitSummary::seconds)
      .def_readonly("poses_set", &InitSummary::poses_set)
      .def_readonly("points_set", &InitSummary::points_set)
      .def_readonly("anchors", &InitSummary::anchors)
      .def_readonly("measurements_used", &InitSummary::measurements_used)
      .def_readonly("message", &InitSummary::message);
  m.def(
      "initialize",
      [](const FactorGraph& g, Values& v, const std::string& method) {
        const InitMethod im = NamedFrom<InitMethod>(method, "initialisation");
        const InUse::Scope graph_read(&g, "FactorGraph", "initialize", InUse::Access::kRead);
        const InUse::Scope values_write(&v, "Values", "initialize", InUse::Access::kWrite);
        return Guarded([&] {
          py::gil_scoped_release release;
          return Initialize(g, &v, im);
        });
      },
      py::arg("graph"), py::arg("values"), py::arg("method") = "chordal",
      "Gives the values a start: 'chordal' (default, as the CLI), 'spanning-tree' or 'file' (as they are).");

  py::class_<PipelineResult>(m, "PipelineResult")
      .def_property_readonly("status", [](const PipelineResult& r) { return std::string(ToString(r.status)); })
      .def_readonly("message", &PipelineResult::message)
      .def("ok", &PipelineResult::ok)
      .def_property_readonly("graph", [](const PipelineResult& r) { return r.file.graph; })
      .def_property_readonly("warnings", [](const PipelineResult& r) { return r.file.warnings; })
      .def_readonly("initialized", &PipelineResult::initialized)
      .def_readonly("init", &PipelineResult::init)
      .def_readonly("initial", &PipelineResult::initial, "the start (with keep_intermediate_values)")
      .def_readonly("optimized", &PipelineResult::optimized)
      .def_readonly("summary", &PipelineResult::summary)
      .def_readonly("values", &PipelineResult::values)
      .def_readonly("truth", &PipelineResult::truth, "the ground truth as read (with ground_truth)")
      .def_readonly("start_error", &PipelineResult::start_error,
                    "TrajectoryError of the file's start against the ground truth")
      .def_readonly("result_error", &PipelineResult::result_error,
                    "TrajectoryError of the result against the ground truth")
      .def_property_readonly(
          "covariances",
          [](const PipelineResult& r) {
            py::dict d;
            for (std::size_t i = 0; i < r.covariances.keys.size(); ++i) {
              d[py::int_(r.covariances.keys[i])] = r.covariances.matrices[i];
            }
            return d;
          },
          "{key: covariance matrix} (with covariance), in the variable's tangent coordinates")
      .def_readonly("written", &PipelineResult::written, "every output was written")
      .def_readonly("written_paths", &PipelineResult::written_paths,
                    "the files written: graph, rejected closures, covariances, plot")
      .def_readonly("output_notes", &PipelineResult::output_notes,
                    "notes on an earlier interrupted commit finished or undone");
  m.def(
      "run_pipeline",
      [](const std::string& input, const std::string& output, const std::string& init, const SolverOptions& solver,
         const std::vector<std::string>& robust, const std::string& format, bool keep_initial,
         const py::object& covariance, const std::string& covariance_output, const std::string& plot,
         const std::string& ground_truth) {
        PipelineOptions po;
        po.input = input;
        po.output = output;
        po.covariance = !covariance.is_none();
        if (py::isinstance<py::str>(covariance)) {
          if (covariance.cast<std::string>() != "all") {
            throw InvalidArgument("covariance is None, 'all' or a sequence of keys, got '" +
                                  covariance.cast<std::string>() + "'");
          }
        } else if (po.covariance) {
          const KeyArray keys = CheckedKeys(covariance, "covariance");
          po.covariance_keys.assign(keys.data(), keys.data() + keys.size());
        }
        po.covariance_output = covariance_output;
        po.plot_output = plot;
        po.ground_truth = ground_truth;
        po.init = NamedFrom<InitMethod>(init, "initialisation");
        po.solver = solver;
        po.read.format = NamedFrom<FileFormat>(format, "file format");
        po.keep_intermediate_values = keep_initial;
        for (const std::string& r : robust) {
          RobustRule rule = ParseRobustRule(r);
          // Python loads its plugins before it calls: a loss name unknown now stays unknown, and
          // is refused here as every other malformed rule is.
          if (rule.loss == nullptr) {
            try {
              rule.loss = MakeLoss(rule.loss_spec);
            } catch (const InvalidArgument& e) {
              throw InvalidArgument("robust rule '" + r + "': " + e.what());
            }
          }
          po.robust.push_back(std::move(rule));
        }
        return Guarded([&] {
          py::gil_scoped_release release;
          return RunPipeline(po, DefaultRegistry());
        });
      },
      py::arg("input"), py::arg("output") = "", py::arg("init") = "chordal", py::arg("options") = SolverOptions(),
      py::arg("robust") = std::vector<std::string>(), py::arg("format") = "auto", py::arg("keep_initial") = false,
      py::arg("covariance") = py::none(), py::arg("covariance_output") = "", py::arg("plot") = "",
      py::arg("ground_truth") = "",
      "What `tether optimize` does: read, initialise, optimise, and write every output together (all or none): "
      "the graph (output), the marginal covariances (covariance: 'all' or keys; to covariance_output, default "
      "OUTPUT.cov), an SVG (plot), and with ground_truth the trajectory errors (start_error, result_error). Never "
      "raises for a bad file: the result's status and message say what happened (as the CLI's exit code does).");
}

void BindPlugins(py::module_& m) {
  py::class_<LoadedPlugin>(m, "LoadedPlugin")
      .def_readonly("name", &LoadedPlugin::name)
      .def_readonly("version", &LoadedPlugin::version)
      .def_readonly("path", &LoadedPlugin::path)
      .def_readonly("type_names", &LoadedPlugin::type_names)
      .def_readonly("variable_names", &LoadedPlugin::variable_names)
      .def_readonly("linear_solver_names", &LoadedPlugin::linear_solver_names)
      .def_readonly("extension_names", &LoadedPlugin::extension_names)
      .def_readonly("loss_names", &LoadedPlugin::loss_names)
      .def("summary", &LoadedPlugin::Summary)
      .def("__repr__", [](const LoadedPlugin& p) { return "<LoadedPlugin " + p.Summary() + ">"; });
  m.def(
      "load_plugin",
      [](const std::string& path) {
        // One loader for the process, never destroyed: loaded code stays loaded.
        static PluginLoader* loader = new PluginLoader(DefaultRegistry());
        return loader->Load(path);
      },
      py::arg("path"),
      "Loads a plugin (a path, or a name found on the plugin search path) into the default registry: its "
      "factor and variable types are then read from files, made with make_factor and stored in Values; its "
      "robust losses are known to make_loss, loss= arguments and robust= rules. "
      "Raises PluginError saying why where it cannot.");
  m.def("plugin_search_path", &PluginLoader::SearchPath);
}

}  // namespace

void BindSolve(py::module_& m) {
  BindOptions(m);
  BindMarginalsAndSmoother(m);
  BindPipeline(m);
  BindPlugins(m);
}
TETHER_PYTHON_PART(40, BindSolve);

}  // namespace python
}  // namespace tether
