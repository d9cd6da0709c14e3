#pragma once
// Monte Carlo localisation of a robot with odometry and a 2D laser in a known map: a particle
// filter over poses (x, y, theta), with the recovery methods of the thesis's section 5.1.
//
//   MclOptions o;                      // method amcl, 1000 particles, likelihood field
//   MonteCarloLocalizer2D mcl(map, o); // map: std::shared_ptr<const OccupancyMap2D>
//   mcl.InitializeGlobal();            // or InitializeGaussian(pose, covariance)
//   for (const lidar::LaserScan& scan : log.scans) {
//     const MclStep step = mcl.AddScan(scan);   // predict, update, resample as the robot moves
//     ... step.estimate.pose, step.estimate.covariance ...
//   }
//
// One step (AddScan, or the three calls in order):
// - Predict: each particle moves by the odometry's motion since the last update, drawn from the
//   sampled odometry motion model (motion_model.h).
// - Update: (cmcl, acmcl) a particle that landed in, or whose motion crossed, the costmap's
//   invalid zone (occupied, unknown, or closer to an obstacle than the robot's radius) is
//   re-drawn uniformly over the valid cells, and marked; then every particle is weighted by the
//   measurement model (measurement_model.h). (amcl, acmcl) The average w_avg over the
//   particles — for acmcl, those not re-drawn — of each one's likelihood per beam (the mean of
//   its beams' probabilities, so that a scan's count of beams and its few beams on what the
//   map does not hold do not swing it by orders of magnitude) drives two exponential filters
//   (both start at the first update's average: from 0, as in the textbook, w_slow would stay
//   below w_fast, and no kidnap be seen, for the first 1 / alpha_slow updates),
//   w_slow += alpha_slow (w_avg - w_slow) and w_fast += alpha_fast (w_avg - w_fast).
// - Resample: low-variance resampling (or, with KLD sampling, draws until the count the
//   spread of the new set needs); (amcl, acmcl) each new particle is instead a random pose
//   drawn uniformly over the free space (acmcl: the valid cells) with probability
//   max(0, 1 - w_fast / w_slow), and marked.
//
// The estimate is the weighted mean of the heaviest cluster (particles in neighbouring bins of
// cluster_xy x cluster_theta), with its covariance. Random numbers come from one seeded stream
// drawn on the calling thread, and the weights are computed per particle, so the results are
// the same for every thread count.
#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "tether/core/enum_names.h"
#include "tether/core/se2.h"
#include "tether/frontends/lidar/sensor/laser_scan.h"
#include "tether/frontends/localization/measurement_model.h"
#include "tether/frontends/localization/motion_model.h"
#include "tether/frontends/localization/occupancy_map_2d.h"
#include "tether/frontends/localization/resampling.h"
#include "tether/frontends/simulation/random_stream.h"

namespace tether {
namespace localization {

enum class MclMethod {
  kMcl,        ///< plain MCL: no recovery
  kAugmented,  ///< Augmented MCL: random particles injected by w_slow / w_fast
  kCostmap,    ///< Costmap MCL: particles in or crossing the invalid zone re-drawn
  kAcmcl,      ///< both, the re-drawn particles left out of w_avg
  /// ACMCL while the filter is not localised (below), Augmented MCL once it is: the costmap's
  /// re-draws find the robot from a global start and after a kidnap, and stay out of tracking,
  /// where a map with an obstacle on the robot's own path (a door closed later, a person
  /// standing) or a narrow door would re-draw the particles at the true pose.
  kAuto,
};
inline constexpr EnumName<MclMethod> kMclMethodNames[] = {{MclMethod::kMcl, "mcl"},
                                                          {MclMethod::kAugmented, "amcl"},
                                                          {MclMethod::kCostmap, "cmcl"},
                                                          {MclMethod::kAcmcl, "acmcl"},
                                                          {MclMethod::kAuto, "auto"}};
constexpr const auto& EnumNames(MclMethod) { return kMclMethodNames; }

enum class MeasurementModelType { kLikelihoodField, kBeam };
inline constexpr EnumName<MeasurementModelType> kMeasurementModelTypeNames[] = {
    {MeasurementModelType::kLikelihoodField, "likelihood-field"}, {MeasurementModelType::kBeam, "beam"}};
constexpr const auto& EnumNames(MeasurementModelType) { return kMeasurementModelTypeNames; }

struct KldOptions {
  bool enabled = false;
  double epsilon = 0.05;     ///< the bound on the KL divergence between the sample and the belief
  double delta = 0.01;       ///< ... held with probability 1 - delta
  int min_particles = 100;   ///< the count never falls below this ...
  int max_particles = 5000;  ///< ... nor rises above this
};

/// The most particles a filter takes (100 bytes each with their scratch: 1 GB).
constexpr int kMaxParticles = 10000000;

struct MclOptions {
  MclMethod method = MclMethod::kAuto;
  int particles = 1000;  ///< the count (the first count where KLD sampling is on)
  OdometryMotionModel motion;
  MeasurementModelType model = MeasurementModelType::kLikelihoodField;
  LikelihoodFieldOptions likelihood_field;
  BeamModelOptions beam;
  int max_beams = 60;         ///< beams scored per scan, evenly spaced over the valid ones
  double range_cap = 0;       ///< metres: the scans' maximum range capped at this (0: not capped)
  double alpha_slow = 0.001;  ///< Augmented MCL's slow filter
  double alpha_fast = 0.1;    ///< ... and fast filter (alpha_slow < alpha_fast)
  KldOptions kld;
  double robot_radius = 0.2;  ///< metres: the costmap's inflation (cmcl, acmcl)
  /// AddScan updates once the odometry moved this far or turned this much since the last
  /// update (the first scan is always an update); between updates the estimate follows the
  /// odometry.
  double update_min_translation = 0.1;
  double update_min_rotation = 0.1;
  /// auto: the filter counts as localised where its heaviest cluster holds at least this share
  /// of the weight and spreads (the square root of its position variances' sum) at most
  /// localised_spread metres.
  double localised_weight = 0.9;
  double localised_spread = 0.5;
  double cluster_xy = 0.5;     ///< metres: bins of the estimate's clusters and of KLD sampling
  double cluster_theta = 0.2;  ///< radians
  /// Tempering: where the scan's likelihoods would leave fewer than this share of the particles'
  /// effective sample size ((sum w)^2 / sum w^2), they are raised to the largest power below 1
  /// that keeps it (a scan of many beams taken as independent is far sharper than the map and
  /// the pose's spread warrant; without this a spread-out set collapses onto the first
  /// particle near a look-alike place). 0: never tempered. 0.1 by the measurements in
  /// benchmarks/RESULTS.md ("Monte Carlo localisation on the benchmark logs").
  double min_effective_fraction = 0.1;
  int threads = 0;  ///< threads weighting the particles (0: every core)
  std::uint64_t seed = 1;

  /// False (and why) for fewer than 1 particle or more than kMaxParticles, invalid model options, alpha_slow not in
  /// (0, alpha_fast), alpha_fast above 1, a KLD setting out of range (epsilon, delta in (0, 1),
  /// 1 <= min <= max), a negative radius, update thresholds or thread count, non-positive
  /// cluster bins.
  bool IsValid(std::string* why) const;
};

struct Particle {
  double x = 0, y = 0, theta = 0;
  double weight = 0;  ///< normalised: the weights sum to 1
  SE2d pose() const { return SE2d(x, y, theta); }
};

struct PoseEstimate {
  SE2d pose;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  ///< of (x, y, theta)
  double cluster_weight = 0;                             ///< the share of the weight in the cluster it comes from
  int clusters = 0;                                      ///< clusters found
};

/// What one AddScan did.
struct MclStep {
  bool updated = false;           ///< false: the robot had not moved enough; the estimate followed odometry
  int redrawn = 0;                ///< particles the costmap re-drew
  int injected = 0;               ///< random particles the resampling injected
  int particles = 0;              ///< the count after the step
  double w_avg = 0;               ///< log of the average likelihood of the update
  double w_slow = 0, w_fast = 0;  ///< logs of the filters after the update
  double tempering = 1;           ///< the power the update raised the likelihoods to
  PoseEstimate estimate;          ///< the robot's pose at this scan
};

/// The number of samples KLD sampling asks for where the samples fill k bins (Fox 2003): the
/// upper 1 - delta quantile of the chi-square distribution with k - 1 degrees of freedom,
/// divided by 2 epsilon, by the Wilson-Hilferty approximation; 1 for k <= 1.
double KldSampleCount(int k, double epsilon, double delta);

/// The standard normal's quantile: z with P(Z <= z) = p, for p in (0, 1).
double NormalQuantile(double p);

class MonteCarloLocalizer2D {
 public:
  /// Throws InvalidArgument for invalid options (IsValid's why), a map without a free cell, or
  /// (cmcl, acmcl) a costmap without a valid cell.
  MonteCarloLocalizer2D(std::shared_ptr<const OccupancyMap2D> map, const MclOptions& options);

  /// Particles spread uniformly over the free space (cmcl and acmcl: the costmap's valid
  /// cells), equal weights.
  void InitializeGlobal();
  /// Particles drawn from a Gaussian around `mean` (covariance of x, y, theta).
  void InitializeGaussian(const SE2d& mean, const Eigen::Matrix3d& covariance);
  /// Particles as given (weights normalised; all equal where they sum to 0).
  void SetParticles(const std::vector<Particle>& particles);

  /// Moves every particle by the odometry's motion from `odometry_from` to `odometry_to`.
  void Predict(const SE2d& odometry_from, const SE2d& odometry_to);
  /// Weights the particles by the scan (re-drawing first for cmcl and acmcl). Throws
  /// InvalidArgument for a scan lidar::ScanProblem refuses.
  void Update(const lidar::LaserScan& scan);
  /// Resamples (with injections for amcl and acmcl; to the KLD count where that is on).
  void Resample();
  /// One step of a log: the first call initialises (globally unless a pose was given)
  /// and updates; later ones predict by the scan's odometry and update and resample once the
  /// robot moved enough. The returned estimate is the robot's pose at this scan.
  MclStep AddScan(const lidar::LaserScan& scan);

  PoseEstimate Estimate() const;
  const std::vector<Particle>& particles() const { return particles_; }
  /// Per particle: re-drawn by the costmap in the last Update, or injected by the last Resample.
  const std::vector<bool>& redrawn() const { return redrawn_; }
  const std::vector<bool>& injected() const { return injected_; }
  const MclOptions& options() const { return options_; }
  const OccupancyMap2D& map() const { return *map_; }
  /// The costmap (nullptr unless the method is cmcl or acmcl).
  const Costmap2D* costmap() const { return costmap_.get(); }
  /// The logs of w_slow and w_fast (-inf before the first update).
  double log_w_slow() const { return log_w_slow_; }
  double log_w_fast() const { return log_w_fast_; }
  /// True where the heaviest cluster holds localised_weight of the weight within
  /// localised_spread (the rule of the auto method, which applies it to the weighted set after
  /// each update, before the resampling injects random particles, and to a set given).
  bool Localised() const;
  /// The probability with which the next Resample injects a random particle.
  double InjectionProbability() const;
  /// Sets the filters (logs), for tests and for a caller that restores a state.
  void SetRecoveryFilters(double log_w_slow, double log_w_fast);
  /// Feeds the filters one average likelihood (its log), as an Update does.
  void UpdateRecoveryFilters(double log_w_avg);

 private:
  Particle RandomParticle();
  bool Localised(const PoseEstimate& e) const;
  void Likelihoods(const lidar::LaserScan& scan, std::vector<double>* log_likelihood, std::vector<double>* mean_p);

  std::shared_ptr<const OccupancyMap2D> map_;
  MclOptions options_;
  std::unique_ptr<Costmap2D> costmap_;
  std::unique_ptr<LikelihoodField> field_;  // built at the first scan (its range_max)
  std::unique_ptr<BeamModel> beam_model_;
  RandomStream random_;
  std::vector<Particle> particles_;
  std::vector<SE2d> before_motion_;  // each particle's pose before the last Predict
  std::vector<bool> redrawn_, injected_;
  double log_w_slow_, log_w_fast_;
  bool localised_ = false;  // auto: Localised() after the last update (or of the set given)
  bool has_last_update_ = false;
  SE2d last_update_odometry_;     // the odometry at the last update
  PoseEstimate last_estimate_;    // at the last update
  PoseEstimate update_estimate_;  // auto: the estimate of the weighted set the last Update left
  MclStep last_step_;
};

}  // namespace localization
}  // namespace tether
