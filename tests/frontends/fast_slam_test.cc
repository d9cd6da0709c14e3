// FastSLAM 1.0 and 2.0 on point landmarks (frontends/ekf/fast_slam.h), and the particle weights'
// helpers they share with Monte Carlo localisation (frontends/localization/resampling.h).
#include "tether/frontends/ekf/fast_slam.h"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <cmath>
#include <random>
#include <vector>

#include "tether/core/error.h"
#include "tether/frontends/ekf/consistency.h"
#include "tether/frontends/ekf/ekf_slam.h"
#include "tether/frontends/localization/resampling.h"

namespace tether {
namespace ekf {
namespace {

// The FastSLAM 2.0 proposal on a linear-Gaussian case: observations z_k = Hx_k x + Hl_k l_k + v_k
// of independent landmarks l_k ~ N(m_k, P_k), v_k ~ N(0, R), pose x ~ N(mu, Sigma). Conditioning
// on them one after the other (ConditionPose, with the landmark's part H_l P H_l^T + R as the
// noise) must give the closed form of conditioning on all at once, and the summed
// log-likelihoods must be the stacked observation's.
TEST(FastSlamProposalTest, SequentialEqualsTheClosedFormOnALinearGaussianCase) {
  std::mt19937 rng(3);
  std::normal_distribution<double> g;
  const auto random_matrix = [&](int r, int c) {
    Eigen::MatrixXd m(r, c);
    for (int i = 0; i < r; ++i)
      for (int j = 0; j < c; ++j) m(i, j) = g(rng);
    return m;
  };
  const auto random_spd = [&](int n, double floor) {
    const Eigen::MatrixXd a = random_matrix(n, n);
    return Eigen::MatrixXd(a * a.transpose() + floor * Eigen::MatrixXd::Identity(n, n));
  };
  const int k = 3;
  PoseBelief belief;
  belief.mean = Eigen::Vector3d(0.3, -1.0, 0.2);
  belief.cov = random_spd(3, 0.1);
  const Eigen::Matrix2d r = random_spd(2, 0.05);
  Eigen::MatrixXd hx(2 * k, 3), noise = Eigen::MatrixXd::Zero(2 * k, 2 * k);
  Eigen::VectorXd nu(2 * k);  // z - (Hx mu + Hl m): the innovation at the prior mean
  std::vector<Eigen::Matrix<double, 2, 3>> hxs;
  std::vector<Eigen::Matrix2d> rests;
  for (int i = 0; i < k; ++i) {
    const Eigen::Matrix<double, 2, 3> h = random_matrix(2, 3);
    const Eigen::Matrix2d hl = random_matrix(2, 2);
    const Eigen::Matrix2d p = random_spd(2, 0.1);
    hxs.push_back(h);
    rests.push_back(hl * p * hl.transpose() + r);
    hx.middleRows(2 * i, 2) = h;
    noise.block(2 * i, 2 * i, 2, 2) = rests.back();
    nu[2 * i] = g(rng);
    nu[2 * i + 1] = g(rng);
  }
  // Closed form.
  const Eigen::MatrixXd s = hx * belief.cov * hx.transpose() + noise;
  const Eigen::LLT<Eigen::MatrixXd> llt(s);
  const Eigen::MatrixXd gain = llt.solve(hx * belief.cov).transpose();
  const Eigen::Vector3d mean = belief.mean + gain * nu;
  const Eigen::Matrix3d cov = belief.cov - gain * s * gain.transpose();
  const Eigen::MatrixXd l = llt.matrixL();
  const double log_likelihood =
      -0.5 * nu.dot(llt.solve(nu)) - k * std::log(2 * M_PI) - l.diagonal().array().log().sum();
  // One after the other: each innovation is taken at the current mean (linear: shift by Hx dx).
  double summed = 0;
  PoseBelief b = belief;
  for (int i = 0; i < k; ++i) {
    const Eigen::Vector2d nu_i = nu.segment(2 * i, 2) - hxs[static_cast<std::size_t>(i)] * (b.mean - belief.mean);
    summed += ConditionPose(&b, nu_i, hxs[static_cast<std::size_t>(i)], rests[static_cast<std::size_t>(i)]);
  }
  // theta is wrapped by ConditionPose; here it stays within (-pi, pi].
  EXPECT_LT((b.mean - mean).cwiseAbs().maxCoeff(), 1e-10);
  EXPECT_LT((b.cov - cov).cwiseAbs().maxCoeff(), 1e-10);
  EXPECT_NEAR(summed, log_likelihood, 1e-9);
  // An innovation covariance that is not positive definite changes nothing.
  PoseBelief same = belief;
  EXPECT_TRUE(std::isnan(
      ConditionPose(&same, Eigen::Vector2d(1, 1), Eigen::Matrix<double, 2, 3>::Zero(), -Eigen::Matrix2d::Identity())));
  EXPECT_EQ(same.mean, belief.mean);
}

TEST(ParticleWeightsTest, EffectiveSampleSizeAndLogWeights) {
  EXPECT_DOUBLE_EQ(EffectiveSampleSize({0.25, 0.25, 0.25, 0.25}), 4.0);
  EXPECT_DOUBLE_EQ(EffectiveSampleSize({1.0, 0.0, 0.0}), 1.0);
  EXPECT_DOUBLE_EQ(EffectiveSampleSize({0.5, 0.5, 0.0, 0.0}), 2.0);
  EXPECT_DOUBLE_EQ(EffectiveSampleSize({}), 0.0);
  // Logs far below what exp() can hold still give their ratios.
  const std::vector<double> w = NormalizedFromLogs({-2000.0, -2000.0 + std::log(3.0)});
  EXPECT_NEAR(w[0], 0.25, 1e-12);
  EXPECT_NEAR(w[1], 0.75, 1e-12);
  const std::vector<double> none = NormalizedFromLogs({-INFINITY, -INFINITY});
  EXPECT_EQ(none, (std::vector<double>{0.5, 0.5}));
}

// A particle set whose weight one particle holds has a singular covariance: its NEES is infinite
// where the estimate is wrong (not a number of the solver's rounding), 0 where it is right.
TEST(ParticleWeightsTest, NeesOfASingularCovariance) {
  const Eigen::Matrix3d flat = Eigen::Vector3d(1, 1, 0).asDiagonal();
  EXPECT_TRUE(std::isinf(Nees(SE2d(0, 0, 0.1), flat, SE2d())));
  EXPECT_EQ(Nees(SE2d(), flat, SE2d()), 0.0);
  EXPECT_TRUE(std::isinf(TangentNees(SE2d(0, 0, 0.1), Eigen::Matrix3d::Zero(), SE2d())));
  EXPECT_NEAR(Nees(SE2d(1, 0, 0), Eigen::Matrix3d::Identity() * 4, SE2d()), 0.25, 1e-15);
  // Positive definite in name only: FastSLAM 1.0's 10 particles on one world (seed 1020, step 193,
  // one particle holding the weight) gave this; solving with it overflowed to NaN.
  Eigen::Matrix3d tiny;
  tiny << 1.0997980531702735e-294, 2.1891526241369886e-294, -3.2977105435051036e-294, 2.1891526241369886e-294,
      4.3575174532736636e-294, -6.5641066277107859e-294, -3.2977105435051036e-294, -6.5641066277107859e-294,
      9.8880833598466525e-294;
  const double nees = Nees(SE2d(0.82300412746024865, 6.3904798760110806, -2.554928834634941), tiny,
                           SE2d(-2.5751810740024106, 5.0540774294151847, -2.1991148575128552));
  EXPECT_FALSE(std::isnan(nees));
  EXPECT_GT(nees, 1e100);
}

LandmarkWorld World(std::uint64_t seed, double noise_scale, int steps = 200) {
  LandmarkWorldOptions o;
  o.seed = seed;
  o.steps = steps;
  o.measurement_sigma *= noise_scale;
  o.control_sigma *= noise_scale;
  return SimulateLandmarkWorld(o);
}

FastSlamOptions Options(FastSlamVersion v, int particles, double noise_scale, std::uint64_t seed = 1) {
  FastSlamOptions o;
  o.version = v;
  o.particles = particles;
  o.seed = seed;
  const LandmarkWorldOptions w;
  o.filter.control_cov = (noise_scale * w.control_sigma).cwiseAbs2().asDiagonal();
  o.filter.measurement_cov = (noise_scale * w.measurement_sigma).cwiseAbs2().asDiagonal();
  return o;
}

Track RunWith(const FastSlamOptions& o, const LandmarkWorld& world) {
  FastSlam f(SE2d(), Eigen::Matrix3d::Zero(), o);
  return RunFastSlam(&f, world);
}

// Resampling happens only where the effective sample size falls below the share asked for:
// never at 0, at every step with observations at 1; in between, at some steps and not others.
TEST(FastSlamTest, SelectiveResampling) {
  const LandmarkWorld world = World(4, 1.0, 60);
  for (const double fraction : {0.0, 0.5, 1.0}) {
    FastSlamOptions o = Options(FastSlamVersion::kTwo, 50, 1.0);
    o.resample_fraction = fraction;
    FastSlam f(SE2d(), Eigen::Matrix3d::Zero(), o);
    RunFastSlam(&f, world);
    if (fraction == 0.0) {
      EXPECT_EQ(f.resamplings(), 0);
    } else if (fraction == 1.0) {
      EXPECT_GE(f.resamplings(), 55);  // every Predict after the first (equal weights at the start)
    } else {
      EXPECT_GT(f.resamplings(), 0);
      EXPECT_LT(f.resamplings(), 55);
    }
    const std::vector<double> w = f.weights();
    double sum = 0;
    for (double x : w) sum += x;
    EXPECT_NEAR(sum, 1.0, 1e-12);
    EXPECT_NEAR(f.effective_sample_size(), EffectiveSampleSize(w), 1e-9);
  }
}

// Where the noise is a tenth of the thesis's, both versions follow the truth to within twice the
// EKF's error (over 50 such worlds, 30 particles: 0.096 m each, the EKF 0.075 m).
TEST(FastSlamTest, FollowsTheTruthWhereTheNoiseIsSmall) {
  double one = 0, two = 0, ekf_sum = 0;
  for (std::uint64_t seed = 1; seed <= 4; ++seed) {
    const LandmarkWorld world = World(seed, 0.1, 120);
    one += TrajectoryRmse(RunWith(Options(FastSlamVersion::kOne, 50, 0.1, seed), world).poses, world.truth);
    two += TrajectoryRmse(RunWith(Options(FastSlamVersion::kTwo, 50, 0.1, seed), world).poses, world.truth);
    EkfSlam e(SE2d(), Eigen::Matrix3d::Zero(), Options(FastSlamVersion::kTwo, 1, 0.1).filter);
    ekf_sum += TrajectoryRmse(RunFilter(&e, world).poses, world.truth);
  }
  EXPECT_LT(one / 4, 0.2);
  EXPECT_LT(two / 4, 0.2);
  EXPECT_LT(one, 2.0 * ekf_sum);
  EXPECT_LT(two, 2.0 * ekf_sum);
}

// Known association: the heaviest particle's landmarks are the true ones seen, in the order
// first seen, and each lies near its truth.
TEST(FastSlamTest, KnownAssociationMapsEveryLandmarkSeen) {
  const LandmarkWorld world = World(2, 0.1, 100);
  const Track t = RunWith(Options(FastSlamVersion::kTwo, 30, 0.1), world);
  const Track truth = TruthTrack(world);
  EXPECT_EQ(t.creator_id, truth.creator_id);
  EXPECT_EQ(t.association, truth.association);
  EXPECT_EQ(t.wrong_associations, 0);
  EXPECT_LT(LandmarkRmse(t, world.landmarks), 0.5);
  ASSERT_EQ(t.landmark_cov.size(), t.landmarks.size());
  for (const Eigen::Matrix2d& c : t.landmark_cov) EXPECT_GT(c.determinant(), 0);
}

// Unknown association where the noise allows it: each particle associates by its own
// landmarks, and the heaviest makes (almost) no wrong association, where the EKF at the thesis's
// noise gets most of them wrong.
TEST(FastSlamTest, PerParticleNearestNeighbourWhereTheNoiseAllowsIt) {
  const LandmarkWorld world = World(3, 0.1, 100);
  FastSlamOptions o = Options(FastSlamVersion::kTwo, 30, 0.1);
  o.filter.association = DataAssociation::kNearestNeighbour;
  FastSlam f(SE2d(), Eigen::Matrix3d::Zero(), o);
  const Track t = RunFastSlam(&f, world);
  int observations = 0;
  for (const auto& step : world.observations) observations += static_cast<int>(step.size());
  EXPECT_LE(t.wrong_associations, observations / 100);
  EXPECT_LE(static_cast<int>(t.landmarks.size()), static_cast<int>(world.landmarks.size()) + 2);
  EXPECT_LT(TrajectoryRmse(t.poses, world.truth), 0.3);
  // Different particles may hold different numbers of landmarks; the track is the heaviest's.
  EXPECT_EQ(static_cast<int>(t.landmarks.size()), f.landmark_count(f.best_particle()));
}

TEST(FastSlamTest, TheSameSeedGivesTheSameRunAndAnotherSeedAnother) {
  const LandmarkWorld world = World(5, 1.0, 40);
  for (const FastSlamVersion v : {FastSlamVersion::kOne, FastSlamVersion::kTwo}) {
    const Track a = RunWith(Options(v, 20, 1.0, 7), world);
    const Track b = RunWith(Options(v, 20, 1.0, 7), world);
    const Track c = RunWith(Options(v, 20, 1.0, 8), world);
    ASSERT_EQ(a.poses.size(), b.poses.size());
    bool differs = false;
    for (std::size_t k = 0; k < a.poses.size(); ++k) {
      EXPECT_EQ(a.poses[k].x(), b.poses[k].x());
      EXPECT_EQ(a.poses[k].theta(), b.poses[k].theta());
      differs = differs || a.poses[k].x() != c.poses[k].x();
    }
    EXPECT_EQ(a.landmarks, b.landmarks);
    EXPECT_TRUE(differs);
  }
}

// The estimate is the particles' weighted mean and covariance; the path is the heaviest
// particle's own, one pose per step, and starts at the start.
TEST(FastSlamTest, EstimateAndPath) {
  const LandmarkWorld world = World(6, 1.0, 30);
  FastSlam f(SE2d(1, 2, 0.5), Eigen::Matrix3d::Zero(), Options(FastSlamVersion::kOne, 40, 1.0));
  EXPECT_LT((f.pose().translation() - Eigen::Vector2d(1, 2)).norm(), 1e-12);
  EXPECT_TRUE(f.pose_cov().isZero(1e-15));
  for (std::size_t k = 0; k < world.odometry.size(); ++k) {
    f.Predict(world.odometry[k], world.dt);
    f.Update(world.observations[k]);
  }
  const std::vector<double> w = f.weights();
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (int i = 0; i < f.particle_count(); ++i)
    mean += w[static_cast<std::size_t>(i)] * f.particle_pose(i).translation();
  EXPECT_LT((f.pose().translation() - mean).norm(), 1e-9);
  EXPECT_GT(f.pose_cov().determinant(), 0);
  const std::vector<SE2d> path = f.best_path();
  ASSERT_EQ(path.size(), world.odometry.size() + 1);
  EXPECT_EQ(path.front().x(), 1.0);
  EXPECT_EQ(path.back().x(), f.particle_pose(f.best_particle()).x());
  EXPECT_EQ(f.best_association().size(), world.odometry.size());
}

// A particle's landmark changes are its own: after resampling copies one particle into many,
// their later updates leave each other's landmarks as they were (the landmarks are shared until
// changed, core/persistent_array.h).
TEST(FastSlamTest, ParticlesSharingLandmarksDoNotSeeEachOthersChanges) {
  const LandmarkWorld world = World(8, 1.0, 20);
  FastSlamOptions o = Options(FastSlamVersion::kOne, 8, 1.0);
  o.resample_fraction = 1.0;  // resample at every Predict
  FastSlam f(SE2d(), Eigen::Matrix3d::Zero(), o);
  for (int k = 0; k < 2; ++k) {  // the second step's observations make the weights unequal
    f.Predict(world.odometry[static_cast<std::size_t>(k)], world.dt);
    f.Update(world.observations[static_cast<std::size_t>(k)]);
  }
  ASSERT_GT(f.landmark_count(0), 0);
  ASSERT_LT(f.effective_sample_size(), 8.0);
  f.Predict(world.odometry[2], world.dt);  // resampled: particles copy one another's landmarks
  ASSERT_EQ(f.resamplings(), 1);
  std::vector<Eigen::Vector2d> before;
  int copies = 0;
  for (int i = 0; i < f.particle_count(); ++i) {
    before.push_back(f.landmark(i, 0).mean);
    for (int j = 0; j < i; ++j) copies += before[static_cast<std::size_t>(j)] == before.back() ? 1 : 0;
  }
  ASSERT_GT(copies, 0);
  f.Update(world.observations[2]);  // each particle corrects landmark 0 from its own sampled pose
  int moved_apart = 0;
  for (int i = 0; i < f.particle_count(); ++i) {
    for (int j = i + 1; j < f.particle_count(); ++j) {
      if (before[static_cast<std::size_t>(i)] == before[static_cast<std::size_t>(j)] &&
          f.landmark(i, 0).mean != f.landmark(j, 0).mean) {
        ++moved_apart;
      }
    }
  }
  EXPECT_GT(moved_apart, 0);  // copies of one landmark, corrected apart
}

TEST(FastSlamTest, BadInputIsRefusedAndChangesNothing) {
  FastSlamOptions o;
  o.particles = 0;
  EXPECT_THROW(FastSlam(SE2d(), Eigen::Matrix3d::Zero(), o), InvalidArgument);
  o = FastSlamOptions();
  o.resample_fraction = 1.5;
  EXPECT_THROW(FastSlam(SE2d(), Eigen::Matrix3d::Zero(), o), InvalidArgument);
  o = FastSlamOptions();
  o.motion_floor = -1;
  EXPECT_THROW(FastSlam(SE2d(), Eigen::Matrix3d::Zero(), o), InvalidArgument);
  o = FastSlamOptions();
  EXPECT_THROW(FastSlam(SE2d(), -Eigen::Matrix3d::Identity(), o), InvalidArgument);
  EXPECT_THROW(FastSlam(SE2d(NAN, 0, 0), Eigen::Matrix3d::Zero(), o), InvalidArgument);
  FastSlam f(SE2d(), Eigen::Matrix3d::Zero(), o);
  EXPECT_THROW(f.Predict(odometry::Control{NAN, 0}, 1), InvalidArgument);
  EXPECT_THROW(f.Predict(odometry::Control{1, 0}, 0), InvalidArgument);
  // Known association needs ids; nothing of a refused step is applied.
  EXPECT_THROW(f.Update({Observation{5, 0, 1}, Observation{5, 1, -1}}), InvalidArgument);
  EXPECT_THROW(f.Update({Observation{-1, 0, 1}}), InvalidArgument);
  EXPECT_EQ(f.landmark_count(0), 0);
  EXPECT_EQ(f.pose().x(), 0.0);
  // A control that moves the robot beyond what a double holds: refused, and the particles, their
  // random stream and the weights are as they were (the next step runs as it would have).
  FastSlamOptions o1;
  o1.version = FastSlamVersion::kOne;
  o1.particles = 5;
  FastSlam a(SE2d(), Eigen::Matrix3d::Zero(), o1), b(SE2d(), Eigen::Matrix3d::Zero(), o1);
  EXPECT_THROW(a.Predict(odometry::Control{1e308, 1e308}, 1e308), InvalidArgument);
  for (int i = 0; i < a.particle_count(); ++i) EXPECT_TRUE(a.particle_pose(i).translation().allFinite());
  a.Predict(odometry::Control{1, 0.1}, 1);
  b.Predict(odometry::Control{1, 0.1}, 1);
  for (int i = 0; i < a.particle_count(); ++i) EXPECT_EQ(a.particle_pose(i).x(), b.particle_pose(i).x());
}

}  // namespace
}  // namespace ekf
}  // namespace tether
