#pragma once
// Pose-landmark factors: the landmark's position measured in the pose's frame.
// PosePoint2 (g2o EDGE_SE2_XY, SE2 pose to VERTEX_XY): e = R^T (l - t) - z.
// PosePoint3 (SE3 pose to a 3D point):                  e = R^T (l - t) - z.
#include "tether/core/factor.h"

namespace tether {

class PosePoint2 : public Factor {
 public:
  PosePoint2(Key pose, Key point, const Eigen::Vector2d& z, SqrtInformation noise)
      : Factor({pose, point}, noise), z_(z) {}
  std::string type_name() const override { return "PosePoint2"; }
  int residual_dim() const override { return 2; }
  std::vector<VarType> variable_types() const override { return {VarType::kSE2, VarType::kPoint2}; }
  bool Evaluate(const double* const* params, double* error, double* const* jacobians) const override;
  std::unique_ptr<Factor> Clone() const override { return std::make_unique<PosePoint2>(*this); }
  std::vector<double> Measurement() const override { return {z_.x(), z_.y()}; }
  bool Predict(std::size_t known, const double* known_params, std::size_t unknown, double* out) const override;

 private:
  Eigen::Vector2d z_;
};

class PosePoint3 : public Factor {
 public:
  PosePoint3(Key pose, Key point, const Eigen::Vector3d& z, SqrtInformation noise)
      : Factor({pose, point}, noise), z_(z) {}
  std::string type_name() const override { return "PosePoint3"; }
  int residual_dim() const override { return 3; }
  std::vector<VarType> variable_types() const override { return {VarType::kSE3, VarType::kPoint3}; }
  bool Evaluate(const double* const* params, double* error, double* const* jacobians) const override;
  std::unique_ptr<Factor> Clone() const override { return std::make_unique<PosePoint3>(*this); }
  std::vector<double> Measurement() const override { return {z_.x(), z_.y(), z_.z()}; }
  bool Predict(std::size_t known, const double* known_params, std::size_t unknown, double* out) const override;

 private:
  Eigen::Vector3d z_;
};

}  // namespace tether
