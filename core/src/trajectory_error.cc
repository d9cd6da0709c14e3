#include "tether/core/trajectory_error.h"

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

namespace tether {

TrajectoryError AbsoluteTrajectoryError(const Values& estimate, const Values& truth, AteAlignment alignment) {
  std::vector<Eigen::Vector3d> est, ref;
  bool planar = true;
  auto position = [](const Values& v, Key k) {
    const double* p = v.Params(k);
    return v.TypeOf(k) == VarType::kSE3 ? Eigen::Vector3d(p[0], p[1], p[2]) : Eigen::Vector3d(p[0], p[1], 0.0);
  };
  for (Key k : estimate.keys()) {
    if (!IsPose(estimate.TypeOf(k)) || !truth.Has(k) || !IsPose(truth.TypeOf(k))) continue;
    const Eigen::Vector3d e = position(estimate, k), t = position(truth, k);
    if (!e.allFinite() || !t.allFinite()) continue;
    planar = planar && estimate.TypeOf(k) == VarType::kSE2 && truth.TypeOf(k) == VarType::kSE2;
    est.push_back(e);
    ref.push_back(t);
  }
  TrajectoryError r;
  r.poses = static_cast<int>(est.size());
  if (est.empty()) {
    r.rmse = r.mean = r.max = std::numeric_limits<double>::quiet_NaN();
    return r;
  }
  const int dim = planar ? 2 : 3;
  const Eigen::Index n = static_cast<Eigen::Index>(est.size());
  Eigen::MatrixXd src(dim, n), dst(dim, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    src.col(i) = est[static_cast<std::size_t>(i)].head(dim);
    dst.col(i) = ref[static_cast<std::size_t>(i)].head(dim);
  }
  if (alignment == AteAlignment::kRigid && n >= 2) {
    // The rigid transform (rotation with det +1, translation) minimising sum |T src_i - dst_i|^2.
    const Eigen::MatrixXd t = Eigen::umeyama(src, dst, false);
    src = (t.topLeftCorner(dim, dim) * src).colwise() + t.col(dim).head(dim);
  } else if (alignment == AteAlignment::kRigid) {
    src = dst;  // one pose: a translation aligns it exactly
  }
  double sum_sq = 0, sum = 0, max = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    const double e = (src.col(i) - dst.col(i)).norm();
    sum_sq += e * e;
    sum += e;
    max = std::max(max, e);
  }
  r.rmse = std::sqrt(sum_sq / static_cast<double>(n));
  r.mean = sum / static_cast<double>(n);
  r.max = max;
  return r;
}

std::string FormatMetres(double metres) {
  if (std::isnan(metres)) return "n/a";
  char buf[48];
  std::snprintf(buf, sizeof(buf), "%.3g m", metres);
  return buf;
}

}  // namespace tether
