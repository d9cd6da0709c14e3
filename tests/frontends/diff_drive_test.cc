// The two-wheel motion model, its Jacobians, the covariance of accumulated odometry and the
// odometry front-end fed to the incremental smoother.
#include "tether/frontends/odometry/diff_drive.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <functional>
#include <vector>

#include "testing/numeric_jacobian.h"
#include "tether/core/error.h"
#include "tether/factors/between_se2.h"
#include "tether/frontends/odometry/odometry_front_end.h"
#include "tether/frontends/odometry/odometry_run.h"
#include "tether/solvers/incremental_smoother.h"

namespace tether {
namespace odometry {
namespace {

constexpr double kPi = 3.14159265358979323846;

Eigen::Vector3d Params(const SE2d& p) { return Eigen::Vector3d(p.x(), p.y(), p.theta()); }

// The closed form (w != 0).
Eigen::Vector3d ClosedForm(const Eigen::Vector3d& x, double v, double w, double dt) {
  const double r = v / w;
  return Eigen::Vector3d(x.x() - r * std::sin(x.z()) + r * std::sin(x.z() + w * dt),
                         x.y() + r * std::cos(x.z()) - r * std::cos(x.z() + w * dt), x.z() + w * dt);
}

using testing::NumericJacobian;

TEST(DiffDriveTest, ArcMatchesTheClosedForm) {
  for (double w : {0.3, -1.7, kPi / 10, 2.5}) {
    for (double theta : {0.0, 1.0, -2.9, 3.1}) {
      const Eigen::Vector3d x(1.5, -2.0, theta);
      const SE2d moved = Move(SE2d(x.x(), x.y(), x.z()), Control{0.8, w}, 1.3);
      const Eigen::Vector3d expect = ClosedForm(x, 0.8, w, 1.3);
      EXPECT_NEAR(moved.x(), expect.x(), 1e-12) << "w " << w << " theta " << theta;
      EXPECT_NEAR(moved.y(), expect.y(), 1e-12);
      EXPECT_NEAR(WrapAngle(moved.theta() - expect.z()), 0.0, 1e-12);
    }
  }
}

TEST(DiffDriveTest, StraightLineIsTheSmoothLimit) {
  const SE2d start(1, 2, 0.7);
  const SE2d straight = Move(start, Control{2.0, 0.0}, 0.5);
  EXPECT_DOUBLE_EQ(straight.x(), 1 + 1.0 * std::cos(0.7));
  EXPECT_DOUBLE_EQ(straight.y(), 2 + 1.0 * std::sin(0.7));
  EXPECT_DOUBLE_EQ(straight.theta(), 0.7);
  const SE2d tiny = Move(start, Control{2.0, 1e-12}, 0.5);
  EXPECT_TRUE(Params(tiny).allFinite());
  // The arc bends off the line by v dt a / 2 = 2.5e-13 m (a = w dt): no more.
  EXPECT_NEAR(tiny.x(), straight.x(), 1e-12);
  EXPECT_NEAR(tiny.y(), straight.y(), 1e-12);
  EXPECT_NEAR(tiny.theta(), 0.7, 1e-12);
  // Across the series' threshold (a = 1e-3) the two branches agree to rounding.
  for (double a : {1e-3 * (1 - 1e-12), 1e-3 * (1 + 1e-12)}) {
    const Eigen::Vector3d d = RelativeMotion(Control{1.0, a}, 1.0);
    EXPECT_NEAR(d.x(), std::sin(1e-3) / 1e-3, 1e-13);
    EXPECT_NEAR(d.y(), (1 - std::cos(1e-3)) / 1e-3, 1e-13);
  }
}

TEST(DiffDriveTest, JacobiansMatchNumericOnesAlsoAtZeroTurnRate) {
  for (double w : {0.0, 1e-12, 9.99e-4, 1.01e-3, 0.4, -2.0}) {
    const Eigen::Vector3d x(0.3, -0.2, 2.8);
    const double v = 1.2, dt = 0.9;
    Eigen::Matrix3d a;
    Eigen::Matrix<double, 3, 2> b;
    Move(SE2d(x.x(), x.y(), x.z()), Control{v, w}, dt, &a, &b);
    const auto by_pose = [&](const Eigen::VectorXd& p) {
      return Eigen::VectorXd(Params(Move(SE2d(p[0], p[1], p[2]), Control{v, w}, dt)));
    };
    const auto by_control = [&](const Eigen::VectorXd& u) {
      return Eigen::VectorXd(Params(Move(SE2d(x.x(), x.y(), x.z()), Control{u[0], u[1]}, dt)));
    };
    EXPECT_LT((a - NumericJacobian(by_pose, x, 2)).cwiseAbs().maxCoeff(), 1e-8) << "w " << w;
    EXPECT_LT((b - NumericJacobian(by_control, Eigen::Vector2d(v, w), 2)).cwiseAbs().maxCoeff(), 1e-8) << "w " << w;
    Eigen::Matrix<double, 3, 2> g;
    RelativeMotion(Control{v, w}, dt, &g);
    const auto rel = [&](const Eigen::VectorXd& u) { return Eigen::VectorXd(RelativeMotion(Control{u[0], u[1]}, dt)); };
    EXPECT_LT((g - NumericJacobian(rel, Eigen::Vector2d(v, w), -1)).cwiseAbs().maxCoeff(), 1e-8) << "w " << w;
  }
}

TEST(DiffDriveTest, WheelSpeedsTicksAndTheirNoise) {
  const Control c = FromWheelSpeeds(0.9, 1.1, 0.5);
  EXPECT_DOUBLE_EQ(c.v, 1.0);
  EXPECT_DOUBLE_EQ(c.w, 0.4);
  const Control t = FromTicks(900, 1100, 0.001, 0.5, 1.0);
  EXPECT_NEAR(t.v, 1.0, 1e-15);
  EXPECT_NEAR(t.w, 0.4, 1e-15);
  const Eigen::Matrix2d s = ControlCovarianceFromWheels(0.1, 0.1, 0.5);
  EXPECT_NEAR(s(0, 0), 0.01 / 2, 1e-15);
  EXPECT_NEAR(s(1, 1), 2 * 0.01 / 0.25, 1e-15);
  EXPECT_NEAR(s(0, 1), 0.0, 1e-15);
  EXPECT_THROW(FromWheelSpeeds(1, 1, 0), InvalidArgument);
  EXPECT_THROW(FromTicks(1, 1, 0.001, 0.5, 0), InvalidArgument);
  EXPECT_THROW(FromTicks(1, 1, -1, 0.5, 1), InvalidArgument);
}

// The accumulated covariance equals the covariance of the composed relative pose linearised
// with respect to all the controls at once (an independent computation).
TEST(DiffDriveTest, AccumulatedCovarianceIsTheLinearisedOneOfAllControls) {
  OdometryNoise noise;
  noise.control << 0.02, 0.001, 0.001, 0.01;
  MotionIntegrator integrator(noise);
  const std::vector<Control> us{{1.0, 0.3}, {0.5, -0.2}, {1.2, 0.0}, {0.8, 1.0}};
  const double dt = 0.7;
  for (const Control& u : us) integrator.Add(u, dt);
  EXPECT_EQ(integrator.steps(), 4);
  const auto composed = [&](const Eigen::VectorXd& all) {
    SE2d p;
    for (std::size_t k = 0; k < us.size(); ++k) p = Move(p, Control{all[2 * k], all[2 * k + 1]}, dt);
    return Eigen::VectorXd(Params(p));
  };
  Eigen::VectorXd all(8);
  Eigen::MatrixXd sigma = Eigen::MatrixXd::Zero(8, 8);
  for (std::size_t k = 0; k < us.size(); ++k) {
    all[2 * k] = us[k].v;
    all[2 * k + 1] = us[k].w;
    sigma.block<2, 2>(2 * k, 2 * k) = noise.control;
  }
  const Eigen::MatrixXd j = NumericJacobian(composed, all, 2);
  const Eigen::Matrix3d expect = j * sigma * j.transpose();
  EXPECT_LT((integrator.covariance() - expect).cwiseAbs().maxCoeff(), 1e-8);
  EXPECT_LT((Params(integrator.relative()) - composed(all)).cwiseAbs().maxCoeff(), 1e-14);
  // One step has rank 2: the floor makes the information finite and is its only addition.
  MotionIntegrator one(noise);
  one.Add(us[0], dt);
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(one.covariance());
  EXPECT_LT(std::abs(eig.eigenvalues()[0]), 1e-15);
  // The information is that of BetweenSE2's error: with pose i at the origin, the error as a
  // function of pose j's parameters has Jacobian J_e at the measurement, and the error's
  // covariance is J_e (C + floor^2 I) J_e^T.
  const Eigen::Matrix3d with_floor = one.covariance() + 0.03 * 0.03 * Eigen::Matrix3d::Identity();
  const BetweenSE2 factor(0, 1, one.relative(), SqrtInformation::Identity(3));
  const auto error = [&](const Eigen::VectorXd& pj) {
    const double pi[3] = {0, 0, 0};
    const double* params[2] = {pi, pj.data()};
    Eigen::Vector3d e;
    factor.Evaluate(params, e.data(), nullptr);
    return Eigen::VectorXd(e);
  };
  const Eigen::MatrixXd je = NumericJacobian(error, Params(one.relative()), 2);
  const Eigen::Matrix3d expect_info = (je * with_floor * je.transpose()).inverse();
  EXPECT_LT((one.Information() - expect_info).cwiseAbs().maxCoeff(), 1e-6 * expect_info.cwiseAbs().maxCoeff());
  // ... which is not the inverse of the parameters' covariance where the motion turns.
  EXPECT_GT((one.Information() - with_floor.inverse()).cwiseAbs().maxCoeff(), 1e-3 * expect_info.cwiseAbs().maxCoeff());
  EXPECT_THROW(one.Add(Control{1, 0}, 0), InvalidArgument);
  EXPECT_THROW(one.Add(Control{std::nan(""), 0}, 1), InvalidArgument);
  OdometryNoise bad;
  bad.floor_sigma = 0;
  EXPECT_THROW(MotionIntegrator{bad}, InvalidArgument);
}

TEST(OdometryFrontEndTest, EmitsPosesAndFactorsTheSmootherTakes) {
  OdometryFrontEndOptions o;
  o.controls_per_pose = 3;
  o.start = SE2d(1, 1, 0.5);
  OdometryFrontEnd odo(o);
  IncrementalSmoother smoother;
  int poses = 0;
  std::vector<FactorId> handles;
  for (int k = 0; k < 30; ++k) {
    const Control u = FromWheelSpeeds(0.9 + 0.01 * k, 1.0, 0.5);
    if (!odo.Add(u, 0.2)) continue;
    ++poses;
    FactorGraph f;
    Values v;
    odo.TakeNew(&f, &v);
    EXPECT_EQ(f.size(), poses == 1 ? 2u : 1u);  // the first also carries the start's prior
    const SmootherUpdate s = smoother.Update(std::move(f), std::move(v));
    EXPECT_TRUE(s.solved);
  }
  EXPECT_EQ(poses, 10);
  ASSERT_EQ(odo.trajectory().size(), 11u);
  // Odometry alone: the estimate is the dead-reckoned trajectory.
  for (int i = 0; i <= 10; ++i) {
    const SE2d e = smoother.Estimate().At<SE2d>(odo.PoseKey(i));
    EXPECT_NEAR(e.x(), odo.trajectory()[static_cast<std::size_t>(i)].x(), 1e-9);
    EXPECT_NEAR(e.y(), odo.trajectory()[static_cast<std::size_t>(i)].y(), 1e-9);
  }
  // Each factor's measurement is three controls composed.
  SE2d p;
  for (int k = 3; k < 6; ++k) p = Move(p, FromWheelSpeeds(0.9 + 0.01 * k, 1.0, 0.5), 0.2);
  const auto& between = dynamic_cast<const BetweenSE2&>(smoother.graph().at(2));
  EXPECT_NEAR(between.Measurement()[0], p.x(), 1e-14);
  EXPECT_NEAR(between.Measurement()[2], p.theta(), 1e-14);
  OdometryFrontEndOptions bad;
  bad.controls_per_pose = 0;
  EXPECT_THROW(OdometryFrontEnd{bad}, InvalidArgument);
}

// The arc's control carries the robot exactly to a pose an arc reaches, forwards and
// backwards, turning either way and going straight.
TEST(OdometryRunTest, TheArcsControlReachesTheNextPose) {
  const SE2d start(2, -1, 0.7);
  for (const Control u : {Control{0.8, 0.3}, Control{-0.5, 0.2}, Control{1.2, -1.5}, Control{0.4, 0.0},
                          Control{-0.3, 0.0}, Control{0.0, 0.9}}) {
    for (double dt : {0.05, 0.5, 2.0}) {
      const SE2d end = Move(start, u, dt);
      const Control back = ControlBetween(start, end, dt);
      EXPECT_NEAR(back.v, u.v, 1e-9) << u.v << " " << u.w << " " << dt;
      EXPECT_NEAR(back.w, u.w, 1e-9) << u.v << " " << u.w << " " << dt;
      const SE2d again = Move(start, back, dt);
      EXPECT_NEAR(again.x(), end.x(), 1e-9);
      EXPECT_NEAR(again.y(), end.y(), 1e-9);
    }
  }
  EXPECT_THROW(ControlBetween(start, start, 0), InvalidArgument);
  EXPECT_THROW(ControlBetween(start, start, std::nan("")), InvalidArgument);
}

// A track driven by arcs: the graph's poses are the track's (every third), each factor's
// measurement is what the poses say (chi2 0 at the dead-reckoned values), a stamp that does
// not advance is merged into the next step, and bad tracks are refused by index.
TEST(OdometryRunTest, ATrackBecomesThePoseGraphOfItsPoses) {
  std::vector<double> stamps;
  std::vector<SE2d> poses;
  SE2d p(1, 2, -0.4);
  double t = 10;
  for (int k = 0; k < 61; ++k) {
    stamps.push_back(t);
    poses.push_back(p);
    const Control u{0.5 + 0.01 * k, 0.3 * std::sin(0.2 * k)};
    p = Move(p, u, 0.1);
    t += 0.1;
  }
  stamps.insert(stamps.begin() + 31, stamps[30]);  // a repeated message, stamp not advancing
  poses.insert(poses.begin() + 31, poses[30]);
  OdometryFrontEndOptions o;
  o.controls_per_pose = 3;
  o.letter = '\0';
  const OdometryRunResult r = RunOdometry(stamps, poses, o);
  EXPECT_EQ(r.report.messages, 62);
  EXPECT_EQ(r.report.merged, 1);
  EXPECT_EQ(r.report.steps, 60);
  EXPECT_EQ(r.report.poses, 21);
  EXPECT_EQ(r.report.sideways, 0);
  EXPECT_NEAR(r.report.duration, 6.0, 1e-9);
  ASSERT_EQ(r.trajectory.size(), 21u);
  ASSERT_EQ(r.stamps.size(), 21u);
  for (int i = 0; i < 21; ++i) {
    const std::size_t k = static_cast<std::size_t>(3 * i + (i > 10 ? 1 : 0));  // the merged message shifts them
    EXPECT_NEAR(r.trajectory[static_cast<std::size_t>(i)].x(), poses[k].x(), 1e-9) << i;
    EXPECT_NEAR(r.trajectory[static_cast<std::size_t>(i)].theta(), poses[k].theta(), 1e-9) << i;
    EXPECT_DOUBLE_EQ(r.stamps[static_cast<std::size_t>(i)], stamps[k]) << i;
    EXPECT_TRUE(r.values.Has(Key(i)));
  }
  EXPECT_EQ(r.graph.size(), 21u);  // the prior and 20 BetweenSE2
  EXPECT_NEAR(r.graph.Chi2(r.values), 0.0, 1e-12);
  double driven = 0;
  for (int k = 0; k < 60; ++k) driven += 0.1 * (0.5 + 0.01 * k);
  EXPECT_NEAR(r.report.distance, driven, 1e-9);
  EXPECT_NE(r.report.Summary().find("1 stamps that did not advance merged"), std::string::npos);

  // A step with a sideways part (no arc has one) is kept as measured and counted.
  std::vector<SE2d> slipping = poses;
  for (std::size_t k = 40; k < slipping.size(); ++k) slipping[k] = slipping[k] * SE2d(0.0, 0.05, 0.0);
  const OdometryRunResult slip = RunOdometry(stamps, slipping, o);
  EXPECT_EQ(slip.report.sideways, 1);
  EXPECT_NEAR(slip.graph.Chi2(slip.values), 0.0, 1e-12);
  EXPECT_NEAR(slip.trajectory.back().y(), slipping.back().y(), 1e-9);
  EXPECT_NE(slip.report.Summary().find("1 steps moved sideways"), std::string::npos) << slip.report.Summary();

  std::vector<double> back = stamps;
  back[5] = 0;
  EXPECT_THROW(RunOdometry(back, poses, o), InvalidArgument);
  std::vector<SE2d> nan = poses;
  nan[7] = SE2d(std::nan(""), 0, 0);
  try {
    RunOdometry(stamps, nan, o);
    ADD_FAILURE() << "a NaN pose was taken";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("pose 7"), std::string::npos) << e.what();
  }
  // Steps after the last full pose make one more: the graph ends at the track's last pose.
  OdometryFrontEndOptions seven = o;
  seven.controls_per_pose = 7;
  const OdometryRunResult tail = RunOdometry(stamps, poses, seven);
  EXPECT_EQ(tail.report.poses, 10);  // 60 steps: 8 poses of 7, one of 4, and the start
  EXPECT_NEAR(tail.trajectory.back().x(), poses.back().x(), 1e-9);
  EXPECT_DOUBLE_EQ(tail.stamps.back(), stamps.back());
  EXPECT_NEAR(tail.graph.Chi2(tail.values), 0.0, 1e-12);
  EXPECT_THROW(RunOdometry({1.0, 1.0, 1.0}, {SE2d(), SE2d(1, 0, 0), SE2d(2, 0, 0)}, o), InvalidArgument);
  EXPECT_THROW(RunOdometry({1.0}, {SE2d()}, o), InvalidArgument);
  EXPECT_THROW(RunOdometry({1.0, 2.0}, {SE2d()}, o), InvalidArgument);
  o.controls_per_pose = 0;
  EXPECT_THROW(RunOdometry(stamps, poses, o), InvalidArgument);
}

}  // namespace
}  // namespace odometry
}  // namespace tether
