#include "tether/factors/scan_match_se2.h"

#include <cmath>

#include "tether/core/error.h"
#include "tether/factors/grid_interpolation.h"

namespace tether {

namespace {

SqrtInformation WeightsNoise(std::size_t n, const ScanMatchWeights& w) {
  Eigen::VectorXd sigmas(static_cast<Eigen::Index>(n) + 3);
  sigmas.head(static_cast<Eigen::Index>(n)).setConstant(std::sqrt(static_cast<double>(n)) / w.occupied_space);
  sigmas.tail<3>() << 1.0 / w.translation, 1.0 / w.translation, 1.0 / w.rotation;
  return SqrtInformation::FromSigmas(sigmas);
}

std::size_t CheckedSize(const std::vector<Eigen::Vector2d>& points, const ScanMatchWeights& weights) {
  std::string why;
  if (!weights.IsValid(&why)) throw InvalidArgument("ScanMatchSE2: " + why);
  if (points.empty()) throw InvalidArgument("ScanMatchSE2: the scan has no points; a scan needs at least one");
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!points[i].allFinite()) {
      throw InvalidArgument("ScanMatchSE2: point " + std::to_string(i) + " is not finite; drop invalid beams first");
    }
  }
  return points.size();
}

}  // namespace

bool ScanMatchWeights::IsValid(std::string* why) const {
  const auto bad = [&](const char* name, double v) {
    if (why != nullptr) {
      *why = std::string("the ") + name + " weight is " + FormatDouble(v) + "; it must be finite and positive";
    }
    return false;
  };
  if (!(std::isfinite(occupied_space) && occupied_space > 0)) return bad("occupied-space", occupied_space);
  if (!(std::isfinite(translation) && translation > 0)) return bad("translation", translation);
  if (!(std::isfinite(rotation) && rotation > 0)) return bad("rotation", rotation);
  if (!(unknown_probability >= 0 && unknown_probability <= 1)) {
    if (why != nullptr)
      *why = "unknown_probability is " + FormatDouble(unknown_probability) + "; it must lie in [0, 1]";
    return false;
  }
  return true;
}

ScanMatchSE2::ScanMatchSE2(Key pose, std::shared_ptr<const ProbabilityGrid> grid, std::vector<Eigen::Vector2d> points,
                           const SE2d& guess, const ScanMatchWeights& weights)
    : Factor({pose}, WeightsNoise(CheckedSize(points, weights), weights)),
      grid_(std::move(grid)),
      points_(std::move(points)),
      guess_(guess),
      weights_(weights) {
  if (grid_ == nullptr) throw InvalidArgument("ScanMatchSE2: the grid is null; give the submap's grid");
  if (!(std::isfinite(guess.x()) && std::isfinite(guess.y()) && std::isfinite(guess.theta()))) {
    throw InvalidArgument("ScanMatchSE2: the guess pose is not finite");
  }
}

bool ScanMatchSE2::Evaluate(const double* const* params, double* error, double* const* jacobians) const {
  const double x = params[0][0], y = params[0][1], theta = params[0][2];
  if (!(std::isfinite(x) && std::isfinite(y) && std::isfinite(theta))) return false;
  const double c = std::cos(theta), s = std::sin(theta);
  double* jac = jacobians != nullptr ? jacobians[0] : nullptr;
  const std::size_t n = points_.size();
  for (std::size_t k = 0; k < n; ++k) {
    const Eigen::Vector2d& h = points_[k];
    const Eigen::Vector2d rh(c * h.x() - s * h.y(), s * h.x() + c * h.y());
    Eigen::Vector2d g;
    error[k] = 1.0 - InterpolateProbability(*grid_, Eigen::Vector2d(x + rh.x(), y + rh.y()), jac ? &g : nullptr,
                                            weights_.unknown_probability);
    if (jac != nullptr) {
      // d(T h)/d(dt) = R, d(T h)/d(dtheta) = (-(R h)_y, (R h)_x).
      double* row = jac + 3 * k;
      row[0] = -(g.x() * c + g.y() * s);
      row[1] = -(-g.x() * s + g.y() * c);
      row[2] = -(-g.x() * rh.y() + g.y() * rh.x());
    }
  }
  error[n] = x - guess_.x();
  error[n + 1] = y - guess_.y();
  error[n + 2] = SE2d(0, 0, theta - guess_.theta()).theta();
  if (jac != nullptr) {
    double* r = jac + 3 * n;
    r[0] = c, r[1] = -s, r[2] = 0;
    r[3] = s, r[4] = c, r[5] = 0;
    r[6] = 0, r[7] = 0, r[8] = 1;
  }
  return true;
}

void RegisterScanMatchFactor(Registry& registry) {
  FactorType t;
  t.name = ScanMatchSE2::kTypeName;
  t.dim = 3;
  t.variable_types = {VarType::kSE2};
  registry.Register(std::move(t));
}

}  // namespace tether
