#include "tether/frontends/ekf/unscented_transform.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "innovation.h"
#include "tether/core/error.h"

namespace tether {
namespace ekf {

bool UnscentedParams::IsValid(std::string* why) const {
  const auto fail = [&](const std::string& w) {
    if (why != nullptr) *why = w;
    return false;
  };
  if (!(std::isfinite(alpha) && alpha > 0 && alpha <= 1)) return fail("alpha must be in (0, 1]");
  if (!std::isfinite(beta)) return fail("beta must be finite");
  // n + lambda = alpha^2 (n + kappa) > 0 for every n >= 1 exactly when kappa > -1.
  if (!(std::isfinite(kappa) && kappa > -1)) return fail("kappa must be finite and above -1 (so that n + lambda > 0)");
  return true;
}

namespace {

Eigen::VectorXd Diff(const Difference& d, const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  return d ? d(a, b) : Eigen::VectorXd(a - b);
}

// L with L L^T = m: the Cholesky factor; for a semi-definite m (a known start, a noise-free
// control) the pivoted LDL^T factor P^T L D^1/2, its rounding below zero clamped to 0.
Eigen::MatrixXd SquareRoot(const Eigen::MatrixXd& m) {
  const Eigen::LLT<Eigen::MatrixXd> llt(m);
  if (llt.info() == Eigen::Success) return llt.matrixL();
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(m);
  const Eigen::VectorXd d = ldlt.vectorD();
  const double scale = std::max(1.0, m.diagonal().cwiseAbs().maxCoeff());
  if (ldlt.info() != Eigen::Success || (d.array() < -1e-9 * scale).any()) {
    throw InvalidArgument(
        "unscented transform: the covariance is not positive semi-definite (its LDL^T factor has a "
        "negative pivot)");
  }
  Eigen::MatrixXd l = ldlt.matrixL();
  l = l * d.cwiseMax(0.0).cwiseSqrt().asDiagonal();
  return ldlt.transpositionsP().transpose() * l;
}

}  // namespace

Transformed UnscentedTransform(const Eigen::VectorXd& mean, const Eigen::MatrixXd& cov, const Function& f,
                               const UnscentedParams& params, const Difference& x_diff, const Difference& y_diff) {
  std::string why;
  if (!params.IsValid(&why)) throw InvalidArgument("unscented transform: " + why);
  const Eigen::Index n = mean.size();
  if (cov.rows() != n || cov.cols() != n) throw InvalidArgument("unscented transform: covariance of the wrong size");
  const double nd = static_cast<double>(n);
  const double lambda = params.alpha * params.alpha * (nd + params.kappa) - nd;
  const double spread = nd + lambda;
  if (!cov.allFinite()) throw InvalidArgument("unscented transform: the covariance is not finite");
  const Eigen::MatrixXd l = SquareRoot(spread * cov);
  const double wm0 = lambda / spread, wc0 = wm0 + 1 - params.alpha * params.alpha + params.beta;
  const double wi = 1 / (2 * spread);

  // Sigma points and their images.
  std::vector<Eigen::VectorXd> xs(2 * n + 1), ys(2 * n + 1);
  xs[0] = mean;
  for (Eigen::Index i = 0; i < n; ++i) {
    xs[1 + i] = mean + l.col(i);
    xs[1 + n + i] = mean - l.col(i);
  }
  for (std::size_t i = 0; i < xs.size(); ++i) ys[i] = f(xs[i]);
  const Eigen::Index m = ys[0].size();

  // Mean around the first image, so that wrapped components average correctly.
  Eigen::VectorXd offset = Eigen::VectorXd::Zero(m);
  for (std::size_t i = 1; i < ys.size(); ++i) offset += wi * Diff(y_diff, ys[i], ys[0]);
  Transformed out;
  out.mean = ys[0] + offset;
  out.cov = Eigen::MatrixXd::Zero(m, m);
  out.cross = Eigen::MatrixXd::Zero(n, m);
  for (std::size_t i = 0; i < ys.size(); ++i) {
    const double w = i == 0 ? wc0 : wi;
    const Eigen::VectorXd dy = Diff(y_diff, ys[i], out.mean);
    const Eigen::VectorXd dx = Diff(x_diff, xs[i], mean);
    out.cov.noalias() += w * dy * dy.transpose();
    out.cross.noalias() += w * dx * dy.transpose();
  }
  return out;
}

void UnscentedPredict(Eigen::VectorXd* mean, Eigen::MatrixXd* cov, const Function& f, const Eigen::MatrixXd& q,
                      const UnscentedParams& params, const Difference& x_diff) {
  Transformed t = UnscentedTransform(*mean, *cov, f, params, x_diff, x_diff);
  *mean = std::move(t.mean);
  *cov = t.cov + q;
  *cov = 0.5 * (*cov + cov->transpose()).eval();
}

Eigen::VectorXd UnscentedUpdate(Eigen::VectorXd* mean, Eigen::MatrixXd* cov, const Function& h,
                                const Eigen::VectorXd& z, const Eigen::MatrixXd& r, const UnscentedParams& params,
                                const Difference& x_diff, const Difference& z_diff) {
  const Transformed t = UnscentedTransform(*mean, *cov, h, params, x_diff, z_diff);
  const Eigen::MatrixXd s = t.cov + r;
  const Eigen::VectorXd nu = Diff(z_diff, z, t.mean);
  if (!KalmanCorrect(t.cross, s, nu, mean, cov)) {
    throw InvalidArgument("unscented update: the innovation covariance is not positive definite");
  }
  *cov = 0.5 * (*cov + cov->transpose()).eval();
  return nu;
}

}  // namespace ekf
}  // namespace tether
