// A plugin with two factor types: TestRightRange, a range from a 2D pose to a fixed point with
// correct Jacobians, and TestWrongRange, the same error with the sign of one Jacobian entry
// flipped, which `tether check-plugin` must report.
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "tether/plugins/plugin.h"

namespace {

// e = |t - z| - r for a pose (x, y, theta) with translation t = (x, y), and the measurement
// (zx, zy, r).
class Range : public tether::Factor {
 public:
  Range(std::string name, bool wrong, tether::Key key, const double* z, tether::SqrtInformation noise)
      : Factor({key}, noise), name_(std::move(name)), wrong_(wrong), z_{z[0], z[1], z[2]} {}
  std::string type_name() const override { return name_; }
  std::vector<tether::VarType> variable_types() const override { return {tether::VarType::kSE2}; }
  int residual_dim() const override { return 1; }
  bool Evaluate(const double* const* params, double* error, double* const* jacobians) const override {
    const double dx = params[0][0] - z_[0], dy = params[0][1] - z_[1];
    const double d = std::hypot(dx, dy);
    if (!(d > 1e-9)) return false;
    error[0] = d - z_[2];
    if (jacobians != nullptr && jacobians[0] != nullptr) {
      // The pose's tangent (vx, vy, w) moves t by R(theta) (vx, vy).
      const double c = std::cos(params[0][2]), s = std::sin(params[0][2]);
      const double gx = dx / d, gy = dy / d;
      jacobians[0][0] = gx * c + gy * s;
      jacobians[0][1] = (wrong_ ? 1 : -1) * gx * s + gy * c;
      jacobians[0][2] = 0;
    }
    return true;
  }
  std::unique_ptr<tether::Factor> Clone() const override { return std::make_unique<Range>(*this); }
  std::vector<double> Measurement() const override { return {z_[0], z_[1], z_[2]}; }

 private:
  std::string name_;
  bool wrong_;
  double z_[3];
};

tether::FactorType RangeType(const std::string& name, const std::string& tag, bool wrong) {
  tether::FactorType t;
  t.name = name;
  t.tag = tag;
  t.dim = 1;
  t.variable_types = {tether::VarType::kSE2};
  t.measurement_size = 3;
  t.make = [name, wrong](std::vector<tether::Key> keys, const double* z, tether::SqrtInformation noise) {
    return std::make_unique<Range>(name, wrong, keys[0], z, noise);
  };
  t.measurement = [](const tether::Factor& f) { return f.Measurement(); };
  return t;
}

void Register(tether::PluginRegistrar& r) {
  r.AddFactorType(RangeType("TestRightRange", "TEST_RIGHT_RANGE", false));
  r.AddFactorType(RangeType("TestWrongRange", "TEST_WRONG_RANGE", true));
}

}  // namespace

TETHER_PLUGIN("test_wrong_jacobian", "0.1.0", Register)
