#include "tether/factors/builtin.h"

#include <mutex>

#include "tether/core/error.h"
#include "tether/factors/between_se2.h"
#include "tether/factors/between_se3.h"
#include "tether/factors/pose_point.h"
#include "tether/factors/prior.h"

namespace tether {

namespace {

SE3d SE3FromMeasurement(const double* m) {
  const Eigen::Quaterniond q(m[6], m[3], m[4], m[5]);
  if (!(q.norm() > 1e-12)) throw InvalidArgument("quaternion of the measurement is zero; it must have unit length");
  return SE3d::FromParams(m);
}

// Standard-layout type description built from (keys, measurement, noise).
FactorType Describe(std::string name, std::string tag, int dim, std::vector<VarType> types, int measurement_size,
                    std::function<std::unique_ptr<Factor>(std::vector<Key>, const double*, SqrtInformation)> make) {
  FactorType t;
  t.name = std::move(name);
  t.tag = std::move(tag);
  t.dim = dim;
  t.variable_types = std::move(types);
  t.measurement_size = measurement_size;
  t.make = std::move(make);
  t.measurement = [](const Factor& f) { return f.Measurement(); };
  return t;
}

}  // namespace

void RegisterBuiltinFactors(Registry& r) {
  const VarType se2 = VarType::kSE2, se3 = VarType::kSE3;
  r.Register(
      Describe("BetweenSE2", "EDGE_SE2", 3, {se2, se2}, 3, [](std::vector<Key> k, const double* m, SqrtInformation n) {
        return std::make_unique<BetweenSE2>(k[0], k[1], SE2d(m[0], m[1], m[2]), n);
      }));
  r.Register(Describe("BetweenSE3", "EDGE_SE3:QUAT", 6, {se3, se3}, 7,
                      [](std::vector<Key> k, const double* m, SqrtInformation n) {
                        return std::make_unique<BetweenSE3>(k[0], k[1], SE3FromMeasurement(m), n);
                      }));
  r.Register(Describe("PosePoint2", "EDGE_SE2_XY", 2, {se2, VarType::kPoint2}, 2,
                      [](std::vector<Key> k, const double* m, SqrtInformation n) {
                        return std::make_unique<PosePoint2>(k[0], k[1], Eigen::Vector2d(m[0], m[1]), n);
                      }));
  r.Register(
      Describe("PriorSE2", "EDGE_PRIOR_SE2", 3, {se2}, 3, [](std::vector<Key> k, const double* m, SqrtInformation n) {
        return std::make_unique<PriorSE2>(k[0], SE2d(m[0], m[1], m[2]), n);
      }));
  r.Register(Describe("PosePoint3", "", 3, {se3, VarType::kPoint3}, 3,
                      [](std::vector<Key> k, const double* m, SqrtInformation n) {
                        return std::make_unique<PosePoint3>(k[0], k[1], Eigen::Vector3d(m[0], m[1], m[2]), n);
                      }));
  r.Register(Describe("PriorSE3", "", 6, {se3}, 7, [](std::vector<Key> k, const double* m, SqrtInformation n) {
    return std::make_unique<PriorSE3>(k[0], SE3FromMeasurement(m), n);
  }));
}

Registry& DefaultRegistry() {
  static Registry registry;
  static std::once_flag once;
  std::call_once(once, [] { RegisterBuiltinFactors(registry); });
  return registry;
}

}  // namespace tether
