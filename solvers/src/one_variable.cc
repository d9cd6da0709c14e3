#include "one_variable.h"

#include <cmath>
#include <limits>

#include "tether/core/robust_kernels.h"

namespace tether {
namespace internal {

double OneVariableCost(const std::vector<const Factor*>& factors, Key key, const double* x, const Values& values,
                       Eigen::MatrixXd* H, Eigen::VectorXd* g) {
  constexpr double kInfinity = std::numeric_limits<double>::infinity();
  const int d = TangentDim(values.TypeOf(key));
  // Scratch kept between calls (the local mode calls this for every edge variable).
  thread_local std::vector<double> e, jac;
  thread_local std::vector<const double*> params;
  thread_local std::vector<double*> jp;
  double cost = 0;
  for (const Factor* f : factors) {
    const int m = f->dim();
    e.assign(static_cast<std::size_t>(m), 0.0);
    jac.assign(static_cast<std::size_t>(m) * d, 0.0);
    params.clear();
    jp.clear();
    for (Key o : f->keys()) {
      params.push_back(o == key ? x : values.Params(o));
      jp.push_back(o == key ? jac.data() : nullptr);
    }
    if (!f->Linearize(params.data(), e.data(), H != nullptr ? jp.data() : nullptr)) return kInfinity;
    double sq = 0, rho = 0;
    for (double v : e) sq += v * v;
    const double w = RobustWeight(f->loss(), sq, &rho);
    cost += rho;
    if (H != nullptr) {
      const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> J(jac.data(), m,
                                                                                                       d);
      const Eigen::Map<const Eigen::VectorXd> r(e.data(), m);
      H->noalias() += w * w * J.transpose() * J;
      g->noalias() += w * w * J.transpose() * r;
    }
  }
  return std::isfinite(cost) ? cost : kInfinity;
}

}  // namespace internal
}  // namespace tether
