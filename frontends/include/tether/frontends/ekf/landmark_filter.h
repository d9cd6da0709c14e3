#pragma once
// What EKF-SLAM and UKF-SLAM share: the state [x, y, theta, L1x, L1y, ...] with its covariance,
// the landmarks' bookkeeping, and data association. The two filters differ in how they predict,
// correct and add a landmark (ekf_slam.h, ukf_slam.h).
//
// Data association, per observation in the order given:
// - kKnown: the observation's id names its landmark (a new id adds a landmark).
// - kNearestNeighbour: the landmark with the smallest Mahalanobis distance
//   d^2 = nu^T S^-1 nu of the innovation, among those no earlier observation of the same step
//   was taken for (a sensor sees a landmark once per scan: without this rule the landmarks of
//   the first scan, each as uncertain as the 2 m range noise, merge into a few); it is taken
//   where d^2 < gate, a new landmark is added
//   where every d^2 >= new_landmark (or there is no landmark yet), and the observation is
//   dropped in between (too close to one to be new, too far to be it). The observation's true id
//   is then only used to count wrong associations (an observation taken for a landmark that was
//   created from another true landmark).
#include <Eigen/Core>
#include <string>
#include <vector>

#include "tether/core/enum_names.h"
#include "tether/frontends/ekf/range_bearing_model.h"
#include "tether/frontends/ekf/unscented_transform.h"
#include "tether/frontends/odometry/diff_drive.h"

namespace tether {
namespace ekf {

enum class DataAssociation { kKnown, kNearestNeighbour };
/// "nn" is another name for "nearest" (the ekf-demo command's).
inline constexpr EnumName<DataAssociation> kDataAssociationNames[] = {{DataAssociation::kKnown, "known"},
                                                                      {DataAssociation::kNearestNeighbour, "nearest"},
                                                                      {DataAssociation::kNearestNeighbour, "nn"}};
constexpr const auto& EnumNames(DataAssociation) { return kDataAssociationNames; }
using ::tether::FromString;
using ::tether::ToString;
using ::tether::operator<<;

struct FilterOptions {
  /// Covariance of the controls (v, w). Default: std 0.1 m/s, pi/18 rad/s.
  Eigen::Matrix2d control_cov = odometry::OdometryNoise().control;
  /// Covariance of an observation (range, bearing). Default: std 2 m, pi/18 rad.
  Eigen::Matrix2d measurement_cov = Eigen::Vector2d(4.0, 0.17453292519943295 * 0.17453292519943295).asDiagonal();
  DataAssociation association = DataAssociation::kKnown;
  /// Nearest neighbour: accept below this d^2 (default: chi-square, 2 dof, 0.99 = 9.21) and
  /// add a landmark at or above new_landmark (default: chi-square, 2 dof, 0.999 = 13.82).
  double gate = 9.2103403719761836;
  double new_landmark = 13.815510557964274;
  /// UKF only: the sigma points' parameters.
  UnscentedParams unscented;
  /// Invariant EKF only: Gauss-Newton iterations of each correction (1: the plain update).
  /// Default 2 (docs/front_ends.md, "Consistency").
  int update_iterations = 2;
  /// Observations of landmarks nearer than this are not used (every filter): where the range
  /// noise is large against the range, no linearisation of the observation holds. A landmark
  /// in the state is judged by its predicted range (the measured one would pick observations
  /// by their noise: +0.3 m of bias at 3 m in the thesis's set-up), a new one by the measured
  /// range. Default 0: every observation is used.
  double min_range = 0;
  /// True where every part can be used; otherwise says why.
  bool IsValid(std::string* why) const;
};

class LandmarkFilter {
 public:
  /// Starts at `start` with covariance `start_cov` (zero: the start is known, as in the
  /// thesis). Throws InvalidArgument for invalid options.
  LandmarkFilter(const SE2d& start, const Eigen::Matrix3d& start_cov, const FilterOptions& options);
  virtual ~LandmarkFilter() = default;

  /// Moves the robot by the control over dt seconds. Throws InvalidArgument, changing nothing,
  /// for a non-finite control or a dt that is not positive and finite.
  void Predict(const odometry::Control& u, double dt);
  /// Corrects with the observations of one time step; returns, per observation, the index of
  /// the landmark (in the state) it was taken for, or -1 where it was dropped (or nearer than
  /// options.min_range). Throws
  /// InvalidArgument, applying nothing, where an observation's range is not positive and finite,
  /// its bearing not finite, or (known association) it has no id.
  std::vector<int> Update(const std::vector<Observation>& observations);

  SE2d pose() const { return SE2d(mean_[0], mean_[1], mean_[2]); }
  Eigen::Matrix3d pose_cov() const { return cov_.topLeftCorner<3, 3>(); }
  int landmark_count() const { return static_cast<int>(creator_id_.size()); }
  Eigen::Vector2d landmark(int i) const { return mean_.segment<2>(3 + 2 * i); }
  Eigen::Matrix2d landmark_cov(int i) const { return cov_.block<2, 2>(3 + 2 * i, 3 + 2 * i); }
  /// The true id of the observation that created landmark i (-1 where it had none).
  int creator_id(int i) const { return creator_id_[static_cast<std::size_t>(i)]; }
  const Eigen::VectorXd& mean() const { return mean_; }
  const Eigen::MatrixXd& cov() const { return cov_; }
  /// Observations taken for a landmark created from another true landmark, so far.
  int wrong_associations() const { return wrong_; }
  /// Observations dropped by the nearest-neighbour rule, so far.
  int dropped_observations() const { return dropped_; }
  /// Observations not used because their landmark was nearer than options.min_range, so far.
  int near_observations() const { return near_; }
  const FilterOptions& options() const { return options_; }

 protected:
  /// The prediction, with checked input.
  virtual void PredictChecked(const odometry::Control& u, double dt) = 0;
  /// Corrects with observation z of landmark i.
  virtual void Correct(int i, const Eigen::Vector2d& z) = 0;
  /// Appends a landmark initialised from z (mean, covariance and cross-covariances).
  virtual void AddLandmark(const Eigen::Vector2d& z) = 0;
  /// The Mahalanobis distance d^2 of z to every landmark's predicted observation (infinity where
  /// the innovation covariance is not positive definite).
  virtual std::vector<double> Distances(const Eigen::Vector2d& z) const = 0;

  /// Wraps theta; symmetrises the covariance.
  void Tidy();

  FilterOptions options_;
  Eigen::VectorXd mean_;
  Eigen::MatrixXd cov_;

 private:
  std::vector<int> creator_id_;
  int wrong_ = 0;
  int dropped_ = 0;
  int near_ = 0;
};

/// Throws InvalidArgument naming `who` unless v and w are finite and dt positive and finite.
void CheckControl(const odometry::Control& u, double dt, const std::string& who);

/// Checks a step's observations before a filter applies any: throws InvalidArgument naming `who`
/// and the observation where a range is not positive and finite, a bearing not finite, or
/// (known association) an id is missing.
void CheckObservations(const std::vector<Observation>& observations, DataAssociation association,
                       const std::string& who);

/// theta and bearings: a - b with the component `angle` wrapped.
Difference AngleDifference(int angle);

}  // namespace ekf
}  // namespace tether
