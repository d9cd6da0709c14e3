#include "tether/solvers/optimizer.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "builtin_linear_solvers.h"
#include "gauge.h"
#include "linear_system.h"
#include "minimizer.h"
#include "problem.h"
#include "step_strategy.h"
#include "tether/core/error.h"
#include "tether/core/timing.h"
#include "tether/solvers/ceres_adapter.h"

namespace tether {

namespace {

using internal::Clock;

SolverSummary Invalid(SolverSummary s, const std::string& why) {
  s.status = SolverStatus::kInvalidInput;
  s.message = why;
  return s;
}

// The problem of the graph, with the gauge chosen; nullptr (and the summary says why) where
// the graph is invalid. Where `solver` spans processes and splits the problem between them
// (LinearSolver::Partition), this process's Problem holds only the factors whose first free
// variable it owns, and *split is set.
internal::Problem* BuildProblem(const FactorGraph& graph, Values* values, const SolverOptions& options,
                                LinearSolver* solver, std::unique_ptr<internal::Problem>* holder, SolverSummary* s,
                                bool* split, std::vector<char>* damped) {
  const std::set<Key> fixed = internal::ChooseFixed(graph, *values, s);
  ProcessGroup* group = solver->processes();
  std::vector<char> mask;
  *split = false;
  std::string failure;
  try {
    if (group != nullptr && group->size() > 1) {
      const internal::VariableGraph vg = internal::Problem::Variables(graph, *values, fixed);
      std::vector<int> owner;
      if (solver->Partition(vg.xadj, vg.adjacency, vg.block_sizes, &owner)) {
        mask.assign(graph.size(), 0);
        for (std::size_t f = 0; f < graph.size(); ++f) {
          // A factor of fixed variables only adds a constant to chi2: the first process's.
          const int v = vg.first_free[f];
          mask[f] = (v >= 0 ? owner[v] : 0) == group->rank();
        }
        // Each variable's damping goes into its owner's share.
        for (std::size_t v = 0; v < owner.size(); ++v) {
          damped->insert(damped->end(), static_cast<std::size_t>(vg.block_sizes[v]), owner[v] == group->rank());
        }
        *split = true;
      }
    }
    *holder = std::make_unique<internal::Problem>(graph, values, fixed, options.num_threads, *split ? &mask : nullptr);
  } catch (const Error& e) {
    failure = e.what();
  }
  if (group != nullptr) {
    // One process's share may fail where another's does not: all give up together.
    double failed = failure.empty() ? 0.0 : 1.0;
    group->Sum(&failed, 1);
    if (failed > 0 && failure.empty()) {
      failure = "another process of the job could not build its share of the problem (its message says why)";
    }
  }
  if (!failure.empty()) {
    holder->reset();
    *s = Invalid(*s, failure);
    return nullptr;
  }
  internal::Problem& p = **holder;
  p.set_processes(group, *split);
  s->num_variables = p.num_free();
  s->num_fixed = static_cast<int>(values->size()) - p.num_free();
  s->num_residuals = p.num_residuals();
  if (*split) {
    double residuals = p.num_residuals();
    group->Sum(&residuals, 1);
    s->num_residuals = static_cast<int>(residuals);
  }
  s->tangent_dim = p.tangent_dim();
  return &p;
}

// Linearises at the start; false (and the summary says why) where chi2 or the Jacobian is
// not finite there.
bool LinearizeStart(internal::Problem& p, SolverSummary* s, double* chi2) {
  *chi2 = p.Linearize();
  s->initial_chi2 = s->final_chi2 = *chi2;
  if (std::isfinite(*chi2) && p.jacobian_finite()) return true;
  // Name the first factor at fault: its type and keys point at the bad value or measurement.
  std::string where = p.DescribeNonFinite();
  if (!where.empty()) where = ": " + where;
  *s = Invalid(
      *s, std::isfinite(*chi2)
              ? "the Jacobian at the initial values is not finite" + where + "; check the initial values"
              : "chi2 at the initial values is not finite" + where + "; check the initial values and measurements");
  return false;
}

SolverSummary NothingToOptimise(SolverSummary s, const SolverOptions& options, const internal::StepStrategy& strategy,
                                double chi2, Clock::time_point t0) {
  s.status = SolverStatus::kConverged;
  s.message = "nothing to optimise: every variable is fixed";
  s.total_seconds = SecondsSince(t0);
  IterationSummary it0;
  it0.chi2 = chi2;
  strategy.Describe(&it0);
  it0.seconds = s.total_seconds;
  s.log.push_back(it0);
  if (options.callback) options.callback(it0);
  return s;
}

// The settings of the pieces in use, for FullReport.
void RecordSettings(const SolverOptions& options, const internal::StepStrategy& strategy,
                    const internal::LinearSystem& system, SolverSummary* s) {
  char buf[160];
  std::snprintf(buf, sizeof buf, "max %d iterations, function %g, gradient %g, parameter %g, time %g s",
                options.max_iterations, options.function_tolerance, options.gradient_tolerance,
                options.parameter_tolerance, options.max_seconds);
  s->settings.emplace_back("stopping rules", buf);
  const std::string step = strategy.Settings();
  if (!step.empty()) s->settings.emplace_back(ToString(options.algorithm), step);
  std::snprintf(buf, sizeof buf, "max_reuse_iterations %d, iterative_tolerance %g, iterative_max_iterations %d",
                options.linear.max_reuse_iterations, options.linear.iterative_tolerance,
                options.linear.iterative_max_iterations);
  s->settings.emplace_back(ToString(options.linear_solver), system.Description() + "; " + buf);
}

// The solve itself; `holder` receives the Problem so that Optimize can restore the last good
// values if a factor (or an allocation) throws mid-solve.
SolverSummary Run(const FactorGraph& graph, Values* values, const SolverOptions& options,
                  std::unique_ptr<internal::Problem>* holder) {
  const Clock::time_point t0 = Clock::now();
  SolverSummary s;
  s.algorithm = options.algorithm;
  s.linear_solver = options.linear_solver;
  s.num_factors = static_cast<int>(graph.size());
  std::string why;
  if (!options.IsValid(&why)) return Invalid(s, "invalid options: " + why);
  // The linear solver first: one that spans processes may split the problem between them.
  LinearSolverEntry entry;  // a copy: a plugin may remove its solver while this one solves
  if (!internal::LinearSolvers().Get(options.linear_solver.name(), &entry)) {
    return Invalid(s, "no linear solver is named '" + options.linear_solver.name() + "'");
  }
  std::unique_ptr<LinearSolver> solver;
  try {
    solver = entry.make(options.linear);
  } catch (const Error& e) {
    return Invalid(s, e.what());
  }
  if (!solver) {
    return Invalid(s, "linear solver '" + entry.name + "' (owner '" + entry.owner + "') made no solver");
  }
  bool split = false;
  std::vector<char> damped;
  internal::Problem* p = BuildProblem(graph, values, options, solver.get(), holder, &s, &split, &damped);
  if (p == nullptr) return s;
  // The Problem outlives the solver (the holder keeps it for Restore): it forgets the
  // processes when this solve ends, however it ends.
  struct ForgetProcesses {
    internal::Problem* p;
    ~ForgetProcesses() { p->set_processes(nullptr, false); }
  } forget{p};
  double chi2 = 0;
  if (!LinearizeStart(*p, &s, &chi2)) return s;
  // The log grows without reallocating for the first 1024 iterations (none in the loop).
  s.log.reserve(static_cast<std::size_t>(std::min(options.max_iterations, 1023)) + 1);
  // Looked up once, here: a plugin may remove a strategy after IsValid saw it.
  const StepStrategyFactory make = internal::FindStepStrategy(options.algorithm.name());
  if (!make) return Invalid(s, "no step strategy is named '" + options.algorithm.name() + "'");
  std::unique_ptr<internal::StepStrategy> strategy;
  try {
    strategy = make(options);
  } catch (const std::exception& e) {
    return Invalid(s, "the step strategy '" + options.algorithm.name() + "' could not be made: " + e.what());
  }
  if (!strategy)
    return Invalid(s, "the step strategy '" + options.algorithm.name() + "' made no strategy (a bug in its plugin)");
  if (p->tangent_dim() == 0) return NothingToOptimise(std::move(s), options, *strategy, chi2, t0);
  std::unique_ptr<internal::LinearSystem> system;
  try {
    system =
        std::make_unique<internal::LinearSystem>(p, entry, options.linear, std::move(solver), split, std::move(damped));
  } catch (const Error& e) {
    return Invalid(s, e.what());
  }
  RecordSettings(options, *strategy, *system, &s);
  s.setup_seconds = SecondsSince(t0);
  internal::Minimizer(options, p, system.get(), strategy.get(), &s, t0).Minimize(chi2);
  return s;
}

// Where some factor carries a robust loss, the solvers' chi2 is the robust cost: it moves to
// initial_cost and final_cost, and chi2 proper is evaluated at the start and the end.
SolverSummary WithCosts(SolverSummary s, const FactorGraph& graph, const Values& values, double start_chi2) {
  s.initial_cost = s.initial_chi2;
  s.final_cost = s.final_chi2;
  if (!graph.HasLoss()) return s;
  s.initial_chi2 = start_chi2;
  try {
    s.final_chi2 = graph.Chi2(values);
  } catch (const Error&) {
    s.final_chi2 = std::numeric_limits<double>::quiet_NaN();  // an invalid graph: the message says why
  }
  return s;
}

// chi2 of the start where some factor carries a loss (NaN where it cannot be evaluated).
double StartChi2(const FactorGraph& graph, const Values& values) {
  if (!graph.HasLoss()) return 0;
  try {
    return graph.Chi2(values);
  } catch (const Error&) {
    return std::numeric_limits<double>::quiet_NaN();
  }
}

SolverSummary RunEither(const FactorGraph& graph, Values* values, const SolverOptions& options) {
  if (options.algorithm == Algorithm::kCeres) return OptimizeWithCeres(graph, values, options);
  std::unique_ptr<internal::Problem> problem;
  try {
    return Run(graph, values, options, &problem);
  } catch (const std::exception& e) {
    // A factor's Evaluate threw, or memory ran out: keep the last good values (LM: the last
    // accepted state; GN: the best visited) and say what happened.
    if (problem) problem->Restore();
    SolverSummary s;
    s.algorithm = options.algorithm;
    s.linear_solver = options.linear_solver;
    s.num_factors = static_cast<int>(graph.size());
    s.status = problem ? SolverStatus::kDiverged : SolverStatus::kInvalidInput;
    s.message = std::string("the solve stopped on an exception: ") + e.what() +
                (problem ? "; the last good values were kept" : "; values untouched");
    return s;
  }
}

}  // namespace

SolverSummary Optimize(const FactorGraph& graph, Values* values, const SolverOptions& options) {
  if (values == nullptr) throw InvalidArgument("Optimize: values must not be null");
  const double start_chi2 = StartChi2(graph, *values);
  return WithCosts(RunEither(graph, values, options), graph, *values, start_chi2);
}

}  // namespace tether
