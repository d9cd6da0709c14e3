#include "tether/factors/prior.h"

#include "relative_pose_error.h"

namespace tether {

// A prior is the relative-pose error with the first pose at the identity.
bool PriorSE2::Evaluate(const double* const* params, double* error, double* const* jacobians) const {
  const double origin[3] = {0, 0, 0};
  EvaluateSE2Relative(z_, cz_, sz_, origin, params[0], error, nullptr, jacobians ? jacobians[0] : nullptr);
  return true;
}

bool PriorSE3::Evaluate(const double* const* params, double* error, double* const* jacobians) const {
  EvaluateSE3Relative(z_, SE3d(), SE3d::FromParams(params[0]), error, nullptr, jacobians ? jacobians[0] : nullptr);
  return true;
}

std::vector<double> PriorSE3::Measurement() const {
  std::vector<double> m(7);
  z_.ToParams(m.data());
  return m;
}

}  // namespace tether
