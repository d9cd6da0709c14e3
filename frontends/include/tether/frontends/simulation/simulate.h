#pragma once
// Simulate: synthetic SLAM problems with known ground truth, for demos, tests and benchmarks.
//
// Three worlds:
// | world     | variables                    | factors                                        |
// |-----------|------------------------------|------------------------------------------------|
// | manhattan | SE2 poses 0..N-1             | BetweenSE2 odometry, BetweenSE2 loop closures  |
// | sphere    | SE3 poses 0..N-1             | BetweenSE3 odometry, BetweenSE3 loop closures  |
// | landmarks | SE2 poses 0..N-1, Point2 N.. | BetweenSE2 odometry, PosePoint2 observations   |
//
// - manhattan (like the M3500 data set): a walk on a unit grid inside a square of about
//   sqrt(N) x sqrt(N) cells; each step turns by +-90 degrees at random (or when the square's
//   edge is ahead) and moves one metre. Each earlier pose (other than the previous one) that
//   lies within one metre of the current true position is, with loop_closure_probability, the
//   other end of a loop closure.
// - sphere (like sphere2500): a climbing helix on a sphere, about sqrt(N) poses per ring,
//   x axis along the direction of travel, z axis pointing out of the sphere. Each of the three
//   poses of the previous ring nearest in longitude is, with loop_closure_probability, the
//   other end of a loop closure.
// - landmarks: laps of a 2k x k metre rectangle (k grows with N up to 15) in one metre steps,
//   and `landmarks` points scattered within 0.9 * landmark_range of random poses of the
//   trajectory. Each pose observes every landmark within landmark_range.
//
// Measurements are the true relative quantities perturbed by Gaussian noise, and their
// information matrices are exactly the inverse of the noise covariance in the factor's error
// coordinates, so graph.Chi2(ground_truth) follows a chi-square distribution with as many
// degrees of freedom as the graph has residual dimensions:
// - SE2: Z = T_rel * Noise with Noise = (nx, ny, ntheta), n ~ N(0, diag(st^2, st^2, sr^2));
//   information diag(1/st^2, 1/st^2, 1/sr^2).
// - SE3: Z = T_rel * Noise with Noise = (Exp(w), t), t ~ N(0, st^2 I), w ~ N(0, sr^2 I) a
//   rotation vector in radians. BetweenSE3's rotation error is the quaternion's vector part,
//   about w / 2, so the information is diag(1/st^2 (x3), 4/sr^2 (x3)).
// - PosePoint2: z = R^T (l - t) + n, n ~ N(0, st^2 I); information I / st^2.
//
// `initial` composes the odometry measurements from pose 0 (which equals its ground truth);
// each landmark starts where its first observation (in pose order) puts it. No variable is
// fixed: the solver chooses the gauge.
//
// Determinism: the same options give the same graph on every platform, up to the last bits
// of floating-point results. Random numbers come from std::mt19937_64 (whose sequence the C++
// standard specifies) with hand-written uniform, integer and Box-Muller normal sampling (the
// standard distributions differ between library implementations). The manhattan grid walk and
// the loop-closure choices use exact arithmetic only; noise, landmark positions and the
// sphere's poses also go through std::log, sin and cos, whose rounding a C library (or a
// compiler fusing multiply-adds) may change in the last bit. The trajectory and landmarks come
// from one random stream and the noise from another, so changing a sigma changes the
// measurements but not the world or the graph's structure.
#include <cstdint>
#include <string>

#include "tether/core/enum_names.h"
#include "tether/core/factor_graph.h"
#include "tether/core/values.h"

namespace tether {

enum class SimWorld { kManhattan, kSphere, kLandmarks };

inline constexpr EnumName<SimWorld> kSimWorldNames[] = {
    {SimWorld::kManhattan, "manhattan"}, {SimWorld::kSphere, "sphere"}, {SimWorld::kLandmarks, "landmarks"}};
constexpr const auto& EnumNames(SimWorld) { return kSimWorldNames; }

struct SimulateOptions {
  SimWorld world = SimWorld::kManhattan;
  /// Number of poses, keys 0..poses-1 (at least 1).
  int poses = 500;
  /// Seed of the random streams; the same seed gives the same graph everywhere.
  std::uint64_t seed = 1;
  /// Standard deviation of each translation component of the noise, in metres, in [1e-9, 1e6].
  double translation_sigma = 0.05;
  /// Standard deviation of each rotation component of the noise, in radians, in [1e-9, 0.5]
  /// (larger noise makes wrapped angle errors far from Gaussian).
  double rotation_sigma = 0.01;
  /// Probability that each loop-closure candidate becomes a factor (manhattan, sphere), in [0, 1].
  double loop_closure_probability = 0.3;
  /// Number of landmarks (landmarks world only, at least 1), keys poses..poses+landmarks-1.
  int landmarks = 100;
  /// Sensor range in metres (landmarks world only, in [1e-3, 1e6]).
  double landmark_range = 4.0;

  /// True when the options can be simulated; otherwise says why (when `why` is not null).
  bool IsValid(std::string* why) const;
};

struct SimulatedGraph {
  Values ground_truth;  ///< true poses (keys 0..N-1) and landmarks (keys N..)
  Values initial;       ///< odometry composed from pose 0; landmarks from their first observation
  FactorGraph graph;    ///< odometry, then per pose its loop closures or observations
  int odometry_factors = 0;
  int loop_closures = 0;
  int observations = 0;  ///< landmark observations (PosePoint2 factors)
};

/// Simulates a problem. Throws InvalidArgument (with IsValid's reason) for invalid options.
SimulatedGraph Simulate(const SimulateOptions& options);

}  // namespace tether
