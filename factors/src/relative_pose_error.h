#pragma once
// Shared error functions of the relative-pose factors (between and prior factors).
#include "tether/core/se2.h"
#include "tether/core/se3.h"

namespace tether {

/// e = toVector(z^-1 * (a^-1 * b)) for SE2 parameters a, b; Jacobians row-major 3x3 (may be null).
/// cz, sz: cos and sin of z's angle, which the factor computes once, not at every evaluation.
void EvaluateSE2Relative(const SE2d& z, double cz, double sz, const double* a, const double* b, double* error,
                         double* jac_a, double* jac_b);
/// e = (t, vec(q)) of z^-1 * (xi^-1 * xj); Jacobians row-major 6x6 (may be null).
void EvaluateSE3Relative(const SE3d& z, const SE3d& xi, const SE3d& xj, double* error, double* jac_i, double* jac_j);

}  // namespace tether
