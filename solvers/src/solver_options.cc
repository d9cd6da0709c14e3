#include "tether/solvers/solver_options.h"

#include <cmath>
#include <cstdio>
#include <sstream>

#include "builtin_linear_solvers.h"
#include "step_strategy.h"
#include "tether/core/enum_names.h"

namespace tether {

const char* ToString(const Algorithm& a) { return a.name().c_str(); }
const char* ToString(const LinearSolverType& t) { return t.name().c_str(); }

std::string AlgorithmNames() {
  std::string names;
  for (const std::string& n : internal::StepStrategyNames()) names += n + ", ";
  return names + Algorithm::kCeres.name();
}

std::string LinearSolverNames() {
  std::string names;
  for (const std::string& n : internal::LinearSolvers().Names()) names += (names.empty() ? "" : ", ") + n;
  return names;
}

bool FromString(const std::string& s, Algorithm* a) {
  if (s != Algorithm::kCeres.name() && !internal::FindStepStrategy(s)) return false;
  *a = Algorithm(s);
  return true;
}
bool FromString(const std::string& s, LinearSolverType* t) {
  if (internal::LinearSolvers().Find(s) == nullptr) return false;
  *t = LinearSolverType(s);
  return true;
}
namespace {

bool Fail(std::string* why, const std::string& m) {
  if (why) *why = m;
  return false;
}

}  // namespace

bool LevenbergMarquardtOptions::IsValid(std::string* why) const {
  if (!(initial_lambda >= 0) || !std::isfinite(initial_lambda)) {
    return Fail(why, "lm.initial_lambda must be finite and >= 0");
  }
  if (!(min_lambda > 0) || !std::isfinite(min_lambda)) return Fail(why, "lm.min_lambda must be finite and > 0");
  if (max_step_halvings < 0) return Fail(why, "lm.max_step_halvings must be >= 0");
  if (!(max_lambda > initial_lambda) || !(max_lambda > min_lambda)) {
    return Fail(why, "lm.max_lambda must exceed lm.initial_lambda and lm.min_lambda");
  }
  return true;
}

bool DogLegOptions::IsValid(std::string* why) const {
  if (!(initial_radius >= 0) || !std::isfinite(initial_radius)) {
    return Fail(why, "dogleg.initial_radius must be finite and >= 0");
  }
  if (!(min_radius > 0) || !(max_radius > min_radius) || !std::isfinite(max_radius)) {
    return Fail(why, "dogleg.min_radius and dogleg.max_radius must be finite with 0 < min_radius < max_radius");
  }
  if (!(shrink_below > 0) || !(grow_above > shrink_below) || !(grow_above < 1)) {
    return Fail(why, "dogleg.shrink_below and dogleg.grow_above must satisfy 0 < shrink_below < grow_above < 1");
  }
  if (!(grow_factor > 1) || !std::isfinite(grow_factor)) return Fail(why, "dogleg.grow_factor must be finite and > 1");
  if (!(shrink_factor > 0) || !(shrink_factor < 1)) return Fail(why, "dogleg.shrink_factor must be in (0, 1)");
  return true;
}

bool SolverOptions::IsValid(std::string* why) const {
  if (algorithm != Algorithm::kCeres && !internal::FindStepStrategy(algorithm.name())) {
    return Fail(why, "algorithm '" + algorithm.name() + "' is not registered; use one of " + AlgorithmNames());
  }
  if (internal::LinearSolvers().Find(linear_solver.name()) == nullptr) {
    return Fail(why, "linear solver '" + linear_solver.name() + "' is not registered; use one of " +
                         LinearSolverNames() + " (or load the plugin that provides it)");
  }
  if (max_iterations < 0) return Fail(why, "max_iterations must be >= 0");
  if (!(function_tolerance >= 0)) return Fail(why, "function_tolerance must be >= 0");
  if (!(gradient_tolerance >= 0)) return Fail(why, "gradient_tolerance must be >= 0");
  if (!(parameter_tolerance >= 0)) return Fail(why, "parameter_tolerance must be >= 0");
  if (!(max_seconds >= 0) || !std::isfinite(max_seconds)) return Fail(why, "max_seconds must be finite and >= 0");
  if (num_threads < 1 || num_threads > 256) return Fail(why, "num_threads must be between 1 and 256");
  return lm.IsValid(why) && dogleg.IsValid(why) && linear.IsValid(why);
}

std::string SolverSummary::BriefReport() const {
  char buf[256];
  std::snprintf(buf, sizeof(buf), "%s: chi2 %.6g -> %.6g in %d iterations, %.3f s", ToString(status), initial_chi2,
                final_chi2, iterations, total_seconds);
  std::string line = buf;
  if (initial_cost != initial_chi2 || final_cost != final_chi2) {  // robust losses: the objective too
    std::snprintf(buf, sizeof(buf), " (robust cost %.6g -> %.6g)", initial_cost, final_cost);
    line += buf;
  }
  // A solve that did not give a usable result says why on the same line.
  if (!IsSolutionUsable() && !message.empty()) line += ": " + message;
  return line;
}

std::string SolverSummary::FullReport() const {
  std::ostringstream o;
  char buf[128];
  o << "Solver summary\n";
  if (algorithm == Algorithm::kCeres) {
    o << "  algorithm          ceres: Ceres Levenberg-Marquardt / SPARSE_NORMAL_CHOLESKY (SuiteSparse "
      << ToString(linear_solver) << ")\n";
  } else {
    o << "  algorithm          " << ToString(algorithm) << " / " << ToString(linear_solver) << "\n";
  }
  o << "  variables          " << num_variables << " free, " << num_fixed << " fixed (" << tangent_dim
    << " unknowns)\n";
  o << "  factors            " << num_factors << " (" << num_residuals << " residuals)\n";
  if (gauge_fixed_automatically) {
    o << "  gauge              nothing was fixed and no prior exists: held " << KeyToString(gauge_key) << " fixed\n";
  }
  std::snprintf(buf, sizeof(buf), "%.9g", initial_chi2);
  o << "  initial chi2       " << buf << "\n";
  std::snprintf(buf, sizeof(buf), "%.9g", final_chi2);
  o << "  final chi2         " << buf << "\n";
  if (initial_cost != initial_chi2 || final_cost != final_chi2) {
    std::snprintf(buf, sizeof(buf), "%.9g -> %.9g", initial_cost, final_cost);
    o << "  robust cost        " << buf << " (the objective: sum of rho over the factors)\n";
  }
  o << "  iterations         " << iterations << " (" << accepted_iterations << " accepted";
  if (algorithm != Algorithm::kCeres) {
    o << ", " << factorizations << (factorizations == 1 ? " factorisation" : " factorisations");
  }
  if (linear_solver_iterations > 0) o << ", " << linear_solver_iterations << " linear-solver iterations";
  o << ")\n";
  std::snprintf(buf, sizeof(buf), "%.3f s (setup %.3f, linearise %.3f, factorise %.3f, solve %.3f)", total_seconds,
                setup_seconds, linearize_seconds, factorize_seconds, solve_seconds);
  o << "  time               " << buf << "\n";
  for (const auto& [label, text] : settings) {
    o << "  " << label << std::string(label.size() < 19 ? 19 - label.size() : 1, ' ') << text << "\n";
  }
  o << "  status             " << ToString(status) << ": " << message << "\n";
  return o.str();
}

std::ostream& operator<<(std::ostream& os, const SolverSummary& s) { return os << s.BriefReport(); }

}  // namespace tether
