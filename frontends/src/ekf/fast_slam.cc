#include "tether/frontends/ekf/fast_slam.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>

#include "tether/core/error.h"
#include "tether/frontends/localization/resampling.h"

namespace tether {
namespace ekf {

namespace {

constexpr double kLog2Pi = 1.8378770664093453;  // log(2 pi)
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr int kMaxParticles = 10000000;

// log N(nu; 0, s) for a 2-vector, through s's Cholesky factor; NaN where s is not positive
// definite. *d2 (optional): nu^T s^-1 nu.
double LogGaussian(const Eigen::Vector2d& nu, const Eigen::Matrix2d& s, double* d2 = nullptr) {
  const Eigen::LLT<Eigen::Matrix2d> llt(s);
  if (llt.info() != Eigen::Success) {
    if (d2 != nullptr) *d2 = kInf;
    return std::nan("");
  }
  const Eigen::Matrix2d l = llt.matrixL();
  const double m = nu.dot(llt.solve(nu));
  if (d2 != nullptr) *d2 = m;
  return -0.5 * m - kLog2Pi - std::log(l(0, 0)) - std::log(l(1, 1));
}

// mean + V sqrt(max(D, 0)) n for cov = V D V^T: a sample where cov may be singular.
template <int N>
Eigen::Matrix<double, N, 1> SampleGaussian(const Eigen::Matrix<double, N, 1>& mean,
                                           const Eigen::Matrix<double, N, N>& cov, RandomStream* random) {
  Eigen::Matrix<double, N, 1> n;
  for (int i = 0; i < N; ++i) n[i] = random->Normal();
  if (cov.isZero(0.0)) return mean;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, N, N>> eig(cov);
  return mean + eig.eigenvectors() * (eig.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal() * n);
}

SE2d PoseOf(const Eigen::Vector3d& v) { return SE2d(v.x(), v.y(), v.z()); }
Eigen::Vector3d VectorOf(const SE2d& p) { return Eigen::Vector3d(p.x(), p.y(), p.theta()); }

bool IsPsd3(const Eigen::Matrix3d& c) {
  if (!c.allFinite() || !c.isApprox(c.transpose(), 1e-12)) return false;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(c, Eigen::EigenvaluesOnly);
  return eig.eigenvalues()[0] >= -1e-12 * std::max(1.0, c.cwiseAbs().maxCoeff());
}

}  // namespace

bool FastSlamOptions::IsValid(std::string* why) const {
  const auto fail = [&](const std::string& w) {
    if (why != nullptr) *why = w;
    return false;
  };
  std::string f;
  if (!filter.IsValid(&f)) return fail(f);
  if (particles < 1 || particles > kMaxParticles) {
    return fail("particles must lie in 1.." + std::to_string(kMaxParticles));
  }
  if (!(resample_fraction >= 0 && resample_fraction <= 1)) return fail("resample_fraction must lie in [0, 1]");
  if (!(std::isfinite(motion_floor) && motion_floor >= 0)) {
    return fail("motion_floor must be finite and not negative");
  }
  if (!std::isfinite(new_landmark_d2))
    return fail("new_landmark_d2 must be finite (negative: the filter's new_landmark)");
  return true;
}

double ConditionPose(PoseBelief* belief, const Eigen::Vector2d& nu, const Eigen::Matrix<double, 2, 3>& hx,
                     const Eigen::Matrix2d& noise) {
  const Eigen::Matrix<double, 3, 2> pht = belief->cov * hx.transpose();
  const Eigen::Matrix2d s = hx * pht + noise;
  const double ll = LogGaussian(nu, s);
  if (std::isnan(ll)) return ll;
  const Eigen::Matrix<double, 3, 2> k = Eigen::LLT<Eigen::Matrix2d>(s).solve(pht.transpose()).transpose();
  belief->mean += k * nu;
  belief->mean.z() = WrapAngle(belief->mean.z());
  belief->cov -= k * s * k.transpose();
  belief->cov = 0.5 * (belief->cov + belief->cov.transpose()).eval();
  return ll;
}

FastSlam::FastSlam(const SE2d& start, const Eigen::Matrix3d& start_cov, const FastSlamOptions& options)
    : options_(options), random_(options.seed, 0x46534c) {
  std::string why;
  if (!options_.IsValid(&why)) throw InvalidArgument("FastSLAM: " + why);
  if (!std::isfinite(start.x()) || !std::isfinite(start.y()) || !std::isfinite(start.theta())) {
    throw InvalidArgument("FastSLAM: the start pose must be finite");
  }
  if (!IsPsd3(start_cov)) {
    throw InvalidArgument("FastSLAM: the start covariance must be symmetric, finite and positive semi-definite");
  }
  const Eigen::Matrix2d& r = options_.filter.measurement_cov;
  const double d2 = options_.new_landmark_d2 >= 0 ? options_.new_landmark_d2 : options_.filter.new_landmark;
  floor2_ = options_.motion_floor * options_.motion_floor;
  log_new_landmark_ = -0.5 * d2 - kLog2Pi - 0.5 * std::log(r.determinant());
  particles_.resize(static_cast<std::size_t>(options_.particles));
  for (Particle& p : particles_) {
    p.belief.mean = SampleGaussian<3>(VectorOf(start), start_cov, &random_);
    p.belief.mean.z() = WrapAngle(p.belief.mean.z());
    p.proposal = p.belief;
    auto first = std::make_shared<Step>();
    first->pose = PoseOf(p.belief.mean);
    p.path = std::move(first);
  }
}

void FastSlam::MaybeResample() {
  // A resampled particle shares its parent's landmarks and path.
  if (SelectiveResample(&particles_, options_.resample_fraction, [this] { return random_.Uniform(); }) >= 0) {
    ++resamplings_;
  }
}

void FastSlam::Predict(const odometry::Control& u, double dt) {
  CheckControl(u, dt, "FastSLAM");
  // A control that moves a particle beyond what a double holds is refused, changing nothing.
  const std::vector<Particle> before = particles_;
  const RandomStream random_before = random_;
  const int resamplings_before = resamplings_;
  PredictChecked(u, dt);
  for (const Particle& p : particles_) {
    if (!p.belief.mean.allFinite() || !p.belief.cov.allFinite()) {
      particles_ = before;
      random_ = random_before;
      resamplings_ = resamplings_before;
      throw InvalidArgument("FastSLAM: the control (v " + std::to_string(u.v) + ", w " + std::to_string(u.w) +
                            ") over dt " + std::to_string(dt) +
                            " moves the robot beyond what can be represented; nothing was applied");
    }
  }
}

void FastSlam::PredictChecked(const odometry::Control& u, double dt) {
  MaybeResample();
  const Eigen::Matrix2d& m = options_.filter.control_cov;
  for (Particle& p : particles_) {
    if (options_.version == FastSlamVersion::kOne) {
      const Eigen::Vector2d noisy = SampleGaussian<2>(Eigen::Vector2d(u.v, u.w), m, &random_);
      p.belief.mean = VectorOf(odometry::Move(PoseOf(p.belief.mean), odometry::Control{noisy.x(), noisy.y()}, dt));
      p.belief.cov.setZero();
    } else {
      Eigen::Matrix3d a;
      Eigen::Matrix<double, 3, 2> b;
      p.belief.mean = VectorOf(odometry::Move(PoseOf(p.belief.mean), u, dt, &a, &b));
      // A second Predict before an Update carries the first one's covariance along.
      const Eigen::Matrix3d q = b * m * b.transpose();
      const double largest = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(q, Eigen::EigenvaluesOnly).eigenvalues()[2];
      p.belief.cov = (p.predicted ? (a * p.belief.cov * a.transpose()).eval() : Eigen::Matrix3d::Zero()) + q +
                     floor2_ * std::max(largest, 0.0) * Eigen::Matrix3d::Identity();
      p.predicted = true;
    }
  }
}

void FastSlam::Sample(Particle* p) {
  p->belief.mean = SampleGaussian<3>(p->belief.mean, p->belief.cov, &random_);
  p->belief.mean.z() = WrapAngle(p->belief.mean.z());
  p->belief.cov.setZero();
  p->predicted = false;
}

std::vector<int> FastSlam::Update(const std::vector<Observation>& observations) {
  CheckObservations(observations, options_.filter.association, "FastSLAM");
  const FilterOptions& fo = options_.filter;
  const Eigen::Matrix2d& r = fo.measurement_cov;
  const bool known = fo.association == DataAssociation::kKnown;
  // Known association: every particle starts the same landmarks in the same order; the ids
  // that start one this step (measured range at least min_range).
  std::vector<int> known_index(observations.size(), -1);
  std::vector<bool> known_new(observations.size(), false);
  if (known) {
    int next = particles_.empty() ? 0 : static_cast<int>(particles_.front().landmarks.size());
    for (std::size_t k = 0; k < observations.size(); ++k) {
      const int id = observations[k].id;
      if (static_cast<std::size_t>(id) < id_to_index_.size() && id_to_index_[static_cast<std::size_t>(id)] >= 0) {
        known_index[k] = id_to_index_[static_cast<std::size_t>(id)];
      } else if (observations[k].range >= fo.min_range) {
        if (static_cast<std::size_t>(id) >= id_to_index_.size())
          id_to_index_.resize(static_cast<std::size_t>(id) + 1, -1);
        id_to_index_[static_cast<std::size_t>(id)] = known_index[k] = next++;
        known_new[k] = true;
      }
    }
  }
  // What a particle does with an observation once the pose is sampled.
  struct Action {
    std::size_t k;
    int landmark;  // -1: none
    bool add;
  };
  for (Particle& p : particles_) {
    auto step = std::make_shared<Step>();
    step->association.assign(observations.size(), -1);
    step->wrong = p.path->wrong;
    step->dropped = p.path->dropped;
    std::vector<Action> actions;
    std::vector<LandmarkGaussian> pending;  // landmarks started this step (indices size + n)
    const int existing = static_cast<int>(p.landmarks.size());
    std::vector<bool> used(static_cast<std::size_t>(existing), false);
    const auto estimate = [&](int j) -> const LandmarkGaussian* {
      return j < existing ? &p.landmarks[static_cast<std::size_t>(j)] : nullptr;  // pending: none yet
    };
    // The innovation of z against landmark l at the belief's mean: nu, the pose Jacobian and
    // the covariance of the rest (landmark + measurement). False where l sits on the pose.
    const auto innovation = [&](const LandmarkGaussian& l, const Eigen::Vector2d& z, Eigen::Vector2d* nu,
                                Eigen::Matrix<double, 2, 3>* hx, Eigen::Matrix2d* rest) {
      Eigen::Matrix2d hl;
      if (!((l.mean - p.belief.mean.head<2>()).squaredNorm() > 0)) return false;
      *nu = MeasurementDifference(z, Observe(PoseOf(p.belief.mean), l.mean, hx, &hl));
      *rest = hl * l.cov * hl.transpose() + r;
      return true;
    };
    for (std::size_t k = 0; k < observations.size(); ++k) {
      const Observation& o = observations[k];
      const Eigen::Vector2d z(o.range, o.bearing);
      int chosen = -1;
      bool add = false, dropped = false;
      if (known) {
        chosen = known_index[k];
        add = known_new[k];
        if (chosen < 0) continue;  // a new landmark too near to start
      } else {
        double best = kInf;
        for (int j = 0; j < existing; ++j) {
          if (used[static_cast<std::size_t>(j)]) continue;
          Eigen::Vector2d nu;
          Eigen::Matrix<double, 2, 3> hx;
          Eigen::Matrix2d rest;
          if (!innovation(p.landmarks[static_cast<std::size_t>(j)], z, &nu, &hx, &rest)) continue;
          double d2 = kInf;
          LogGaussian(nu, hx * p.belief.cov * hx.transpose() + rest, &d2);
          if (d2 < best) {
            best = d2;
            chosen = j;
          }
        }
        if (best >= fo.new_landmark) {
          add = true;
          chosen = existing + static_cast<int>(pending.size());
        } else if (!(best < fo.gate)) {
          chosen = -1;
          dropped = true;
        }
      }
      // Too near to use (as the EKF: a landmark by its estimate, a new one by the measured range).
      const LandmarkGaussian* l = add || chosen < 0 ? nullptr : estimate(chosen);
      if (!dropped &&
          (add ? o.range < fo.min_range : l != nullptr && (l->mean - p.belief.mean.head<2>()).norm() < fo.min_range)) {
        continue;
      }
      if (dropped) {
        p.log_weight += log_new_landmark_;
        ++step->dropped;
        continue;
      }
      if (add) {
        p.log_weight += log_new_landmark_;
        if (known) {
          if (chosen != existing + static_cast<int>(pending.size())) {
            throw InvalidArgument("FastSLAM: internal: the particles' landmarks disagree");
          }
        }
        LandmarkGaussian started;
        started.creator_id = o.id;
        pending.push_back(started);
      } else if (l != nullptr && options_.version == FastSlamVersion::kTwo) {
        // 2.0's proposal and weight (1.0 weighs at the sampled pose, below).
        Eigen::Vector2d nu;
        Eigen::Matrix<double, 2, 3> hx;
        Eigen::Matrix2d rest;
        if (innovation(*l, z, &nu, &hx, &rest)) {
          const double ll = ConditionPose(&p.belief, nu, hx, rest);
          if (!std::isnan(ll)) p.log_weight += ll;
        }
      }
      const int creator = chosen < existing ? estimate(chosen)->creator_id
                                            : pending[static_cast<std::size_t>(chosen - existing)].creator_id;
      if (!add && o.id >= 0 && creator != o.id) ++step->wrong;
      if (chosen < existing) used[static_cast<std::size_t>(chosen)] = true;
      step->association[k] = chosen;
      actions.push_back(Action{k, chosen, add});
    }
    // The pose (2.0: from the proposal, which is kept for the estimate), then the landmarks at it.
    p.proposal = p.belief;
    if (p.predicted || !p.belief.cov.isZero(0.0)) Sample(&p);
    const SE2d pose = PoseOf(p.belief.mean);
    for (const Action& a : actions) {
      const Eigen::Vector2d z(observations[a.k].range, observations[a.k].bearing);
      if (a.add) {
        Eigen::Matrix2d gz;
        LandmarkGaussian l = pending[static_cast<std::size_t>(a.landmark - existing)];
        l.mean = l.first_seen = InverseObserve(pose, z, nullptr, &gz);
        l.cov = gz * r * gz.transpose();
        p.landmarks.PushBack(l);
        continue;
      }
      LandmarkGaussian l = p.landmarks[static_cast<std::size_t>(a.landmark)];
      if (!((l.mean - pose.translation()).squaredNorm() > 0)) continue;
      Eigen::Matrix2d hl;
      const Eigen::Vector2d nu = MeasurementDifference(z, Observe(pose, l.mean, nullptr, &hl));
      const Eigen::Matrix2d s = hl * l.cov * hl.transpose() + r;
      const Eigen::LLT<Eigen::Matrix2d> llt(s);
      if (llt.info() != Eigen::Success) continue;
      if (options_.version == FastSlamVersion::kOne) {
        // 1.0's weight: the observation at the sampled pose (2.0's came with the proposal).
        const double ll = LogGaussian(nu, s);
        if (!std::isnan(ll)) p.log_weight += ll;
      }
      const Eigen::Matrix2d gain = llt.solve(hl * l.cov).transpose();  // P H^T S^-1
      const Eigen::Matrix2d ikh = Eigen::Matrix2d::Identity() - gain * hl;
      l.mean += gain * nu;
      l.cov = ikh * l.cov * ikh.transpose() + gain * r * gain.transpose();  // Joseph form
      p.landmarks.Set(static_cast<std::size_t>(a.landmark), l);
    }
    step->pose = pose;
    step->parent = std::move(p.path);
    p.path = std::move(step);
  }
  return best().path->association;
}

SE2d FastSlam::particle_pose(int i) const { return PoseOf(particles_.at(static_cast<std::size_t>(i)).belief.mean); }

std::vector<double> FastSlam::weights() const {
  std::vector<double> log_w;
  log_w.reserve(particles_.size());
  for (const Particle& p : particles_) log_w.push_back(p.log_weight);
  return NormalizedFromLogs(log_w);
}

double FastSlam::effective_sample_size() const { return EffectiveSampleSize(weights()); }

int FastSlam::best_particle() const {
  int best = 0;
  for (std::size_t i = 1; i < particles_.size(); ++i) {
    if (particles_[i].log_weight > particles_[static_cast<std::size_t>(best)].log_weight) best = static_cast<int>(i);
  }
  return best;
}

int FastSlam::landmark_count(int particle) const {
  return static_cast<int>(particles_.at(static_cast<std::size_t>(particle)).landmarks.size());
}

const LandmarkGaussian& FastSlam::landmark(int particle, int j) const {
  return particles_.at(static_cast<std::size_t>(particle)).landmarks[static_cast<std::size_t>(j)];
}

const PoseBelief& FastSlam::Estimated(const Particle& p) const {
  return options_.version == FastSlamVersion::kTwo && !p.predicted ? p.proposal : p.belief;
}

SE2d FastSlam::pose() const {
  const std::vector<double> w = weights();
  Eigen::Vector2d t = Eigen::Vector2d::Zero();
  double c = 0, s = 0;
  for (std::size_t i = 0; i < particles_.size(); ++i) {
    const Eigen::Vector3d& m = Estimated(particles_[i]).mean;
    t += w[i] * m.head<2>();
    c += w[i] * std::cos(m.z());
    s += w[i] * std::sin(m.z());
  }
  return SE2d(t.x(), t.y(), std::atan2(s, c));
}

Eigen::Matrix3d FastSlam::pose_cov() const {
  const std::vector<double> w = weights();
  const SE2d mean = pose();
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < particles_.size(); ++i) {
    const PoseBelief& b = Estimated(particles_[i]);
    const Eigen::Vector3d d(b.mean.x() - mean.x(), b.mean.y() - mean.y(), WrapAngle(b.mean.z() - mean.theta()));
    cov += w[i] * (b.cov + d * d.transpose());
  }
  return cov;
}

std::vector<SE2d> FastSlam::best_path() const {
  std::vector<SE2d> out;
  for (const Step* s = best().path.get(); s != nullptr; s = s->parent.get()) out.push_back(s->pose);
  std::reverse(out.begin(), out.end());
  return out;
}

std::vector<std::vector<int>> FastSlam::best_association() const {
  std::vector<std::vector<int>> out;
  for (const Step* s = best().path.get(); s != nullptr && s->parent != nullptr; s = s->parent.get()) {
    out.push_back(s->association);
  }
  std::reverse(out.begin(), out.end());
  return out;
}

int FastSlam::wrong_associations() const { return best().path->wrong; }
int FastSlam::dropped_observations() const { return best().path->dropped; }

Track RunFastSlam(FastSlam* filter, const LandmarkWorld& world) {
  if (world.odometry.size() != world.observations.size()) throw InvalidArgument("RunFastSlam: a malformed world");
  Track t;
  t.poses.push_back(filter->pose());
  t.pose_cov.push_back(filter->pose_cov());
  for (std::size_t k = 0; k < world.odometry.size(); ++k) {
    filter->Predict(world.odometry[k], world.dt);
    filter->Update(world.observations[k]);
    t.poses.push_back(filter->pose());
    t.pose_cov.push_back(filter->pose_cov());
  }
  t.association = filter->best_association();
  const int b = filter->best_particle();
  for (int j = 0; j < filter->landmark_count(b); ++j) {
    const LandmarkGaussian& l = filter->landmark(b, j);
    t.first_seen.push_back(l.first_seen);
    t.creator_id.push_back(l.creator_id);
    t.landmarks.push_back(l.mean);
    t.landmark_cov.push_back(l.cov);
  }
  t.wrong_associations = filter->wrong_associations();
  t.dropped_observations = filter->dropped_observations();
  return t;
}

}  // namespace ekf
}  // namespace tether
