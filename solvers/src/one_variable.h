#pragma once
// Internal: the cost of some factors as a function of one of their variables alone, every
// other variable held at its value. The incremental smoother starts a new variable at the
// minimum of it (RefineNewValues), and its local mode asks how much a variable at a region's
// edge could still gain (LocalRegions::Gain).
#include <Eigen/Core>
#include <vector>

#include "tether/core/factor.h"
#include "tether/core/values.h"

namespace tether {
namespace internal {

/// The summed cost (rho(chi2) with a loss, else chi2) of `factors` with `key` at the
/// parameters `x` and every other variable at its value in `values`. Where `H` and `g` are
/// not null (d x d and d for the key's tangent size d), adds the Gauss-Newton system of the
/// key's tangent to them: H += w^2 J^T J, g += w^2 J^T r for the whitened residual r and
/// Jacobian J, w = sqrt(rho') as the solvers weigh. Infinity where a factor cannot be
/// evaluated. Each factor must use `key` exactly once.
double OneVariableCost(const std::vector<const Factor*>& factors, Key key, const double* x, const Values& values,
                       Eigen::MatrixXd* H, Eigen::VectorXd* g);

}  // namespace internal
}  // namespace tether
