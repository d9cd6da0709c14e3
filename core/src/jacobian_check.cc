#include "tether/core/jacobian_check.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace tether {

namespace {
bool Contains(const std::vector<int>& v, int x) { return std::find(v.begin(), v.end(), x) != v.end(); }
}  // namespace

std::string JacobianCheck::Report() const {
  std::ostringstream s;
  if (!evaluated) s << factor << ": Evaluate returned false at the point or at a step\n";
  for (const JacobianEntry& e : mismatches) {
    s << factor << ": d e[" << e.row << "] / d delta_" << e.key << "[" << e.column << "]: analytic " << e.analytic
      << ", numeric " << e.numeric << "\n";
  }
  if (ok) s << factor << ": ok (largest difference " << max_abs_error << ")";
  return s.str();
}

JacobianCheck CheckJacobians(const Factor& f, const Values& values, const JacobianCheckOptions& options) {
  JacobianCheck out;
  out.factor = f.type_name();
  const std::vector<VarType> types = f.variable_types();
  const std::vector<const double*> base = f.GatherParams(values);
  const int m = f.residual_dim();
  std::vector<std::vector<double>> analytic(types.size());
  std::vector<double*> jptr(types.size());
  for (std::size_t k = 0; k < types.size(); ++k) {
    analytic[k].assign(static_cast<std::size_t>(m) * TangentDim(types[k]), 0.0);
    jptr[k] = analytic[k].data();
  }
  std::vector<double> e0(m), ep(m), em(m);
  out.evaluated = f.Evaluate(base.data(), e0.data(), jptr.data());
  const double h = options.step;
  for (std::size_t k = 0; k < types.size(); ++k) {
    const int d = TangentDim(types[k]);
    std::vector<double> plus(AmbientDim(types[k])), minus(AmbientDim(types[k])), delta(d, 0.0);
    for (int c = 0; c < d; ++c) {
      delta[c] = h;
      RetractParams<double>(types[k], base[k], delta.data(), plus.data());
      delta[c] = -h;
      RetractParams<double>(types[k], base[k], delta.data(), minus.data());
      delta[c] = 0.0;
      std::vector<const double*> pp = base, pm = base;
      pp[k] = plus.data();
      pm[k] = minus.data();
      out.evaluated = f.Evaluate(pp.data(), ep.data(), nullptr) && out.evaluated;
      out.evaluated = f.Evaluate(pm.data(), em.data(), nullptr) && out.evaluated;
      for (int r = 0; r < m; ++r) {
        const double diff = Contains(options.angle_rows, r) ? WrapAngle(ep[r] - em[r]) : ep[r] - em[r];
        const double numeric = diff / (2 * h);
        const double a = analytic[k][static_cast<std::size_t>(r) * d + c];
        const double err = std::abs(a - numeric);
        out.max_abs_error = std::max(out.max_abs_error, std::isnan(err) ? INFINITY : err);
        if (!(err <= options.absolute_tolerance + options.relative_tolerance * std::abs(numeric))) {
          out.mismatches.push_back(JacobianEntry{static_cast<int>(k), r, c, a, numeric});
        }
      }
    }
  }
  out.ok = out.evaluated && out.mismatches.empty();
  return out;
}

}  // namespace tether
