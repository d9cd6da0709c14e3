#include "tether/frontends/odometry/odometry_front_end.h"

#include <cmath>

#include "tether/core/error.h"
#include "tether/factors/between_se2.h"
#include "tether/factors/prior.h"

namespace tether {
namespace odometry {

OdometryFrontEnd::OdometryFrontEnd(const OdometryFrontEndOptions& options)
    : options_(options), integrator_(options.noise) {
  if (options_.controls_per_pose < 1) throw InvalidArgument("odometry front-end: controls_per_pose must be at least 1");
  if (!(std::isfinite(options_.prior_sigma) && options_.prior_sigma >= 0)) {
    throw InvalidArgument("odometry front-end: prior_sigma must be finite and not negative");
  }
  trajectory_.push_back(options_.start);
  pending_values_.Insert(PoseKey(0), options_.start);
  if (options_.prior_sigma > 0) {
    const double s = options_.prior_sigma;
    pending_factors_.Add<PriorSE2>(PoseKey(0), options_.start, SqrtInformation::FromSigmas(Eigen::Vector3d(s, s, s)));
  }
}

Key OdometryFrontEnd::PoseKey(int i) const { return Symbol(options_.letter, static_cast<std::uint64_t>(i)); }

bool OdometryFrontEnd::Add(const Control& u, double dt) {
  integrator_.Add(u, dt);
  return MaybeMakePose();
}

bool OdometryFrontEnd::AddMotion(const SE2d& delta, double dt) {
  integrator_.AddMotion(delta, dt);
  return MaybeMakePose();
}

bool OdometryFrontEnd::Flush() {
  if (integrator_.steps() == 0) return false;
  MakePose();
  return true;
}

bool OdometryFrontEnd::MaybeMakePose() {
  if (integrator_.steps() < options_.controls_per_pose) return false;
  MakePose();
  return true;
}

void OdometryFrontEnd::MakePose() {
  const int i = static_cast<int>(trajectory_.size());
  trajectory_.push_back(trajectory_.back() * integrator_.relative());
  pending_values_.Insert(PoseKey(i), trajectory_.back());
  pending_factors_.Add<BetweenSE2>(PoseKey(i - 1), PoseKey(i), integrator_.relative(),
                                   SqrtInformation::FromInformation(integrator_.Information()));
  integrator_.Reset();
}

void OdometryFrontEnd::TakeNew(FactorGraph* factors, Values* values) {
  for (std::size_t k = 0; k < pending_factors_.size(); ++k) factors->Add(pending_factors_.at(k).Clone());
  for (Key k : pending_values_.keys()) values->InsertParams(k, pending_values_.TypeOf(k), pending_values_.Params(k));
  pending_factors_ = FactorGraph();
  pending_values_ = Values();
}

}  // namespace odometry
}  // namespace tether
