#pragma once
// How well a scan fits the map from a particle's pose: the two measurement models of
// "Probabilistic Robotics" (chapter 6).
//
// - The likelihood field: a beam's end point is scored by the distance d from it to the
//   nearest occupied cell, p = z_hit exp(-d^2 / (2 sigma_hit^2)) + z_rand / range_max, with d
//   capped at max_distance; beams without a return are left out. The score of every cell is
//   computed once, so a beam costs a lookup.
// - The beam model: a ray is cast through the map from the laser to the first occupied cell
//   (the expected range z*), and the measured range z is scored by the mixture of a hit
//   (Gaussian around z*), a short reading (exponential, z < z*), a no-return (z at the
//   maximum range) and a random reading (uniform).
//
// A scan's score is the sum of its beams' log p (their product: the beams independent), or
// where `combination` is kSumOfCubes, log(1 + sum of p^3) — the ad hoc rule of the ROS amcl
// package, which is much less peaked and so keeps more particles alive.
//
//   const ScanBeams beams = SelectBeams(scan, 60);
//   const LikelihoodField field(map, {});
//   const double log_weight = field.LogLikelihood(pose, beams);
#include <Eigen/Core>
#include <string>
#include <vector>

#include "tether/core/enum_names.h"
#include "tether/core/se2.h"
#include "tether/frontends/lidar/sensor/laser_scan.h"
#include "tether/frontends/localization/occupancy_map_2d.h"

namespace tether {
namespace localization {

enum class BeamCombination { kProduct, kSumOfCubes };
inline constexpr EnumName<BeamCombination> kBeamCombinationNames[] = {{BeamCombination::kProduct, "product"},
                                                                      {BeamCombination::kSumOfCubes, "sum-of-cubes"}};
constexpr const auto& EnumNames(BeamCombination) { return kBeamCombinationNames; }

/// The beams of a scan a model scores, in the robot's frame.
struct ScanBeams {
  Eigen::Vector2d laser = Eigen::Vector2d::Zero();  ///< the laser's position on the robot
  std::vector<double> angles;                       ///< each beam's direction (robot frame, radians)
  std::vector<double> ranges;                       ///< metres; range_max where no return
  std::vector<bool> hit;                            ///< false: no return (range_max)
  double range_max = 0;
};

/// Up to `max_beams` of the scan's beams, evenly spaced over its valid ones (every valid beam
/// where max_beams is 0 or at least their number), and, where `with_no_returns`, the beams
/// without a return too (for the beam model), at range_max. The scan's laser_in_robot places
/// them on the robot. range_max is the scan's, capped at `range_cap` where that is positive.
ScanBeams SelectBeams(const lidar::LaserScan& scan, int max_beams, bool with_no_returns = false, double range_cap = 0);

struct LikelihoodFieldOptions {
  double sigma_hit = 0.1;     ///< metres
  double z_hit = 0.95;        ///< weight of the hit term
  double z_rand = 0.05;       ///< weight of the uniform term (over [0, range_max])
  double max_distance = 2.0;  ///< metres: distances beyond count as this
  BeamCombination combination = BeamCombination::kProduct;
  bool IsValid(std::string* why) const;
};

class LikelihoodField {
 public:
  /// Scores for beams of at most `range_max` metres (the z_rand term's range). Throws
  /// InvalidArgument for invalid options or a non-positive range_max.
  LikelihoodField(const OccupancyMap2D& map, const LikelihoodFieldOptions& options, double range_max);

  /// The scan's log-likelihood from robot pose `pose` (its beams' end points looked up; an end
  /// point outside the map scores as max_distance).
  double LogLikelihood(const SE2d& pose, const ScanBeams& beams) const;
  /// The same for many poses (x, y, theta each), written to `out`; the end points are put in
  /// cells once for all of them. Where `mean_probability` is given, each pose's mean beam
  /// probability p (over its beams) goes there.
  void LogLikelihoods(const double* poses, std::size_t count, const ScanBeams& beams, double* out,
                      double* mean_probability = nullptr) const;
  /// A beam's p where its end point lies at `distance` from the nearest occupied cell ...
  double BeamProbability(double distance) const;
  /// ... and its score: log p (product) or p^3 (sum of cubes).
  double BeamScore(double distance) const;
  double range_max() const { return range_max_; }
  const LikelihoodFieldOptions& options() const { return options_; }

 private:
  GridGeometry geometry_;
  LikelihoodFieldOptions options_;
  double range_max_;
  struct Cell {
    float score;  // log p (product) or p^3 (sum of cubes)
    float p;
  };
  std::vector<Cell> cells_;  // per cell: a lookup reads both from one cache line
  Cell outside_;             // an end point outside the map
};

struct BeamModelOptions {
  double z_hit = 0.8, z_short = 0.1, z_max = 0.05, z_rand = 0.05;
  double sigma_hit = 0.1;     ///< metres
  double lambda_short = 0.1;  ///< 1/metres
  BeamCombination combination = BeamCombination::kProduct;
  bool IsValid(std::string* why) const;
};

class BeamModel {
 public:
  /// Throws InvalidArgument for invalid options. The map must outlive the model.
  BeamModel(const OccupancyMap2D& map, const BeamModelOptions& options);
  /// The scan's log-likelihood from robot pose `pose`, a ray cast for every beam (and, where
  /// given, the mean beam probability).
  double LogLikelihood(const SE2d& pose, const ScanBeams& beams, double* mean_probability = nullptr) const;
  /// The range along the ray from `origin` in direction `angle` (world frame) to the first
  /// occupied cell, at most `range_max` (the map's edge counts as no hit).
  double CastRay(const Eigen::Vector2d& origin, double angle, double range_max) const;
  /// One beam's p(z | z*).
  double BeamProbability(double z, double expected, double range_max) const;

 private:
  const OccupancyMap2D* map_;
  BeamModelOptions options_;
};

}  // namespace localization
}  // namespace tether
