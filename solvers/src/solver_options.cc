#include "tether/solvers/solver_options.h"

#include <cmath>
#include <cstdio>
#include <sstream>

namespace tether {

const char* ToString(Algorithm a) {
  switch (a) {
    case Algorithm::kGaussNewton:
      return "gn";
    case Algorithm::kLevenbergMarquardt:
      return "lm";
    case Algorithm::kCeres:
      return "ceres";
  }
  return "lm";
}

const char* ToString(LinearSolverType t) {
  switch (t) {
    case LinearSolverType::kCholmod:
      return "cholmod";
    case LinearSolverType::kEigenLDLT:
      return "ldlt";
    case LinearSolverType::kQR:
      return "qr";
  }
  return "cholmod";
}

const char* ToString(SolverStatus s) {
  switch (s) {
    case SolverStatus::kConverged:
      return "converged";
    case SolverStatus::kMaxIterations:
      return "max-iterations";
    case SolverStatus::kTimeLimit:
      return "time-limit";
    case SolverStatus::kDiverged:
      return "diverged";
    case SolverStatus::kRankDeficient:
      return "rank-deficient";
    case SolverStatus::kInvalidInput:
      return "invalid-input";
  }
  return "invalid-input";
}

namespace {
template <typename E>
bool Parse(const std::string& s, std::initializer_list<E> all, E* out) {
  for (E e : all) {
    if (s == ToString(e)) {
      *out = e;
      return true;
    }
  }
  return false;
}
}  // namespace

bool FromString(const std::string& s, Algorithm* a) {
  return Parse(s, {Algorithm::kGaussNewton, Algorithm::kLevenbergMarquardt, Algorithm::kCeres}, a);
}
bool FromString(const std::string& s, LinearSolverType* t) {
  return Parse(s, {LinearSolverType::kCholmod, LinearSolverType::kEigenLDLT, LinearSolverType::kQR}, t);
}
bool FromString(const std::string& s, SolverStatus* st) {
  return Parse(s,
               {SolverStatus::kConverged, SolverStatus::kMaxIterations, SolverStatus::kTimeLimit,
                SolverStatus::kDiverged, SolverStatus::kRankDeficient, SolverStatus::kInvalidInput},
               st);
}

bool SolverOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (max_iterations < 0) return fail("max_iterations must be >= 0");
  if (!(function_tolerance >= 0)) return fail("function_tolerance must be >= 0");
  if (!(gradient_tolerance >= 0)) return fail("gradient_tolerance must be >= 0");
  if (!(parameter_tolerance >= 0)) return fail("parameter_tolerance must be >= 0");
  if (!(max_seconds >= 0) || !std::isfinite(max_seconds)) return fail("max_seconds must be finite and >= 0");
  if (!(initial_lambda >= 0) || !std::isfinite(initial_lambda)) return fail("initial_lambda must be finite and >= 0");
  if (!(min_lambda > 0) || !std::isfinite(min_lambda)) return fail("min_lambda must be finite and > 0");
  if (max_step_halvings < 0) return fail("max_step_halvings must be >= 0");
  if (max_reuse_iterations < 0) return fail("max_reuse_iterations must be >= 0");
  if (num_threads < 1 || num_threads > 256) return fail("num_threads must be between 1 and 256");
  if (!(max_lambda > initial_lambda) || !(max_lambda > min_lambda)) {
    return fail("max_lambda must exceed initial_lambda and min_lambda");
  }
  return true;
}

std::string SolverSummary::BriefReport() const {
  char buf[256];
  std::snprintf(buf, sizeof(buf), "%s: chi2 %.6g -> %.6g in %d iterations, %.3f s", ToString(status), initial_chi2,
                final_chi2, iterations, total_seconds);
  return buf;
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
  o << "  iterations         " << iterations << " (" << accepted_iterations << " accepted";
  if (algorithm != Algorithm::kCeres) {
    o << ", " << factorizations << (factorizations == 1 ? " factorisation" : " factorisations");
  }
  o << ")\n";
  std::snprintf(buf, sizeof(buf), "%.3f s (setup %.3f, linearise %.3f, factorise %.3f, solve %.3f)", total_seconds,
                setup_seconds, linearize_seconds, factorize_seconds, solve_seconds);
  o << "  time               " << buf << "\n";
  o << "  status             " << ToString(status) << ": " << message << "\n";
  return o.str();
}

}  // namespace tether
