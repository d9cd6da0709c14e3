// my_factors: two factor types for tether.
//
// | type       | g2o tag             | keys        | after the tag                   | Jacobians |
// |------------|---------------------|-------------|---------------------------------|-----------|
// | Bearing2D  | EDGE_BEARING_SE2_XY | SE2, Point2 | id_pose id_landmark bearing I11 | analytic  |
// | Distance2D | EDGE_DISTANCE_SE2   | SE2, SE2    | id_a id_b distance I11          | automatic |
#include <cmath>
#include <memory>
#include <vector>

#include "tether/core/autodiff_factor.h"
#include "tether/core/so2.h"
#include "tether/plugins/plugin.h"

namespace {

using tether::Key, tether::SE2d, tether::SqrtInformation;

// The bearing of a landmark seen from a pose, in the pose's frame (a camera or a direction
// finder). With v = l - t:  e = wrap(atan2(v_y, v_x) - theta - z).
class Bearing2D : public tether::TypedFactor<Bearing2D, 1, SE2d, Eigen::Vector2d> {
 public:
  static constexpr const char* kTypeName = "Bearing2D";
  Bearing2D(Key pose, Key landmark, double bearing, SqrtInformation noise)
      : TypedFactor({pose, landmark}, std::move(noise)), bearing_(bearing) {}
  std::vector<double> Measurement() const override { return {bearing_}; }

  bool Evaluate(const double* const* params, double* error, double* const* jacobians) const override {
    const double* x = params[0];  // pose: x y theta
    const double* l = params[1];  // landmark: x y
    const double vx = l[0] - x[0], vy = l[1] - x[1], r2 = vx * vx + vy * vy;
    if (!(r2 > 1e-24)) return false;  // the landmark sits on the pose: no bearing
    error[0] = tether::WrapAngle(std::atan2(vy, vx) - x[2] - bearing_);
    if (jacobians == nullptr) return true;

    // d atan2(v_y, v_x) / dv = g^T with g = (-v_y, v_x) / |v|^2.
    const double gx = -vy / r2, gy = vx / r2;
    // Pose, moved by the SE2 box-plus t' = t + R(theta) dt, theta' = theta + dtheta:
    //   de/d(dt) = -g^T R(theta),  de/d(dtheta) = -1.
    if (double* J = jacobians[0]) {  // 1 x 3, row-major
      const double c = std::cos(x[2]), s = std::sin(x[2]);
      J[0] = -(gx * c + gy * s);
      J[1] = -(-gx * s + gy * c);
      J[2] = -1.0;
    }
    // Landmark, moved by l' = l + d:  de/dd = g^T.
    if (double* J = jacobians[1]) {  // 1 x 2
      J[0] = gx;
      J[1] = gy;
    }
    return true;
  }

 private:
  double bearing_;
};

// The distance between two poses (two robots with UWB radios, or one robot that measured how
// far it is from where it was). Only the error is written, as a template: AutoDiffFactor
// evaluates it with T = double, and with T = ceres::Jet for the Jacobians.
class Distance2D : public tether::AutoDiffFactor<Distance2D, 1, SE2d, SE2d> {
 public:
  static constexpr const char* kTypeName = "Distance2D";
  Distance2D(Key a, Key b, double distance, SqrtInformation noise)
      : AutoDiffFactor({a, b}, std::move(noise)), distance_(distance) {}
  std::vector<double> Measurement() const override { return {distance_}; }

  template <typename T>
  bool operator()(const T* const* params, T* error) const {
    using std::sqrt;  // ceres::sqrt for Jets is found by argument-dependent lookup
    const T dx = params[1][0] - params[0][0];
    const T dy = params[1][1] - params[0][1];
    const T d2 = dx * dx + dy * dy;
    if (!(d2 > T(1e-24))) return false;  // sqrt has no derivative at 0
    error[0] = sqrt(d2) - T(distance_);
    return true;
  }

 private:
  double distance_;
};

// Name, dimension and variable types come from the classes (DescribeFactor); the rest is the
// g2o tag, the number of measurement values after the ids, and how to make a factor of them.
void RegisterMyFactors(tether::PluginRegistrar& registrar) {
  tether::FactorType bearing = tether::DescribeFactor<Bearing2D>(
      "EDGE_BEARING_SE2_XY", 1, [](std::vector<Key> keys, const double* m, SqrtInformation noise) {
        return std::make_unique<Bearing2D>(keys[0], keys[1], m[0], std::move(noise));
      });
  bearing.measurement_layout = "bearing";  // names the value in messages about malformed lines
  registrar.AddFactorType(std::move(bearing));

  tether::FactorType distance = tether::DescribeFactor<Distance2D>(
      "EDGE_DISTANCE_SE2", 1, [](std::vector<Key> keys, const double* m, SqrtInformation noise) {
        if (!(m[0] >= 0)) throw tether::InvalidArgument("a distance cannot be negative");
        return std::make_unique<Distance2D>(keys[0], keys[1], m[0], std::move(noise));
      });
  distance.measurement_layout = "distance";
  registrar.AddFactorType(std::move(distance));
}

}  // namespace

TETHER_PLUGIN("my_factors", "0.1.0", RegisterMyFactors)
