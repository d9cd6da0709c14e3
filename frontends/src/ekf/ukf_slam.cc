#include "tether/frontends/ekf/ukf_slam.h"

#include "innovation.h"

namespace tether {
namespace ekf {

namespace {

// [mean; 0] and diag(cov, noise).
void Augment(const Eigen::VectorXd& mean, const Eigen::MatrixXd& cov, const Eigen::Matrix2d& noise, Eigen::VectorXd* am,
             Eigen::MatrixXd* ac) {
  const Eigen::Index n = mean.size();
  am->setZero(n + 2);
  am->head(n) = mean;
  ac->setZero(n + 2, n + 2);
  ac->topLeftCorner(n, n) = cov;
  ac->bottomRightCorner<2, 2>() = noise;
}

SE2d PoseOf(const Eigen::VectorXd& x) { return SE2d(x[0], x[1], x[2]); }

}  // namespace

void UkfSlam::PredictChecked(const odometry::Control& u, double dt) {
  const Eigen::Index n = mean_.size();
  Eigen::VectorXd am;
  Eigen::MatrixXd ac;
  Augment(mean_, cov_, options_.control_cov, &am, &ac);
  const Function f = [&](const Eigen::VectorXd& x) {
    Eigen::VectorXd y = x.head(n);
    const odometry::Control noisy{u.v + x[n], u.w + x[n + 1]};
    const SE2d moved = odometry::Move(PoseOf(x), noisy, dt);
    y.head<3>() << moved.x(), moved.y(), moved.theta();
    return y;
  };
  Transformed t = UnscentedTransform(am, ac, f, options_.unscented, AngleDifference(2), AngleDifference(2));
  mean_ = std::move(t.mean);
  cov_ = std::move(t.cov);
  Tidy();
}

void UkfSlam::Correct(int i, const Eigen::Vector2d& z) {
  const Eigen::Index li = 3 + 2 * i;
  const Function h = [li](const Eigen::VectorXd& x) { return Eigen::VectorXd(Observe(PoseOf(x), x.segment<2>(li))); };
  UnscentedUpdate(&mean_, &cov_, h, z, options_.measurement_cov, options_.unscented, AngleDifference(2),
                  AngleDifference(1));
}

void UkfSlam::AddLandmark(const Eigen::Vector2d& z) {
  const Eigen::Index n = mean_.size();
  Eigen::VectorXd am;
  Eigen::MatrixXd ac;
  Augment(mean_, cov_, options_.measurement_cov, &am, &ac);
  const Function f = [&](const Eigen::VectorXd& x) {
    Eigen::VectorXd y(n + 2);
    y.head(n) = x.head(n);
    y.tail<2>() = InverseObserve(PoseOf(x), z + x.tail<2>());
    return y;
  };
  Transformed t = UnscentedTransform(am, ac, f, options_.unscented, AngleDifference(2), AngleDifference(2));
  mean_ = std::move(t.mean);
  cov_ = std::move(t.cov);
}

std::vector<double> UkfSlam::Distances(const Eigen::Vector2d& z) const {
  const int m = landmark_count();
  std::vector<double> d(static_cast<std::size_t>(m));
  if (m == 0) return d;
  const Function h = [m](const Eigen::VectorXd& x) {
    Eigen::VectorXd y(2 * m);
    for (int i = 0; i < m; ++i) y.segment<2>(2 * i) = Observe(PoseOf(x), x.segment<2>(3 + 2 * i));
    return y;
  };
  const Difference bearings = [](const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
    Eigen::VectorXd r = a - b;
    for (Eigen::Index k = 1; k < r.size(); k += 2) r[k] = WrapAngle(r[k]);
    return r;
  };
  const Transformed t = UnscentedTransform(mean_, cov_, h, options_.unscented, AngleDifference(2), bearings);
  for (int i = 0; i < m; ++i) {
    const Eigen::Matrix2d s = t.cov.block<2, 2>(2 * i, 2 * i) + options_.measurement_cov;
    const Eigen::Vector2d nu = MeasurementDifference(z, t.mean.segment<2>(2 * i));
    d[static_cast<std::size_t>(i)] = SquaredMahalanobis(nu, s);
  }
  return d;
}

}  // namespace ekf
}  // namespace tether
