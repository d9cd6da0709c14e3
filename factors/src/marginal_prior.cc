#include "tether/factors/marginal_prior.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <utility>

#include "tether/core/error.h"
#include "tether/core/se3.h"

namespace tether {

namespace {

// D = d Local(x0, x (+) tau) / d tau at tau = 0 (dim x dim, column-major), with xi =
// Local(x0, x) already computed.
void BoxMinusJacobian(VarType type, const double* x0, const double* x, const double* xi, Eigen::MatrixXd* D) {
  const int n = TangentDim(type);
  D->setIdentity(n, n);
  switch (type) {
    case VarType::kPoint2:
    case VarType::kPoint3:
      return;
    case VarType::kSE2: {
      // Local_t = R0^T (t - t0) and t moves by R dt: R0^T R = the rotation by theta - theta0.
      const double a = x[2] - x0[2], c = std::cos(a), s = std::sin(a);
      (*D)(0, 0) = c, (*D)(0, 1) = -s, (*D)(1, 0) = s, (*D)(1, 1) = c;
      return;
    }
    case VarType::kSE3: {
      const Eigen::Quaterniond q0(x0[6], x0[3], x0[4], x0[5]), q(x[6], x[3], x[4], x[5]);
      D->topLeftCorner<3, 3>() = (q0.normalized().conjugate() * q.normalized()).toRotationMatrix();
      // Log(R0^T R Exp(tau)) moves by the inverse right Jacobian of SO(3) at w; the right
      // Jacobian is the left one's transpose.
      const Eigen::Vector3d w(xi[3], xi[4], xi[5]);
      D->bottomRightCorner<3, 3>() = SE3d::LeftJacobian(w).inverse().transpose();
      return;
    }
    default: {
      const VariableType& t = Describe(type);
      const int m = t.ambient_dim;
      Eigen::VectorXd tau = Eigen::VectorXd::Zero(n), plus(m), minus(m), lp(n), lm(n);
      for (int j = 0; j < n; ++j) {
        const double h = 1e-6;
        tau[j] = h;
        t.retract(x, tau.data(), plus.data());
        tau[j] = -h;
        t.retract(x, tau.data(), minus.data());
        tau[j] = 0;
        t.local(x0, plus.data(), lp.data());
        t.local(x0, minus.data(), lm.data());
        D->col(j) = (lp - lm) / (2 * h);
      }
    }
  }
}

}  // namespace

MarginalPrior::MarginalPrior(std::vector<Key> keys, std::vector<VarType> types, std::vector<double> points,
                             Eigen::MatrixXd R, Eigen::VectorXd d)
    : Factor(std::move(keys), SqrtInformation::Identity(static_cast<int>(std::max<Eigen::Index>(R.rows(), 1)))),
      types_(std::move(types)),
      points_(std::move(points)),
      R_(std::move(R)),
      d_(std::move(d)) {
  if (types_.size() != this->keys().size()) {
    throw InvalidArgument("MarginalPrior: " + std::to_string(this->keys().size()) + " keys but " +
                          std::to_string(types_.size()) + " types");
  }
  int ambient = 0, tangent = 0;
  for (VarType t : types_) {
    point_offsets_.push_back(ambient);
    tangent_offsets_.push_back(tangent);
    ambient += AmbientDim(t);
    tangent += TangentDim(t);
  }
  if (static_cast<int>(points_.size()) != ambient) {
    throw InvalidArgument("MarginalPrior: the linearisation point has " + std::to_string(points_.size()) +
                          " parameters, the keys' types take " + std::to_string(ambient));
  }
  if (R_.rows() < 1 || R_.cols() != tangent || d_.size() != R_.rows()) {
    throw InvalidArgument("MarginalPrior: R is " + std::to_string(R_.rows()) + " x " + std::to_string(R_.cols()) +
                          " and d has " + std::to_string(d_.size()) + " entries; the keys' tangents take " +
                          std::to_string(tangent) + " columns, d one entry per row of R");
  }
  for (double p : points_) {
    if (!std::isfinite(p)) throw InvalidArgument("MarginalPrior: the linearisation point is not finite");
  }
  if (!R_.allFinite() || !d_.allFinite()) throw InvalidArgument("MarginalPrior: R or d is not finite");
  CheckShape();
}

std::unique_ptr<MarginalPrior> MarginalPrior::FromInformation(std::vector<Key> keys, std::vector<VarType> types,
                                                              std::vector<double> points, const Eigen::MatrixXd& H,
                                                              const Eigen::VectorXd& g, double relative_floor) {
  if (H.rows() != H.cols() || g.size() != H.rows() || !H.allFinite() || !g.allFinite()) {
    throw InvalidArgument(
        "MarginalPrior: the information matrix is not square, not finite, or not the gradient's size");
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(0.5 * (H + H.transpose()));
  if (eig.info() != Eigen::Success || H.rows() == 0) {
    throw InvalidArgument("MarginalPrior: the information matrix could not be decomposed");
  }
  const Eigen::VectorXd& lambda = eig.eigenvalues();  // ascending
  const double largest = lambda[lambda.size() - 1];
  if (!(largest > 0)) throw InvalidArgument("MarginalPrior: the information matrix has no positive eigenvalue");
  int first = 0;
  while (first < lambda.size() && !(lambda[first] > relative_floor * largest)) ++first;
  const int rank = static_cast<int>(lambda.size()) - first;
  // H = V L V^T over the kept directions: R = L^(1/2) V^T, d = L^(-1/2) V^T g.
  const Eigen::MatrixXd V = eig.eigenvectors().rightCols(rank);
  const Eigen::VectorXd sqrt_l = lambda.tail(rank).cwiseSqrt();
  Eigen::MatrixXd R = sqrt_l.asDiagonal() * V.transpose();
  Eigen::VectorXd d = sqrt_l.cwiseInverse().asDiagonal() * (V.transpose() * g);
  return std::make_unique<MarginalPrior>(std::move(keys), std::move(types), std::move(points), std::move(R),
                                         std::move(d));
}

bool MarginalPrior::Evaluate(const double* const* params, double* error, double* const* jacobians) const {
  Eigen::VectorXd xi(R_.cols());
  for (std::size_t k = 0; k < types_.size(); ++k) {
    LocalParams(types_[k], point(k), params[k], xi.data() + tangent_offsets_[k]);
  }
  if (!xi.allFinite()) return false;
  Eigen::Map<Eigen::VectorXd>(error, R_.rows()) = R_ * xi + d_;
  if (jacobians == nullptr) return true;
  Eigen::MatrixXd D;
  for (std::size_t k = 0; k < types_.size(); ++k) {
    if (jacobians[k] == nullptr) continue;
    const int n = TangentDim(types_[k]);
    BoxMinusJacobian(types_[k], point(k), params[k], xi.data() + tangent_offsets_[k], &D);
    using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    Eigen::Map<RowMajor>(jacobians[k], R_.rows(), n) = R_.middleCols(tangent_offsets_[k], n) * D;
  }
  return true;
}

}  // namespace tether
