#pragma once
// MarginalPrior: what a set of variables that were marginalised out of a graph said about the
// variables they shared factors with (their separator), kept as one factor: a Gaussian over
// the separator in the tangent space at the point where the marginalisation was done.
//
//   e(x) = R xi + d,   xi = (Local(x0_1, x_1), ..., Local(x0_n, x_n))
//
// so that |e|^2 = xi^T H xi + 2 g^T xi + const, with H = R^T R and g = R^T d the information
// and gradient of the Schur complement at x0. The linearisation point x0 stays where it was
// (it is the point the eliminated factors were linearised at); the Jacobians are exact, the
// derivative of the box-minus included (SE2: R0^T R on the translation; SE3: the same, and the
// inverse right Jacobian of SO(3) on the rotation; a registered type: central differences of
// its box-plus and box-minus). The residual is already whitened: the noise model is the
// identity. It anchors the graph (Factor::anchors), as a prior does.
#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "tether/core/factor.h"

namespace tether {

class MarginalPrior : public Factor {
 public:
  static constexpr const char* kTypeName = "MarginalPrior";
  /// `types` and `points` (each variable's parameters at x0, one after the other, in the
  /// types' ambient layouts) go with `keys`; R has one column per tangent entry of the keys in
  /// order and d one entry per row of R. Throws InvalidArgument where the sizes disagree or an
  /// entry is not finite.
  MarginalPrior(std::vector<Key> keys, std::vector<VarType> types, std::vector<double> points, Eigen::MatrixXd R,
                Eigen::VectorXd d);

  /// The prior of the quadratic xi^T H xi + 2 g^T xi (H symmetric, positive semi-definite)
  /// at x0: R and d from H's eigen-decomposition, the directions whose eigenvalue is below
  /// `relative_floor` times the largest left out (H says nothing there). Throws
  /// InvalidArgument where H is not finite or has no positive eigenvalue.
  static std::unique_ptr<MarginalPrior> FromInformation(std::vector<Key> keys, std::vector<VarType> types,
                                                        std::vector<double> points, const Eigen::MatrixXd& H,
                                                        const Eigen::VectorXd& g, double relative_floor = 1e-12);

  std::string type_name() const override { return kTypeName; }
  int residual_dim() const override { return static_cast<int>(R_.rows()); }
  std::vector<VarType> variable_types() const override { return types_; }
  bool Evaluate(const double* const* params, double* error, double* const* jacobians) const override;
  std::unique_ptr<Factor> Clone() const override { return std::make_unique<MarginalPrior>(*this); }
  bool anchors() const override { return true; }

  /// The linearisation point of key index k (its ambient parameters).
  const double* point(std::size_t k) const { return points_.data() + point_offsets_[k]; }
  const Eigen::MatrixXd& R() const { return R_; }
  const Eigen::VectorXd& d() const { return d_; }
  /// H = R^T R and g = R^T d.
  Eigen::MatrixXd Information() const { return R_.transpose() * R_; }
  Eigen::VectorXd Gradient() const { return R_.transpose() * d_; }

 private:
  std::vector<VarType> types_;
  std::vector<double> points_;
  std::vector<int> point_offsets_;    // of each key's parameters in points_
  std::vector<int> tangent_offsets_;  // of each key's columns in R_
  Eigen::MatrixXd R_;
  Eigen::VectorXd d_;
};

}  // namespace tether
