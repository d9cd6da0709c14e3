#pragma once
// Pose-landmark factors: the landmark's position measured in the pose's frame.
// PosePoint2 (g2o EDGE_SE2_XY, SE2 pose to VERTEX_XY): e = R^T (l - t) - z.
// PosePoint3 (SE3 pose to a 3D point):                  e = R^T (l - t) - z.
#include "tether/core/factor.h"

namespace tether {

class PosePoint2 : public TypedFactor<PosePoint2, 2, SE2d, Eigen::Vector2d> {
 public:
  static constexpr const char* kTypeName = "PosePoint2";
  PosePoint2(Key pose, Key point, const Eigen::Vector2d& z, SqrtInformation noise)
      : TypedFactor({pose, point}, std::move(noise)), z_(z) {}
  bool Evaluate(const double* const* params, double* error, double* const* jacobians) const override;
  std::vector<double> Measurement() const override { return {z_.x(), z_.y()}; }
  bool Predict(std::size_t known, const double* known_params, std::size_t unknown, double* out) const override;

 private:
  Eigen::Vector2d z_;
};

class PosePoint3 : public TypedFactor<PosePoint3, 3, SE3d, Eigen::Vector3d> {
 public:
  static constexpr const char* kTypeName = "PosePoint3";
  PosePoint3(Key pose, Key point, const Eigen::Vector3d& z, SqrtInformation noise)
      : TypedFactor({pose, point}, std::move(noise)), z_(z) {}
  bool Evaluate(const double* const* params, double* error, double* const* jacobians) const override;
  std::vector<double> Measurement() const override { return {z_.x(), z_.y(), z_.z()}; }
  bool Predict(std::size_t known, const double* known_params, std::size_t unknown, double* out) const override;

 private:
  Eigen::Vector3d z_;
};

}  // namespace tether
