// Example plugin "odometry_scale": wheel odometry whose distances are off by an unknown
// scale (a worn tyre, a wrong wheel radius), and the scale as a variable that the solver
// estimates beside the poses.
//
//   variable type  Scale             VERTEX_SCALE id s                 (1 parameter, 1 tangent)
//   factor type    ScaledOdometrySE2 EDGE_SE2_SCALED id_i id_j id_s dx dy dtheta I11 .. I33
//   error          e = (R(dtheta)^T (D.t - s z.t), wrap(D.theta - z.theta)),  D = Xi^-1 Xj
//
// The odometry measured z = (dx, dy, dtheta); the true motion has translation s z.t. With a
// few absolute fixes (priors, GPS, loop closures) the scale becomes observable.
#include <cmath>
#include <memory>
#include <vector>

#include "tether/core/autodiff_factor.h"
#include "tether/plugins/plugin.h"

// ---- the variable type (lines counted in docs/writing-a-factor-plugin.md) ----
namespace odometry_scale {
/// The scale: true distance = value * measured distance.
struct Scale {
  double value = 1.0;
};
}  // namespace odometry_scale

template <>
struct tether::VariableTraits<odometry_scale::Scale> {
  static constexpr const char* kName = "Scale";
  static constexpr const char* kTag = "VERTEX_SCALE";
  static constexpr const char* kParameterNames = "s";
  static constexpr int kAmbient = 1, kTangent = 1;
  template <typename T>
  static void Retract(const T* x, const T* d, T* out) {
    out[0] = x[0] + d[0];
  }
  static void Local(const double* x, const double* y, double* d) { d[0] = y[0] - x[0]; }
  static void Identity(double* x) { x[0] = 1.0; }
  static odometry_scale::Scale FromParams(const double* p) { return {p[0]}; }
  static void ToParams(const odometry_scale::Scale& s, double* p) { p[0] = s.value; }
};
// ---- end of the variable type ----

namespace odometry_scale {

// ---- the factor (lines counted in docs/writing-a-factor-plugin.md) ----
using tether::Key, tether::SE2d, tether::SqrtInformation;

class ScaledOdometrySE2 : public tether::AutoDiffFactor<ScaledOdometrySE2, 3, SE2d, SE2d, Scale> {
 public:
  static constexpr const char* kTypeName = "ScaledOdometrySE2";
  ScaledOdometrySE2(Key i, Key j, Key s, const double* z, SqrtInformation noise)
      : AutoDiffFactor({i, j, s}, std::move(noise)), z_{z[0], z[1], z[2]} {}
  template <typename T>
  bool operator()(const T* const* p, T* e) const {
    using std::cos, std::sin;
    const T dx = p[1][0] - p[0][0], dy = p[1][1] - p[0][1], c = cos(p[0][2]), s = sin(p[0][2]);
    const T tx = c * dx + s * dy - p[2][0] * z_[0], ty = -s * dx + c * dy - p[2][0] * z_[1];
    const double cz = std::cos(z_[2]), sz = std::sin(z_[2]);
    const T a = p[1][2] - p[0][2] - z_[2];
    e[0] = cz * tx + sz * ty;
    e[1] = -sz * tx + cz * ty;
    e[2] = atan2(sin(a), cos(a));  // wrapped to (-pi, pi]
    return true;
  }
  std::vector<double> Measurement() const override { return {z_[0], z_[1], z_[2]}; }

 private:
  double z_[3];
};

void Register(tether::PluginRegistrar& r) {
  r.AddVariableType<Scale>();
  r.AddFactorType(tether::DescribeFactor<ScaledOdometrySE2>(
      "EDGE_SE2_SCALED", 3, [](std::vector<Key> k, const double* m, SqrtInformation n) {
        return std::make_unique<ScaledOdometrySE2>(k[0], k[1], k[2], m, std::move(n));
      }));
}
// ---- end of the factor ----

}  // namespace odometry_scale

TETHER_PLUGIN("odometry_scale", "1.0.0", odometry_scale::Register)
