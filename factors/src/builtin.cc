#include "tether/factors/builtin.h"

#include <cmath>
#include <mutex>

#include "tether/core/error.h"
#include "tether/factors/between_se2.h"
#include "tether/factors/between_se3.h"
#include "tether/factors/pose_point.h"
#include "tether/factors/prior.h"
#include "tether/factors/range_bearing.h"
#include "tether/factors/scan_match_se2.h"
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

// g2o's 3D landmark and prior edges refer to a sensor offset P on the pose (a PARAMS_SE3OFFSET
// line: the sensor's pose in the robot's frame) by a parameter id after their vertex ids.
constexpr const char* kOffsetTag = "PARAMS_SE3OFFSET";
constexpr const char* kIdentityOffset = "PARAMS_SE3OFFSET 0 0 0 0 0 0 0 1";

// The offset that field `field` of the line names; its line number goes to *line.
SE3d OffsetParameter(const Fields& f, std::size_t field, const ReadContext& ctx, long* line) {
  const Key id = f.Id(field);
  const auto it = ctx.parameters.find(id);
  if (it == ctx.parameters.end()) {
    f.Fail(std::string(f.tag()) + " field " + std::to_string(field) + " names parameter " + std::to_string(id) +
           ", which no " + kOffsetTag + " line above it defines; add '" + kOffsetTag + " " + std::to_string(id) +
           " 0 0 0 0 0 0 1' (a sensor at the robot's origin) before this line, or fix the id");
  }
  if (it->second.tag != kOffsetTag) {
    f.Fail(std::string(f.tag()) + " field " + std::to_string(field) + " names parameter " + std::to_string(id) +
           ", which line " + std::to_string(it->second.line) + " defines as " + it->second.tag + ", not " + kOffsetTag +
           "; fix the id");
  }
  *line = it->second.line;
  return SE3d::FromParams(it->second.values.data());
}

bool IsIdentity(const SE3d& p) {
  return p.translation() == Eigen::Vector3d::Zero() && std::abs(p.quaternion().w()) == 1.0;
}

Eigen::MatrixXd UpperInformation(const Fields& f, std::size_t first, int dim) {
  Eigen::MatrixXd omega(dim, dim);
  for (int i = 0; i < dim; ++i)
    for (int j = i; j < dim; ++j) omega(i, j) = omega(j, i) = f.Double(first++);
  return omega;
}

// EDGE_SE3_TRACKXYZ pose point offset_id x y z I11 I12 I13 I22 I23 I33: the point measured in
// the sensor's frame S = X P. g2o's error is R_P^T (X^-1 l - P z), so PosePoint3 with the
// measurement P z and the information R_P Omega R_P^T has the same chi2 at every estimate:
// the offset is applied exactly, and the edge is written back with the identity offset.
std::unique_ptr<Factor> ReadTrackXyz(const Fields& f, ReadContext& ctx) {
  f.ExpectCount(12, "pose point offset_id x y z I11 I12 I13 I22 I23 I33");
  const Key pose = f.Id(1), point = f.Id(2);
  long line = 0;
  const SE3d offset = OffsetParameter(f, 3, ctx, &line);
  const Eigen::Vector3d z(f.Double(4), f.Double(5), f.Double(6));
  if (IsIdentity(offset)) return std::make_unique<PosePoint3>(pose, point, z, ctx.ReadUpperInformation(f, 7, 3));
  const Eigen::Matrix3d r = offset.rotation().matrix();
  Eigen::MatrixXd omega = r * UpperInformation(f, 7, 3) * r.transpose();
  omega = 0.5 * (omega + omega.transpose()).eval();
  return std::make_unique<PosePoint3>(pose, point, offset * z, ctx.FromInformation(f, std::move(omega)));
}

// EDGE_SE3_PRIOR pose offset_id x y z qx qy qz qw + 21 information entries. g2o's error is
// that of Z^-1 X P; with P the identity it is PriorSE3's. Another offset is refused: it does
// not reduce to a prior on the robot pose with the same error.
std::unique_ptr<Factor> ReadSE3Prior(const Fields& f, ReadContext& ctx) {
  f.ExpectCount(30, "pose offset_id x y z qx qy qz qw I11 I12 .. I66 (21 entries, upper triangle row by row)");
  const Key pose = f.Id(1);
  long line = 0;
  const SE3d offset = OffsetParameter(f, 2, ctx, &line);
  double m[7];
  for (std::size_t i = 0; i < 7; ++i) m[i] = f.Double(3 + i);
  if (!IsIdentity(offset)) {
    f.Fail("EDGE_SE3_PRIOR field 2 names parameter " + std::to_string(f.Id(2)) + ", a sensor offset (" + kOffsetTag +
           " at line " + std::to_string(line) +
           ") that is not the identity; tether's PriorSE3 constrains the robot pose itself and cannot apply it "
           "exactly: give the prior on the robot pose (measurement Z * offset^-1, with the information "
           "transformed to match) and an identity offset, or remove the line");
  }
  return std::make_unique<PriorSE3>(pose, SE3FromMeasurement(m), ctx.ReadUpperInformation(f, 10, 6));
}

// tag, the factor's keys, parameter id 0 (the identity offset), measurement, information.
std::string WriteWithIdentityOffset(const char* tag, const Factor& factor) {
  std::string line = tag;
  for (Key k : factor.keys()) {
    line.push_back(' ');
    AppendKey(&line, k);
  }
  line += " 0";
  const std::vector<double> m = factor.Measurement();
  for (std::size_t i = 0; i < m.size(); ++i) {
    if (!std::isfinite(m[i])) {
      throw InvalidArgument("cannot write a factor of type '" + factor.type_name() + "': measurement number " +
                            std::to_string(i) + " is not finite, and the file could not be read back");
    }
    line.push_back(' ');
    AppendDouble(&line, m[i]);
  }
  const Eigen::MatrixXd info = factor.noise().Information();
  for (int i = 0; i < info.rows(); ++i) {
    for (int j = i; j < info.cols(); ++j) {
      line.push_back(' ');
      AppendDouble(&line, info(i, j));
    }
  }
  return line;
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
  {
    FactorType t =
        DescribeFactor<PosePoint3>("EDGE_SE3_TRACKXYZ", 3, [](std::vector<Key> k, const double* m, SqrtInformation n) {
          return std::make_unique<PosePoint3>(k[0], k[1], Eigen::Vector3d(m[0], m[1], m[2]), std::move(n));
        });
    t.read = ReadTrackXyz;
    t.write = [](const Factor& f) { return WriteWithIdentityOffset("EDGE_SE3_TRACKXYZ", f); };
    t.preamble = kIdentityOffset;
    r.Register(std::move(t));
  }
  {
    FactorType t =
        DescribeFactor<PriorSE3>("EDGE_SE3_PRIOR", 7, [](std::vector<Key> k, const double* m, SqrtInformation n) {
          return std::make_unique<PriorSE3>(k[0], SE3FromMeasurement(m), std::move(n));
        });
    t.read = ReadSE3Prior;
    t.write = [](const Factor& f) { return WriteWithIdentityOffset("EDGE_SE3_PRIOR", f); };
    t.preamble = kIdentityOffset;
    r.Register(std::move(t));
  }
  RegisterSwitchableFactors(r);
  RegisterScanMatchFactor(r);
}

Registry& DefaultRegistry() {
  static Registry registry;
  static std::once_flag once;
  std::call_once(once, [] { RegisterBuiltinFactors(registry); });
  return registry;
}

}  // namespace tether
