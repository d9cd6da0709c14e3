// Example plugin "range_2d": the distance from an SE2 pose to a 2D landmark, for example a
// radio beacon (UWB, Wi-Fi round-trip time) at a known or unknown position.
//
//   factor type  Range2D
//   g2o tag      EDGE_RANGE_SE2_XY
//   file line    EDGE_RANGE_SE2_XY id_pose id_landmark range I11
//   keys         SE2 pose (VERTEX_SE2), Point2 landmark (VERTEX_XY)
//   error        e = |l - t| - r   (1-dim; t: the pose's position, l: landmark, r: range)
//
// The Jacobians are written by hand (derivation in Evaluate); the plugin tests compare them
// with central differences. For a factor whose Jacobians you would rather not derive, see
// the position_prior example (automatic differentiation with ceres::Jet).
//
// Load it with `tether optimize --plugin range_2d.so graph.g2o`, or from C++ with
// tether::PluginLoader(registry).Load("range_2d.so").
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "tether/core/error.h"
#include "tether/core/factor.h"
#include "tether/plugins/plugin.h"

namespace {

using tether::Factor;
using tether::Key;
using tether::SE2d;
using tether::SqrtInformation;

// Closer than this the direction from the pose to the landmark, and with it the Jacobian, is
// undefined (|v| has no derivative at v = 0). Evaluate then returns false, which the solvers
// read as an infinite chi2: Levenberg-Marquardt rejects a step that lands there, and a graph
// that starts there is refused as invalid input. In practice a pose sitting on its beacon
// within 1e-12 units means the initial values are wrong (for example two vertices at 0 0).
constexpr double kMinDistance = 1e-12;

// The base states the name, the error size (1) and the keys' variable types (an SE2 pose, a
// 2D point) once; type_name(), residual_dim(), variable_types() and Clone() come from it, and
// so does the registry entry below (DescribeFactor).
class Range2D : public tether::TypedFactor<Range2D, 1, SE2d, Eigen::Vector2d> {
 public:
  static constexpr const char* kTypeName = "Range2D";  // the writer looks the type up by it

  Range2D(Key pose, Key landmark, double range, SqrtInformation noise)
      : TypedFactor({pose, landmark}, std::move(noise)), range_(range) {}

  // The numbers written after the ids in the file (standard layout).
  std::vector<double> Measurement() const override { return {range_}; }

  // Predict (used to give vertices without a VERTEX line an initial value) keeps the default,
  // which returns false: a range alone places neither a landmark from a pose (any point on a
  // circle fits) nor a pose from a landmark. Graphs with this factor need vertex lines, or
  // other factors that reach every variable.

  bool Evaluate(const double* const* params, double* error, double* const* jacobians) const override {
    const double* x = params[0];  // pose: x y theta
    const double* l = params[1];  // landmark: x y
    const double dx = l[0] - x[0], dy = l[1] - x[1];
    const double distance = std::hypot(dx, dy);
    if (!(distance > kMinDistance)) return false;  // on the landmark (or NaN): see kMinDistance
    error[0] = distance - range_;
    if (jacobians == nullptr) return true;

    // With u = (l - t) / |l - t|, the unit vector from the pose to the landmark, d|v|/dv = u^T.
    const double ux = dx / distance, uy = dy / distance;
    // Pose, perturbed by the SE2 box-plus t' = t + R(theta) dt, theta' = theta + dtheta:
    //   de/d(dt) = -u^T R(theta),  de/d(dtheta) = 0 (a distance does not depend on heading).
    if (double* J = jacobians[0]) {
      const double c = std::cos(x[2]), s = std::sin(x[2]);
      J[0] = -(ux * c + uy * s);
      J[1] = -(-ux * s + uy * c);
      J[2] = 0.0;
    }
    // Landmark, perturbed by l' = l + d:  de/dd = u^T.
    if (double* J = jacobians[1]) {
      J[0] = ux;
      J[1] = uy;
    }
    return true;
  }

 private:
  double range_;
};

// Describes the type to the registry: its tag, the size of its measurement, and how to build
// a factor from the numbers of a file line (the reader and writer of the standard layout come
// for free). Name, dimension and variable types come from the class.
void RegisterRange2D(tether::PluginRegistrar& registrar) {
  tether::FactorType type = tether::DescribeFactor<Range2D>(
      "EDGE_RANGE_SE2_XY", 1,
      [](std::vector<Key> keys, const double* m, SqrtInformation noise) -> std::unique_ptr<Factor> {
        // Thrown InvalidArguments reach the user with the file and line prefixed.
        if (!(m[0] >= 0)) {
          throw tether::InvalidArgument("the range is " + tether::FormatDouble(m[0]) +
                                        "; a distance cannot be negative");
        }
        return std::make_unique<Range2D>(keys[0], keys[1], m[0], std::move(noise));
      });
  type.measurement_layout = "range";  // used in error messages about malformed lines
  registrar.AddFactorType(std::move(type));
}

}  // namespace

TETHER_PLUGIN("range_2d", "1.0.0", RegisterRange2D)
