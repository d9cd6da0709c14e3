#include "tether/frontends/ekf/landmark_filter.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>

#include "tether/core/error.h"

namespace tether {
namespace ekf {

namespace {

bool IsCovariance(const Eigen::Matrix2d& m) {
  return m.allFinite() && m.isApprox(m.transpose()) && m.llt().info() == Eigen::Success;
}

}  // namespace

bool FilterOptions::IsValid(std::string* why) const {
  const auto fail = [&](const std::string& w) {
    if (why != nullptr) *why = w;
    return false;
  };
  if (!odometry::IsControlCovariance(control_cov)) {
    return fail("control_cov must be symmetric, finite and positive semi-definite");
  }
  if (!IsCovariance(measurement_cov)) return fail("measurement_cov must be symmetric, finite and positive definite");
  if (!(gate > 0 && new_landmark >= gate && std::isfinite(new_landmark))) {
    return fail("nearest neighbour needs 0 < gate <= new_landmark (both finite)");
  }
  std::string u;
  if (!unscented.IsValid(&u)) return fail("unscented: " + u);
  if (update_iterations < 1) return fail("update_iterations must be at least 1");
  if (!(std::isfinite(min_range) && min_range >= 0)) return fail("min_range must be finite and not negative");
  return true;
}

LandmarkFilter::LandmarkFilter(const SE2d& start, const Eigen::Matrix3d& start_cov, const FilterOptions& options)
    : options_(options), mean_(3), cov_(start_cov) {
  std::string why;
  if (!options_.IsValid(&why)) throw InvalidArgument("landmark filter: " + why);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(start_cov, Eigen::EigenvaluesOnly);
  if (!start_cov.allFinite() || !start_cov.isApprox(start_cov.transpose(), 1e-12) ||
      eig.eigenvalues()[0] < -1e-12 * std::max(1.0, start_cov.cwiseAbs().maxCoeff())) {
    throw InvalidArgument("landmark filter: the start covariance must be symmetric, finite and positive semi-definite");
  }
  if (!std::isfinite(start.x()) || !std::isfinite(start.y()) || !std::isfinite(start.theta())) {
    throw InvalidArgument("landmark filter: the start pose must be finite");
  }
  mean_ << start.x(), start.y(), start.theta();
}

void LandmarkFilter::Predict(const odometry::Control& u, double dt) {
  CheckControl(u, dt, "landmark filter");
  PredictChecked(u, dt);
}

std::vector<int> LandmarkFilter::Update(const std::vector<Observation>& observations) {
  // Every observation is checked before any is applied: a refused step changes nothing.
  CheckObservations(observations, options_.association, "landmark filter");
  std::vector<int> taken(observations.size(), -1);
  std::vector<bool> used(static_cast<std::size_t>(landmark_count()), false);  // this step's, by index
  for (std::size_t k = 0; k < observations.size(); ++k) {
    const Observation& o = observations[k];
    const Eigen::Vector2d z(o.range, o.bearing);
    int chosen = -1;
    bool add = false;
    if (options_.association == DataAssociation::kKnown) {
      const auto it = std::find(creator_id_.begin(), creator_id_.end(), o.id);
      if (it == creator_id_.end()) {
        add = true;
      } else {
        chosen = static_cast<int>(it - creator_id_.begin());
      }
    } else {
      const std::vector<double> d = Distances(z);
      double best = std::numeric_limits<double>::infinity();
      for (std::size_t i = 0; i < d.size(); ++i) {
        if (i < used.size() && used[i]) continue;  // one observation per landmark and step
        if (d[i] < best) {
          best = d[i];
          chosen = static_cast<int>(i);
        }
      }
      if (best >= options_.new_landmark) {
        add = true;
        chosen = -1;
      } else if (!(best < options_.gate)) {
        chosen = -1;
        ++dropped_;
      }
    }
    // Too near to use: a landmark already in the state by its predicted range (not the measured
    // one, which would select observations by their noise), a new one by the measured range.
    const bool near = add ? o.range < options_.min_range
                          : chosen >= 0 && (landmark(chosen) - mean_.head<2>()).norm() < options_.min_range;
    if (near) {
      ++near_;
      continue;
    }
    if (add) {
      AddLandmark(z);
      creator_id_.push_back(o.id);
      chosen = landmark_count() - 1;
    } else if (chosen >= 0) {
      if (o.id >= 0 && creator_id_[static_cast<std::size_t>(chosen)] != o.id) ++wrong_;
      Correct(chosen, z);
    }
    Tidy();
    taken[k] = chosen;
    if (chosen >= 0) {
      used.resize(static_cast<std::size_t>(landmark_count()), false);
      used[static_cast<std::size_t>(chosen)] = true;
    }
  }
  return taken;
}

void CheckControl(const odometry::Control& u, double dt, const std::string& who) {
  if (!std::isfinite(u.v) || !std::isfinite(u.w) || !(std::isfinite(dt) && dt > 0)) {
    throw InvalidArgument(who + ": a prediction needs finite v and w and a positive, finite dt (got v " +
                          std::to_string(u.v) + ", w " + std::to_string(u.w) + ", dt " + std::to_string(dt) + ")");
  }
}

void CheckObservations(const std::vector<Observation>& observations, DataAssociation association,
                       const std::string& who) {
  for (std::size_t k = 0; k < observations.size(); ++k) {
    const Observation& o = observations[k];
    if (!(std::isfinite(o.range) && std::isfinite(o.bearing) && o.range > 0)) {
      throw InvalidArgument(who + ": observation " + std::to_string(k) +
                            " needs a positive, finite range and a finite bearing; nothing of this step was applied");
    }
    if (association == DataAssociation::kKnown && o.id < 0) {
      throw InvalidArgument(who + ": known data association needs every observation's id (observation " +
                            std::to_string(k) + " has none); nothing of this step was applied");
    }
  }
}

void LandmarkFilter::Tidy() {
  mean_[2] = WrapAngle(mean_[2]);
  cov_ = 0.5 * (cov_ + cov_.transpose()).eval();
}

Difference AngleDifference(int angle) {
  return [angle](const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
    Eigen::VectorXd d = a - b;
    d[angle] = WrapAngle(d[angle]);
    return d;
  };
}

}  // namespace ekf
}  // namespace tether
