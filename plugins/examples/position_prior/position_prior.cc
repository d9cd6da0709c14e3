// Example plugin "position_prior": GPS-like priors on the position of a pose, with the
// Jacobians computed by automatic differentiation (ceres::Jet) instead of by hand.
//
// | type             | g2o tag                 | key | file line after the tag           |
// |------------------|-------------------------|-----|-----------------------------------|
// | PositionPriorSE2 | EDGE_POSITION_PRIOR_SE2 | SE2 | id x y I11 I12 I22                |
// | PositionPriorSE3 | EDGE_POSITION_PRIOR_SE3 | SE3 | id x y z I11 I12 I13 I22 I23 I33  |
//
// Error: e = t - z, the pose's position in the world frame minus the measured position.
// The orientation is left free: a GPS fix says where the robot is, not where it points.
//
// Only the residual is written, as a template over the scalar type T. AutoDiffFactor calls it
// with T = double to evaluate, and with T = ceres::Jet to differentiate it with respect to the
// box-plus perturbation of each variable. For this factor that Jacobian is [R 0], not the
// identity, because box-plus moves a pose's position in its own frame (t' = t + R dt).
#include <algorithm>
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "tether/core/autodiff_factor.h"
#include "tether/plugins/plugin.h"

namespace {

using tether::Key;
using tether::SqrtInformation;
using tether::VarType;

// Position components of a pose type.
constexpr int PositionDim(VarType pose) { return pose == VarType::kSE2 ? 2 : 3; }

// One class template serves both pose types: SE2 (x y theta) and SE3 (tx ty tz qx qy qz qw)
// parameters both start with the position.
template <VarType kPose>
class PositionPrior : public tether::AutoDiffFactor<PositionPrior<kPose>, PositionDim(kPose), kPose> {
 public:
  static constexpr int kDim = PositionDim(kPose);

  PositionPrior(Key key, const double* z, SqrtInformation noise)
      : tether::AutoDiffFactor<PositionPrior, kDim, kPose>({key}, noise) {
    std::copy(z, z + kDim, z_.begin());
  }

  // The residual. params[0] holds the pose's raw parameters (already perturbed, when T is a Jet).
  template <typename T>
  bool operator()(const T* const* params, T* error) const {
    for (int i = 0; i < kDim; ++i) error[i] = params[0][i] - T(z_[i]);
    return true;
  }

  // Must be the names the types are registered under: the writer looks the type up by it.
  std::string type_name() const override { return kPose == VarType::kSE2 ? "PositionPriorSE2" : "PositionPriorSE3"; }
  std::unique_ptr<tether::Factor> Clone() const override { return std::make_unique<PositionPrior>(*this); }
  // The numbers written after the id in the file (standard layout).
  std::vector<double> Measurement() const override { return {z_.begin(), z_.end()}; }
  // Predict keeps the default (false): a unary factor has no other variable to place.

 private:
  std::array<double, kDim> z_;
};

// Describes one of the two types to the registry; the standard layout's reader and writer
// come for free from `make` and `measurement`.
template <VarType kPose>
tether::FactorType Describe(const char* name, const char* tag, const char* layout) {
  tether::FactorType type;
  type.name = name;
  type.tag = tag;
  type.dim = PositionDim(kPose);
  type.variable_types = {kPose};
  type.measurement_size = PositionDim(kPose);
  type.measurement_layout = layout;  // used in error messages about malformed lines
  type.make = [](std::vector<Key> keys, const double* m, SqrtInformation noise) -> std::unique_ptr<tether::Factor> {
    return std::make_unique<PositionPrior<kPose>>(keys[0], m, noise);
  };
  type.measurement = [](const tether::Factor& f) { return f.Measurement(); };
  return type;
}

void RegisterPositionPriors(tether::PluginRegistrar& registrar) {
  registrar.AddFactorType(Describe<VarType::kSE2>("PositionPriorSE2", "EDGE_POSITION_PRIOR_SE2", "x y"));
  registrar.AddFactorType(Describe<VarType::kSE3>("PositionPriorSE3", "EDGE_POSITION_PRIOR_SE3", "x y z"));
}

}  // namespace

TETHER_PLUGIN("position_prior", "1.0.0", RegisterPositionPriors)
