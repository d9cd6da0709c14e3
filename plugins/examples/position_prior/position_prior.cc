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
#include <type_traits>
#include <vector>

#include "tether/core/autodiff_factor.h"
#include "tether/plugins/plugin.h"

namespace {

using tether::Key;
using tether::SE2d;
using tether::SE3d;
using tether::SqrtInformation;

// Position components of a pose type.
template <class Pose>
constexpr int kPositionDim = std::is_same_v<Pose, SE2d> ? 2 : 3;

// One class template serves both pose types: SE2 (x y theta) and SE3 (tx ty tz qx qy qz qw)
// parameters both start with the position. The base states the name, the error size and the
// key's variable type once; the registration below reads them from here.
template <class Pose>
class PositionPrior : public tether::AutoDiffFactor<PositionPrior<Pose>, kPositionDim<Pose>, Pose> {
 public:
  static constexpr int kDim = kPositionDim<Pose>;
  // The registered name: the writer looks the type up by it.
  static constexpr const char* kTypeName = kDim == 2 ? "PositionPriorSE2" : "PositionPriorSE3";

  PositionPrior(Key key, const double* z, SqrtInformation noise)
      : tether::AutoDiffFactor<PositionPrior, kDim, Pose>({key}, std::move(noise)) {
    std::copy(z, z + kDim, z_.begin());
  }

  // The residual. params[0] holds the pose's raw parameters (already perturbed, when T is a Jet).
  template <typename T>
  bool operator()(const T* const* params, T* error) const {
    for (int i = 0; i < kDim; ++i) error[i] = params[0][i] - T(z_[i]);
    return true;
  }

  // The numbers written after the id in the file (standard layout).
  std::vector<double> Measurement() const override { return {z_.begin(), z_.end()}; }
  // Predict keeps the default (false): a unary factor has no other variable to place.

 private:
  std::array<double, kDim> z_;
};

// Describes one of the two types to the registry; name, size and variable type come from the
// class, the standard layout's reader and writer from `make` and `measurement`.
template <class Pose>
tether::FactorType Describe(const char* tag, const char* layout) {
  using F = PositionPrior<Pose>;
  tether::FactorType type = tether::DescribeFactor<F>(
      tag, F::kDim,
      [](std::vector<Key> keys, const double* m, SqrtInformation noise) -> std::unique_ptr<tether::Factor> {
        return std::make_unique<F>(keys[0], m, std::move(noise));
      });
  type.measurement_layout = layout;  // used in error messages about malformed lines
  return type;
}

void RegisterPositionPriors(tether::PluginRegistrar& registrar) {
  registrar.AddFactorType(Describe<SE2d>("EDGE_POSITION_PRIOR_SE2", "x y"));
  registrar.AddFactorType(Describe<SE3d>("EDGE_POSITION_PRIOR_SE3", "x y z"));
}

}  // namespace

TETHER_PLUGIN("position_prior", "1.0.0", RegisterPositionPriors)
