#pragma once
// A small valid factor type for the test plugins: a prior on a 2D point, e = p - z, in the
// standard g2o layout "TAG id x y I11 I12 I22". Each test plugin gives it its own name and tag.
#include <memory>
#include <string>
#include <vector>

#include "tether/plugins/plugin.h"

namespace tether_test {

class PointPrior : public tether::Factor {
 public:
  PointPrior(std::string type_name, tether::Key key, const double* z, tether::SqrtInformation noise)
      : Factor({key}, noise), type_name_(std::move(type_name)), z_{z[0], z[1]} {}
  std::string type_name() const override { return type_name_; }
  std::vector<tether::VarType> variable_types() const override { return {tether::VarType::kPoint2}; }
  int residual_dim() const override { return 2; }
  bool Evaluate(const double* const* params, double* error, double* const* jacobians) const override {
    error[0] = params[0][0] - z_[0];
    error[1] = params[0][1] - z_[1];
    if (jacobians != nullptr && jacobians[0] != nullptr) {
      double* J = jacobians[0];
      J[0] = 1, J[1] = 0;
      J[2] = 0, J[3] = 1;
    }
    return true;
  }
  std::unique_ptr<tether::Factor> Clone() const override { return std::make_unique<PointPrior>(*this); }
  std::vector<double> Measurement() const override { return {z_[0], z_[1]}; }

 private:
  std::string type_name_;
  double z_[2];
};

inline tether::FactorType PointPriorType(const std::string& name, const std::string& tag) {
  tether::FactorType t;
  t.name = name;
  t.tag = tag;
  t.dim = 2;
  t.variable_types = {tether::VarType::kPoint2};
  t.measurement_size = 2;
  t.make = [name](std::vector<tether::Key> keys, const double* z, tether::SqrtInformation noise) {
    return std::make_unique<PointPrior>(name, keys[0], z, noise);
  };
  t.measurement = [](const tether::Factor& f) { return f.Measurement(); };
  return t;
}

}  // namespace tether_test
