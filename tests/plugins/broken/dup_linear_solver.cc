// Registers a valid factor type, then a linear solver named "cholmod", which tether has
// built in: the load must fail and register neither.
#include "point_prior_type.h"
#include "tether/core/linear_solver.h"

namespace {

void Register(tether::PluginRegistrar& r) {
  r.AddFactorType(tether_test::PointPriorType("TestDupSolverPrior", "TEST_DUP_SOLVER_PRIOR"));
  r.AddLinearSolver(
      "cholmod", [](const tether::LinearSolverOptions&) -> std::unique_ptr<tether::LinearSolver> { return nullptr; });
}

}  // namespace

TETHER_PLUGIN("test_dup_linear_solver", "0.1.0", Register)
