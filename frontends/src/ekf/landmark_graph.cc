#include "tether/frontends/ekf/landmark_graph.h"

#include <Eigen/Cholesky>
#include <chrono>
#include <cmath>
#include <map>

#include "tether/core/error.h"
#include "tether/core/timing.h"
#include "tether/factors/between_se2.h"
#include "tether/factors/prior.h"
#include "tether/factors/range_bearing.h"

namespace tether {
namespace ekf {

namespace {

// The known association: landmark indices in the order the true ids are first seen.
Track KnownAssociation(const LandmarkWorld& world) {
  Track t;
  std::map<int, int> index;
  for (const std::vector<Observation>& step : world.observations) {
    std::vector<int> a;
    for (const Observation& o : step) {
      if (o.id < 0) throw InvalidArgument("known association: an observation has no id");
      const auto it = index.emplace(o.id, static_cast<int>(index.size())).first;
      if (it->second == static_cast<int>(t.creator_id.size())) t.creator_id.push_back(o.id);
      a.push_back(it->second);
    }
    t.association.push_back(std::move(a));
  }
  return t;
}

void CheckTrack(const LandmarkWorld& world, const Track& seed) {
  if (seed.poses.size() != world.observations.size() + 1 || seed.association.size() != world.observations.size() ||
      world.odometry.size() != world.observations.size()) {
    throw InvalidArgument("landmark graph: the track does not match the world (" + std::to_string(seed.poses.size()) +
                          " poses for " + std::to_string(world.odometry.size()) + " controls)");
  }
  for (std::size_t k = 0; k < seed.association.size(); ++k) {
    if (seed.association[k].size() != world.observations[k].size()) {
      throw InvalidArgument("landmark graph: step " + std::to_string(k) + " has another number of observations");
    }
    for (int j : seed.association[k]) {
      if (j >= static_cast<int>(seed.first_seen.size())) {
        throw InvalidArgument("landmark graph: step " + std::to_string(k) + " names landmark " + std::to_string(j) +
                              ", which has no initial value");
      }
    }
  }
}

SqrtInformation MeasurementNoise(const LandmarkGraphOptions& o) {
  const Eigen::LLT<Eigen::Matrix2d> llt(o.measurement_cov);
  if (!o.measurement_cov.allFinite() || o.measurement_cov(0, 1) != o.measurement_cov(1, 0) ||
      llt.info() != Eigen::Success) {
    throw InvalidArgument("landmark graph: measurement_cov must be symmetric, finite and positive definite");
  }
  return SqrtInformation::FromInformation(llt.solve(Eigen::Matrix2d::Identity()));
}

// The factors of step k (the odometry from pose k to k + 1, the observations at k + 1).
void AddStep(const LandmarkWorld& world, const std::vector<int>& association, std::size_t k,
             const LandmarkGraphOptions& o, const SqrtInformation& rb_noise, FactorGraph* g) {
  odometry::MotionIntegrator m(o.odometry);
  m.Add(world.odometry[k], world.dt);
  const int i = static_cast<int>(k);
  g->Add<BetweenSE2>(PoseKey(i), PoseKey(i + 1), m.relative(), SqrtInformation::FromInformation(m.Information()));
  for (std::size_t n = 0; n < association.size(); ++n) {
    if (association[n] < 0) continue;
    const Observation& ob = world.observations[k][n];
    g->Add<RangeBearing2>(PoseKey(i + 1), LandmarkKey(association[n]), ob.range, ob.bearing, rb_noise);
  }
}

void AddPrior(const Track& seed, const LandmarkGraphOptions& o, FactorGraph* g) {
  const double s = o.prior_sigma;
  g->Add<PriorSE2>(PoseKey(0), seed.poses.front(), SqrtInformation::FromSigmas(Eigen::Vector3d(s, s, s)));
}

}  // namespace

Track RunFilter(LandmarkFilter* filter, const LandmarkWorld& world) {
  if (world.odometry.size() != world.observations.size()) throw InvalidArgument("RunFilter: a malformed world");
  Track t;
  t.poses.push_back(filter->pose());
  t.pose_cov.push_back(filter->pose_cov());
  for (std::size_t k = 0; k < world.odometry.size(); ++k) {
    filter->Predict(world.odometry[k], world.dt);
    const int before = filter->landmark_count();
    t.association.push_back(filter->Update(world.observations[k]));
    for (int j = before; j < filter->landmark_count(); ++j) {
      t.first_seen.push_back(filter->landmark(j));
      t.creator_id.push_back(filter->creator_id(j));
    }
    t.poses.push_back(filter->pose());
    t.pose_cov.push_back(filter->pose_cov());
  }
  for (int j = 0; j < filter->landmark_count(); ++j) {
    t.landmarks.push_back(filter->landmark(j));
    t.landmark_cov.push_back(filter->landmark_cov(j));
  }
  t.wrong_associations = filter->wrong_associations();
  t.dropped_observations = filter->dropped_observations();
  return t;
}

Track TruthTrack(const LandmarkWorld& world) {
  Track t = KnownAssociation(world);
  t.poses = world.truth;
  for (int id : t.creator_id) t.first_seen.push_back(world.landmarks.at(static_cast<std::size_t>(id)));
  t.landmarks = t.first_seen;
  return t;
}

Track DeadReckoningTrack(const LandmarkWorld& world) {
  Track t = KnownAssociation(world);
  t.poses = DeadReckoning(world);
  std::vector<Eigen::Vector2d> sum(t.creator_id.size(), Eigen::Vector2d::Zero());
  std::vector<int> count(t.creator_id.size(), 0);
  t.first_seen.assign(t.creator_id.size(), Eigen::Vector2d::Zero());
  for (std::size_t k = 0; k < world.observations.size(); ++k) {
    for (std::size_t n = 0; n < world.observations[k].size(); ++n) {
      const Observation& o = world.observations[k][n];
      const auto j = static_cast<std::size_t>(t.association[k][n]);
      const Eigen::Vector2d l = InverseObserve(t.poses[k + 1], Eigen::Vector2d(o.range, o.bearing));
      if (count[j] == 0) t.first_seen[j] = l;
      sum[j] += l;
      ++count[j];
    }
  }
  for (std::size_t j = 0; j < sum.size(); ++j) t.landmarks.push_back(sum[j] / count[j]);
  return t;
}

FactorGraph BuildLandmarkGraph(const LandmarkWorld& world, const std::vector<std::vector<int>>& association,
                               const LandmarkGraphOptions& options) {
  Track seed;
  seed.poses.assign(world.observations.size() + 1, world.truth.empty() ? SE2d() : world.truth.front());
  seed.association = association;
  int most = -1;
  for (const auto& step : association) {
    for (int j : step) most = std::max(most, j);
  }
  seed.first_seen.assign(static_cast<std::size_t>(most + 1), Eigen::Vector2d::Zero());
  CheckTrack(world, seed);
  FactorGraph g;
  AddPrior(seed, options, &g);
  const SqrtInformation rb = MeasurementNoise(options);
  for (std::size_t k = 0; k < world.observations.size(); ++k) AddStep(world, association[k], k, options, rb, &g);
  return g;
}

Values SeedValues(const Track& seed) {
  Values v;
  for (std::size_t i = 0; i < seed.poses.size(); ++i) v.Insert(PoseKey(static_cast<int>(i)), seed.poses[i]);
  std::vector<bool> used(seed.first_seen.size(), false);
  for (const auto& step : seed.association) {
    for (int j : step) {
      if (j >= 0) used[static_cast<std::size_t>(j)] = true;
    }
  }
  for (std::size_t j = 0; j < used.size(); ++j) {
    if (used[j]) v.Insert(LandmarkKey(static_cast<int>(j)), seed.first_seen[j]);
  }
  return v;
}

SmoothedTrack SmoothLandmarkRun(const LandmarkWorld& world, const Track& seed, const LandmarkGraphOptions& options) {
  CheckTrack(world, seed);
  IncrementalSmoother smoother(options.smoother);
  const SqrtInformation rb = MeasurementNoise(options);
  std::vector<bool> placed(seed.first_seen.size(), false);
  SmoothedTrack out;
  const auto t0 = std::chrono::steady_clock::now();
  {
    FactorGraph g;
    Values v;
    AddPrior(seed, options, &g);
    v.Insert(PoseKey(0), seed.poses.front());
    smoother.Update(std::move(g), std::move(v));
    ++out.updates;
  }
  if (options.record_online) {
    out.online_poses.push_back(seed.poses.front());
    out.online_pose_cov.push_back(Eigen::Matrix3d::Identity() * options.prior_sigma * options.prior_sigma);
  }
  for (std::size_t k = 0; k < world.observations.size(); ++k) {
    FactorGraph g;
    Values v;
    v.Insert(PoseKey(static_cast<int>(k + 1)), seed.poses[k + 1]);
    for (int j : seed.association[k]) {
      if (j < 0 || placed[static_cast<std::size_t>(j)]) continue;
      placed[static_cast<std::size_t>(j)] = true;
      v.Insert(LandmarkKey(j), seed.first_seen[static_cast<std::size_t>(j)]);
    }
    AddStep(world, seed.association[k], k, options, rb, &g);
    smoother.Update(std::move(g), std::move(v));
    ++out.updates;
    if (options.record_online) {
      const Key x = PoseKey(static_cast<int>(k + 1));
      out.online_poses.push_back(smoother.Estimate().At<SE2d>(x));
      out.online_pose_cov.push_back(smoother.Marginal(x));
    }
  }
  out.online_seconds = SecondsSince(t0);
  const auto t1 = std::chrono::steady_clock::now();
  const Values& optimum = smoother.Finish();
  out.finish_seconds = SecondsSince(t1);
  out.finish = smoother.finish_summary();
  out.chi2 = smoother.graph().Chi2(optimum);
  out.track = seed;
  out.track.pose_cov.clear();
  out.track.landmark_cov.clear();
  for (std::size_t i = 0; i < seed.poses.size(); ++i)
    out.track.poses[i] = optimum.At<SE2d>(PoseKey(static_cast<int>(i)));
  out.track.landmarks.assign(seed.first_seen.size(), Eigen::Vector2d::Constant(std::nan("")));
  for (std::size_t j = 0; j < placed.size(); ++j) {
    if (placed[j]) out.track.landmarks[j] = optimum.At<Eigen::Vector2d>(LandmarkKey(static_cast<int>(j)));
  }
  return out;
}

double TrajectoryRmse(const std::vector<SE2d>& poses, const std::vector<SE2d>& truth) {
  if (poses.size() != truth.size() || poses.empty())
    throw InvalidArgument("TrajectoryRmse: the trajectories differ in length");
  double sum = 0;
  for (std::size_t i = 0; i < poses.size(); ++i) sum += (poses[i].translation() - truth[i].translation()).squaredNorm();
  return std::sqrt(sum / static_cast<double>(poses.size()));
}

double LandmarkRmse(const Track& track, const std::vector<Eigen::Vector2d>& truth) {
  double sum = 0;
  int n = 0;
  for (std::size_t j = 0; j < track.landmarks.size() && j < track.creator_id.size(); ++j) {
    const int id = track.creator_id[j];
    if (id < 0 || static_cast<std::size_t>(id) >= truth.size() || !track.landmarks[j].allFinite()) continue;
    sum += (track.landmarks[j] - truth[static_cast<std::size_t>(id)]).squaredNorm();
    ++n;
  }
  return n == 0 ? std::nan("") : std::sqrt(sum / n);
}

}  // namespace ekf
}  // namespace tether
