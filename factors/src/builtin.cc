#include "tether/factors/builtin.h"

#include <mutex>

#include "tether/core/error.h"
#include "tether/factors/between_se2.h"
#include "tether/factors/between_se3.h"
#include "tether/factors/pose_point.h"
#include "tether/factors/prior.h"
#include "tether/factors/range_bearing.h"
#include "tether/factors/switchable.h"

namespace tether {

namespace {

SE3d SE3FromMeasurement(const double* m) {
  // stableNorm, and dividing before the rotation normalises, keep a quaternion with entries
  // above about 1e154 from overflowing its norm to infinity and becoming all zeros.
  const double norm = Eigen::Vector4d(m[3], m[4], m[5], m[6]).stableNorm();
  if (!(norm > 1e-12)) throw InvalidArgument("quaternion of the measurement is zero; it must have unit length");
  const Eigen::Quaterniond q(m[6] / norm, m[3] / norm, m[4] / norm, m[5] / norm);
  return SE3d(q, Eigen::Vector3d(m[0], m[1], m[2]));
}

}  // namespace

void RegisterBuiltinFactors(Registry& r) {
  r.Register(DescribeFactor<BetweenSE2>("EDGE_SE2", 3, [](std::vector<Key> k, const double* m, SqrtInformation n) {
    return std::make_unique<BetweenSE2>(k[0], k[1], SE2d(m[0], m[1], m[2]), std::move(n));
  }));
  r.Register(DescribeFactor<BetweenSE3>("EDGE_SE3:QUAT", 7, [](std::vector<Key> k, const double* m, SqrtInformation n) {
    return std::make_unique<BetweenSE3>(k[0], k[1], SE3FromMeasurement(m), std::move(n));
  }));
  r.Register(DescribeFactor<PosePoint2>("EDGE_SE2_XY", 2, [](std::vector<Key> k, const double* m, SqrtInformation n) {
    return std::make_unique<PosePoint2>(k[0], k[1], Eigen::Vector2d(m[0], m[1]), std::move(n));
  }));
  {
    FactorType t = DescribeFactor<RangeBearing2>(
        "EDGE_RANGE_BEARING_SE2_XY", 2, [](std::vector<Key> k, const double* m, SqrtInformation n) {
          // The field numbers are those of the line (pose point range bearing I11 I12 I22).
          if (!(m[0] >= 0)) {
            throw InvalidArgument("the range (field 3) is " + FormatDouble(m[0]) +
                                  "; a range is a distance, finite and not negative");
          }
          return std::make_unique<RangeBearing2>(k[0], k[1], m[0], m[1], std::move(n));
        });
    t.measurement_layout = "range bearing";
    r.Register(std::move(t));
  }
  r.Register(DescribeFactor<PriorSE2>("EDGE_PRIOR_SE2", 3, [](std::vector<Key> k, const double* m, SqrtInformation n) {
    return std::make_unique<PriorSE2>(k[0], SE2d(m[0], m[1], m[2]), std::move(n));
  }));
  r.Register(DescribeFactor<PosePoint3>("", 3, [](std::vector<Key> k, const double* m, SqrtInformation n) {
    return std::make_unique<PosePoint3>(k[0], k[1], Eigen::Vector3d(m[0], m[1], m[2]), std::move(n));
  }));
  r.Register(DescribeFactor<PriorSE3>("", 7, [](std::vector<Key> k, const double* m, SqrtInformation n) {
    return std::make_unique<PriorSE3>(k[0], SE3FromMeasurement(m), std::move(n));
  }));
  RegisterSwitchableFactors(r);
}

Registry& DefaultRegistry() {
  static Registry registry;
  static std::once_flag once;
  std::call_once(once, [] { RegisterBuiltinFactors(registry); });
  return registry;
}

}  // namespace tether
