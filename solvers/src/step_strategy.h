#pragma once
// Internal: the built-in step strategies (the interface is public: tether/solvers/
// step_strategy.h). Gauss-Newton ("gn"), Levenberg-Marquardt ("lm") and Powell's dog-leg
// ("dogleg"), each in its own file; more are added by name with RegisterStepStrategy or from
// a plugin, touching no existing function.
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "linear_system.h"
#include "problem.h"
#include "tether/solvers/solver_options.h"
#include "tether/solvers/step_strategy.h"

namespace tether {
namespace internal {

using tether::FindStepStrategy;
using tether::RegisterStepStrategy;
using tether::Step;
using tether::StepStrategy;
using tether::StepStrategyFactory;
using tether::StepStrategyNames;

// The built-in strategies (gauss_newton.cc, levenberg_marquardt.cc, dogleg.cc).
std::unique_ptr<StepStrategy> MakeGaussNewton(const SolverOptions& options);
std::unique_ptr<StepStrategy> MakeLevenbergMarquardt(const SolverOptions& options);
std::unique_ptr<StepStrategy> MakeDogLeg(const SolverOptions& options);

}  // namespace internal
}  // namespace tether
