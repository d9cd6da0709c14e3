#pragma once
// FastSLAM (Montemerlo et al. 2002, 2003) on point landmarks seen by range and bearing, the
// particle filter of the landmark experiment (`tether ekf-demo`) beside the EKF, the UKF and the
// invariant EKF. Each particle carries one sample of the robot's path and, per landmark, a 2x2
// EKF conditioned on that path; the landmarks of different particles are independent given
// their paths (the Rao-Blackwellisation), so a particle's update costs O(log n), not O(n^2).
//
// One time step: Predict(u, dt), then Update(observations).
// - FastSLAM 1.0: Predict samples each particle's pose from the motion model (the control plus
//   Gaussian noise of FilterOptions::control_cov, through odometry::Move). Update takes each
//   observation for a landmark (below), weighs the particle by the observation's likelihood at
//   the sampled pose, N(nu; 0, H_l P_l H_l^T + R), and corrects the landmark's EKF.
// - FastSLAM 2.0: the proposal includes the current observations. Predict keeps each particle's
//   predicted pose and its covariance Q = B Sigma_u B^T (B the motion's Jacobian in the
//   controls); Update conditions that Gaussian on the step's observations one after the other,
//   each a Kalman update of the pose with the landmark's uncertainty added to the noise
//   (ConditionPose), samples the pose from the result and then corrects the landmarks at the
//   sample. The weight is the product of the observations' predictive likelihoods, each
//   N(nu; 0, H_x Sigma_x H_x^T + H_l P_l H_l^T + R) at the pose belief before it: the
//   likelihood of the step's observations with the pose integrated out (linearised).
// - A new landmark is initialised from the observation at the sampled pose (mean and
//   G R G^T); an observation that starts a landmark, or is dropped by the association, weighs
//   its particle by new_landmark_likelihood (below).
// - Data association (FilterOptions::association), per particle: kKnown by the observation's
//   id; kNearestNeighbour by the smallest Mahalanobis distance d^2 of the innovation (with the
//   covariance above: 2.0 includes the pose belief), among that particle's landmarks no earlier
//   observation of the step was taken for, with FilterOptions' gate and new_landmark thresholds
//   as in the EKF (landmark_filter.h). Each particle thus holds its own hypothesis of which
//   landmark is which, and resampling keeps the hypotheses whose predictions came true.
// - Weights are kept as logarithms. Resampling is selective: low-variance resampling
//   (localization/resampling.h) at the start of a Predict, where the effective sample size has
//   fallen below resample_fraction * particles; otherwise the weights carry on.
// - The landmarks are a PersistentArray (core/persistent_array.h): a resampled particle shares
//   its parent's landmarks until one of them changes, and a change copies O(log n) of them.
//   The path is a linked list of steps shared the same way.
//
// The estimate of the robot (pose(), pose_cov()) is the particles' weighted mean and their
// weighted covariance (the heading by its mean direction, differences wrapped). FastSLAM 2.0
// reads each particle's proposal there, not its sample: the weighted proposals are the filter's
// posterior of the current pose (a mixture of Gaussians), the samples one draw from it. The map
// (landmarks(), Track) is the heaviest particle's. Deterministic for a seed.
#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "tether/core/persistent_array.h"
#include "tether/core/se2.h"
#include "tether/frontends/ekf/landmark_filter.h"
#include "tether/frontends/ekf/landmark_graph.h"
#include "tether/frontends/ekf/landmark_simulator.h"
#include "tether/frontends/simulation/random_stream.h"

namespace tether {
namespace ekf {

enum class FastSlamVersion { kOne, kTwo };
inline constexpr EnumName<FastSlamVersion> kFastSlamVersionNames[] = {{FastSlamVersion::kOne, "1.0"},
                                                                      {FastSlamVersion::kTwo, "2.0"},
                                                                      {FastSlamVersion::kOne, "1"},
                                                                      {FastSlamVersion::kTwo, "2"}};
constexpr const auto& EnumNames(FastSlamVersion) { return kFastSlamVersionNames; }

struct FastSlamOptions {
  /// The noise, the data association and its thresholds, min_range (the UKF's and the invariant
  /// EKF's parts are not used).
  FilterOptions filter;
  FastSlamVersion version = FastSlamVersion::kTwo;
  int particles = 100;
  /// Resample where the effective sample size is below this share of the particles (0: never,
  /// 1: at every step).
  double resample_fraction = 0.5;
  /// The likelihood an observation that starts a landmark, or is dropped, weighs its particle
  /// by, as the Gaussian density at this squared Mahalanobis distance with the measurement
  /// noise's covariance; negative: FilterOptions::new_landmark. (With known association every
  /// particle starts the same landmarks, and it cancels.)
  double new_landmark_d2 = -1;
  /// FastSLAM 2.0: the predicted pose covariance B Sigma_u B^T of a step has rank 2 (the model
  /// has no sideways slip), so a particle's proposal is flat in one direction and the estimate's
  /// covariance singular where one particle holds the weight (NEES in the billions). The
  /// proposal adds motion_floor^2 times Q's largest eigenvalue on its diagonal: a floor that
  /// scales with the noise (the landmark graph's absolute 0.03 cost 70% in accuracy at a tenth of
  /// the thesis's noise). 0.3 against 0.1 and none, 50 worlds at the thesis's noise and at a
  /// tenth of it (benchmarks/RESULTS.md, "FastSLAM"): the lowest NEES at both, the accuracy
  /// within the worlds' spread. FastSLAM 1.0 samples the controls through the exact motion and
  /// uses none.
  double motion_floor = 0.3;
  std::uint64_t seed = 1;
  bool IsValid(std::string* why) const;
};

/// One landmark's EKF in one particle.
struct LandmarkGaussian {
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
  Eigen::Vector2d first_seen = Eigen::Vector2d::Zero();  ///< the mean it started with
  int creator_id = -1;                                   ///< the true id of the observation that started it
};

/// A Gaussian belief of the pose in the parameters (x, y, theta).
struct PoseBelief {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
};

/// Conditions the pose belief on one linearised observation: innovation nu (measured minus
/// predicted at the belief's mean), Jacobian hx of the prediction in the pose, and noise the
/// covariance of everything else in the innovation (for FastSLAM 2.0: the landmark's
/// uncertainty through its Jacobian plus the measurement noise). A Kalman update of `belief`;
/// returns log N(nu; 0, hx cov hx^T + noise), the observation's predictive log-likelihood, or
/// NaN (belief unchanged) where that covariance is not positive definite.
double ConditionPose(PoseBelief* belief, const Eigen::Vector2d& nu, const Eigen::Matrix<double, 2, 3>& hx,
                     const Eigen::Matrix2d& noise);

class FastSlam {
 public:
  /// Particles drawn around `start` with covariance `start_cov` (zero: all at the start, as in
  /// the thesis). Throws InvalidArgument for invalid options or start.
  FastSlam(const SE2d& start, const Eigen::Matrix3d& start_cov, const FastSlamOptions& options);

  /// Moves the particles by the control over dt seconds (1.0: samples; 2.0: predicts, the
  /// sample is drawn in Update). Throws InvalidArgument, changing nothing, for a non-finite
  /// control, a dt that is not positive and finite, or a motion that leaves a pose not finite.
  void Predict(const odometry::Control& u, double dt);
  /// The step's observations. Returns, per observation, the landmark index the heaviest particle
  /// took it for (-1: dropped or too near). Throws InvalidArgument, applying nothing, as
  /// LandmarkFilter::Update does.
  std::vector<int> Update(const std::vector<Observation>& observations);

  int particle_count() const { return static_cast<int>(particles_.size()); }
  /// Particle i's pose (2.0 between Predict and Update: its predicted mean).
  SE2d particle_pose(int i) const;
  /// The normalised weights.
  std::vector<double> weights() const;
  double effective_sample_size() const;
  /// The heaviest particle (the lowest index among equals).
  int best_particle() const;
  int landmark_count(int particle) const;
  const LandmarkGaussian& landmark(int particle, int j) const;

  /// The weighted mean of the particles and their weighted covariance (x, y, theta).
  SE2d pose() const;
  Eigen::Matrix3d pose_cov() const;

  /// The heaviest particle's path (the start first, one pose per Update) and, per Update, the
  /// landmark index it took each observation for.
  std::vector<SE2d> best_path() const;
  std::vector<std::vector<int>> best_association() const;
  /// The heaviest particle's wrong associations (an observation taken for a landmark started by
  /// another true landmark) and dropped observations, over its whole path.
  int wrong_associations() const;
  int dropped_observations() const;
  /// Resampling steps so far.
  int resamplings() const { return resamplings_; }
  const FastSlamOptions& options() const { return options_; }

 private:
  struct Step {  // one Update of one particle's path
    SE2d pose;
    std::vector<int> association;
    int wrong = 0, dropped = 0;  // so far, this step included
    std::shared_ptr<const Step> parent;
  };
  struct Particle {
    PoseBelief belief;    // 1.0: the sample (zero covariance); 2.0 after Predict: the prediction
    PoseBelief proposal;  // 2.0 after Update: the Gaussian the pose was drawn from
    double log_weight = 0;
    PersistentArray<LandmarkGaussian> landmarks;
    std::shared_ptr<const Step> path;
    bool predicted = false;  // 2.0: Predict since the last sample
  };

  void MaybeResample();
  /// Predict's work, its input checked.
  void PredictChecked(const odometry::Control& u, double dt);
  /// What the estimate reads of a particle: 2.0 after an Update its proposal, else its pose.
  const PoseBelief& Estimated(const Particle& p) const;
  /// Samples the particle's pose from its belief (2.0).
  void Sample(Particle* p);
  const Particle& best() const { return particles_[static_cast<std::size_t>(best_particle())]; }

  FastSlamOptions options_;
  double log_new_landmark_ = 0;
  double floor2_ = 0;
  std::vector<Particle> particles_;
  std::vector<int> id_to_index_;  // known association: the same in every particle
  RandomStream random_;
  int resamplings_ = 0;
};

/// Runs FastSLAM over the world (predict with each control, update with the step's
/// observations): poses and pose_cov the filter's estimate after each step (the weighted mean
/// and covariance), association, landmarks and their covariances the heaviest particle's at the
/// end, first_seen and creator_id its landmarks' starts.
Track RunFastSlam(FastSlam* filter, const LandmarkWorld& world);

}  // namespace ekf
}  // namespace tether
