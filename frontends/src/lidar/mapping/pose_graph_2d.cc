#include "tether/frontends/lidar/mapping/pose_graph_2d.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <utility>

#include "tether/core/error.h"
#include "tether/core/robust_kernels.h"
#include "tether/core/timing.h"
#include "tether/factors/between_se2.h"
#include "tether/factors/prior.h"

namespace tether {
namespace lidar {

namespace {

bool PositiveFinite(double v) { return std::isfinite(v) && v > 0; }

PoseGraphOptions Checked(const PoseGraphOptions& o) {
  std::string why;
  if (!o.IsValid(&why)) throw InvalidArgument("PoseGraphOptions: " + why);
  return o;
}

SqrtInformation Noise(double translation, double rotation) {
  return SqrtInformation::FromSigmas(Eigen::Vector3d(translation, translation, rotation));
}

}  // namespace

bool PoseGraphOptions::IsValid(std::string* why) const {
  const auto fail = [&](const std::string& w) {
    if (why != nullptr) *why = w;
    return false;
  };
  if (!PositiveFinite(local_translation_sigma) || !PositiveFinite(local_rotation_sigma) ||
      !PositiveFinite(loop_translation_sigma) || !PositiveFinite(loop_rotation_sigma)) {
    return fail("the constraints' sigmas must be positive and finite");
  }
  if ((consecutive_translation_sigma > 0) != (consecutive_rotation_sigma > 0) ||
      !(std::isfinite(consecutive_translation_sigma) && consecutive_translation_sigma >= 0) ||
      !(std::isfinite(consecutive_rotation_sigma) && consecutive_rotation_sigma >= 0)) {
    return fail(
        "consecutive_translation_sigma and consecutive_rotation_sigma must both be positive and finite, or both 0 "
        "(no consecutive constraints)");
  }
  if (!PositiveFinite(huber_delta)) return fail("huber_delta must be positive and finite");
  if (!(std::isfinite(local_huber_delta) && local_huber_delta >= 0)) {
    return fail("local_huber_delta must be finite and not negative (0: none)");
  }
  if (apply_every_n_scans < 1 || update_every_n_scans < 1) {
    return fail("apply_every_n_scans and update_every_n_scans must be at least 1");
  }
  if (!ConstraintBuilderOptions::IsValid(why)) return false;
  std::string w;
  if (!smoother.IsValid(&w)) return fail("smoother: " + w);
  return true;
}

PoseGraph2D::PoseGraph2D(const PoseGraphOptions& options)
    : options_(Checked(options)),
      smoother_(options.smoother),
      builder_(options_,
               GraphEstimates{[this](int i) { return ScanPose(i); }, [this](int j) { return SubmapPose(j); }}) {}

SE2d PoseGraph2D::Pose(Key k) const {
  if (pending_values_.Has(k)) return pending_values_.At<SE2d>(k);
  if (smoother_.Estimate().Has(k)) return smoother_.Estimate().At<SE2d>(k);
  for (auto t = trajectories_.rbegin(); t != trajectories_.rend(); ++t) {
    if (t->held_values.Has(k)) return t->held_values.At<SE2d>(k);
  }
  return smoother_.Estimate().At<SE2d>(k);  // throws, naming the key
}

int PoseGraph2D::ScanTrajectory(int i) const {
  int t = 0;
  while (t + 1 < trajectory_count() && trajectories_[static_cast<std::size_t>(t + 1)].first_scan <= i) ++t;
  return t;
}

void PoseGraph2D::StartTrajectory(const InsertedSubmaps& finished) {
  const Trajectory& current = trajectories_.back();
  for (const auto& [j, submap] : finished) {
    const int global = j + current.first_submap;
    if (submap == nullptr || global < 0 || !submap->finished()) {
      throw InvalidArgument("PoseGraph2D::StartTrajectory: submap " + std::to_string(j) +
                            " of the ending trajectory is null, negative or not finished");
    }
    // A submap the graph never got (only scans that went to the new trajectory were in it).
    if (global >= submap_count()) continue;
    if (options_.loop_closure) builder_.FinishSubmap(global);
  }
  if (scan_count() == current.first_scan) return;
  builder_.StartTrajectory();
  Trajectory next;
  next.first_scan = scan_count();
  next.first_submap = submap_count();
  trajectories_.push_back(std::move(next));
  active_.clear();
}

void PoseGraph2D::Restore(const LidarState& state) {
  if (scan_count() > 0) throw InvalidArgument("PoseGraph2D::Restore: scans were added already");
  if (const std::string why = state.Problem(); !why.empty()) throw InvalidArgument("PoseGraph2D::Restore: " + why);
  if (state.scans.empty()) return;
  for (std::size_t j = 0; j < state.submaps.size(); ++j) {
    const SavedSubmap& m = state.submaps[j];
    auto submap = Submap2D::Restored(m.local_pose, std::make_shared<ProbabilityGrid>(*m.grid), m.num_scans);
    submaps_.push_back(submap);
    builder_.AddSubmap(submap);
    pending_values_.Insert(SubmapKey(static_cast<int>(j)), m.pose);
  }
  const SqrtInformation local = Noise(options_.local_translation_sigma, options_.local_rotation_sigma);
  const bool consecutive = options_.consecutive_translation_sigma > 0;
  const SqrtInformation tie =
      consecutive ? Noise(options_.consecutive_translation_sigma, options_.consecutive_rotation_sigma) : local;
  const auto local_loss = [&](Factor& f) {
    if (options_.local_huber_delta > 0) f.set_loss(std::make_shared<HuberLoss>(options_.local_huber_delta));
  };
  for (std::size_t i = 0; i < state.scans.size(); ++i) {
    const SavedScan& s = state.scans[i];
    const int k = static_cast<int>(i);
    pending_values_.Insert(ScanKey(k), s.pose);
    if (i == 0) pending_graph_.Add<PriorSE2>(ScanKey(0), s.pose, Noise(1e-3, 1e-3));
    for (const int j : s.submaps) {
      local_loss(pending_graph_.Add<BetweenSE2>(
          SubmapKey(j), ScanKey(k), state.submaps[static_cast<std::size_t>(j)].local_pose.Inverse() * s.local_pose,
          local));
    }
    const bool same = i > 0 && state.scans[i - 1].trajectory == s.trajectory;
    if (same && (consecutive || s.submaps.empty())) {
      Factor& f = pending_graph_.Add<BetweenSE2>(ScanKey(k - 1), ScanKey(k),
                                                 state.scans[i - 1].local_pose.Inverse() * s.local_pose, tie);
      if (consecutive) local_loss(f);
    }
    std::vector<Eigen::Vector2d> points = s.points;
    for (Eigen::Vector2d& p : points) p = s.laser_in_robot * p;
    builder_.AddScan(s.local_pose, std::move(points), s.submaps);
    local_poses_.push_back(s.local_pose);
  }
  for (const SavedClosure& c : state.closures) {
    BetweenSE2& f =
        pending_graph_.Add<BetweenSE2>(SubmapKey(c.submap), ScanKey(c.scan), c.relative,
                                       Noise(options_.loop_translation_sigma, options_.loop_rotation_sigma));
    f.set_loss(std::make_shared<HuberLoss>(options_.huber_delta));
    f.set_loop_closure(true);
    closures_.push_back(LoopClosure{c.scan, c.submap, c.relative, c.score});
  }
  for (int j = 0; j < submap_count(); ++j) builder_.RestoreFinishedSubmap(j);
  Flush();
  // The next scans: a trajectory of their own, joined by the global search.
  builder_.StartTrajectory();
  Trajectory next;
  next.first_scan = scan_count();
  next.first_submap = submap_count();
  trajectories_.push_back(std::move(next));
  active_.clear();
}

void PoseGraph2D::Join(int t, const SE2d& correction) {
  Trajectory& tr = trajectories_[static_cast<std::size_t>(t)];
  for (const Key k : tr.held_values.keys()) pending_values_.Insert(k, correction * tr.held_values.At<SE2d>(k));
  for (std::size_t f = 0; f < tr.held_graph.size(); ++f) pending_graph_.Add(tr.held_graph.at(f).Clone());
  tr.held_graph = FactorGraph();
  tr.held_values = Values();
}

void PoseGraph2D::PlaceUnjoined() {
  double right = -std::numeric_limits<double>::infinity();
  for (int i = 0; i < scan_count(); ++i) {
    if (TrajectoryJoinedAt(ScanTrajectory(i)) >= 0) right = std::max(right, ScanPose(i).x());
  }
  for (int t = 1; t < trajectory_count(); ++t) {
    const Trajectory& tr = trajectories_[static_cast<std::size_t>(t)];
    if (tr.joined_at >= 0 || tr.held_values.empty()) continue;
    double left = std::numeric_limits<double>::infinity();
    for (const Key k : tr.held_values.keys()) left = std::min(left, tr.held_values.At<SE2d>(k).x());
    const SE2d shift(right + 5 - left, 0, 0);
    Join(t, shift);
    pending_graph_.Add<PriorSE2>(ScanKey(tr.first_scan), pending_values_.At<SE2d>(ScanKey(tr.first_scan)),
                                 Noise(1e-3, 1e-3));
    // The next one beside this one.
    for (int i = tr.first_scan; i < scan_count() && ScanTrajectory(i) == t; ++i) {
      right = std::max(right, ScanPose(i).x());
    }
  }
}
SE2d PoseGraph2D::ScanPose(int i) const { return Pose(ScanKey(i)); }
SE2d PoseGraph2D::SubmapPose(int j) const { return Pose(SubmapKey(j)); }

void PoseGraph2D::Flush() {
  if (pending_graph_.empty() && pending_values_.size() == 0) return;
  const auto t0 = std::chrono::steady_clock::now();
  smoother_.Update(std::move(pending_graph_), std::move(pending_values_));
  stats_.optimize_seconds += SecondsSince(t0);
  ++stats_.updates;
  pending_graph_ = FactorGraph();
  pending_values_ = Values();
}

SE2d PoseGraph2D::GlobalFromLocal() const {
  if (local_poses_.empty()) return SE2d();
  return ScanPose(scan_count() - 1) * local_poses_.back().Inverse();
}

void PoseGraph2D::AddScan(const SE2d& local_pose, std::vector<Eigen::Vector2d> points,
                          const InsertedSubmaps& inserted_into) {
  Trajectory& tr = trajectories_.back();
  int next = submap_count() - tr.first_submap;  // the index (the trajectory's) a new submap must have
  for (const auto& [j, submap] : inserted_into) {
    if (submap == nullptr || j < 0 || j > next) {
      throw InvalidArgument("PoseGraph2D::AddScan: submap " + std::to_string(j) + " is null or skips an index (" +
                            std::to_string(submap_count() - tr.first_submap) +
                            " so far in this trajectory; give new submaps in increasing order)");
    }
    if (j == next) ++next;
  }
  const int i = scan_count();
  // A new trajectory's first scan continues from the last scan before it (a placement only:
  // nothing links the two).
  const SE2d global_from_local =
      i == tr.first_scan && i > 0 ? ScanPose(i - 1) * local_pose.Inverse() : GlobalFromLocal();
  const bool held = tr.joined_at < 0;
  FactorGraph& g = held ? tr.held_graph : pending_graph_;
  Values& v = held ? tr.held_values : pending_values_;
  for (const auto& [local_index, submap] : inserted_into) {
    const int j = local_index + tr.first_submap;
    if (j == submap_count()) {
      submaps_.push_back(submap);
      builder_.AddSubmap(submap);
      v.Insert(SubmapKey(j), global_from_local * submap->local_pose());
    }
  }
  v.Insert(ScanKey(i), global_from_local * local_pose);
  if (i == 0) g.Add<PriorSE2>(ScanKey(0), local_pose, Noise(1e-3, 1e-3));
  if (!inserted_into.empty()) {
    active_.clear();
    for (const auto& [local_index, submap] : inserted_into) active_.push_back(local_index + tr.first_submap);
  }
  // A scan left out of the submaps (the motion filter; no points) was matched against the
  // active ones all the same: it is tied to them as an inserted scan would be. Tied to the scan
  // before it instead, a run of such scans hung from one end only, and a single loop closure
  // on it could bend it away from the scans after it (Intel: a 1.34 m tear at 388 s).
  builder_.AddScan(local_pose, std::move(points), active_);
  const auto local_loss = [&](Factor& f) {
    if (options_.local_huber_delta > 0) f.set_loss(std::make_shared<HuberLoss>(options_.local_huber_delta));
  };
  for (const int j : active_) {
    local_loss(g.Add<BetweenSE2>(SubmapKey(j), ScanKey(i),
                                 submaps_[static_cast<std::size_t>(j)]->local_pose().Inverse() * local_pose,
                                 Noise(options_.local_translation_sigma, options_.local_rotation_sigma)));
  }
  // Tied to the scan before it (of its trajectory) by the local poses: always with the
  // consecutive ties on, and before the first submap (then as a local constraint, quadratic)
  // where they are off.
  const bool consecutive = options_.consecutive_translation_sigma > 0;
  if (i > tr.first_scan && (consecutive || active_.empty())) {
    Factor& f = g.Add<BetweenSE2>(
        ScanKey(i - 1), ScanKey(i), local_poses_.back().Inverse() * local_pose,
        consecutive ? Noise(options_.consecutive_translation_sigma, options_.consecutive_rotation_sigma)
                    : Noise(options_.local_translation_sigma, options_.local_rotation_sigma));
    if (consecutive) local_loss(f);
  }
  local_poses_.push_back(local_pose);
  // The searches started before this scan are applied with its update: one update for both.
  const bool closures = i > 0 && i % options_.apply_every_n_scans == 0 && TakeClosures();
  if (closures || i % options_.update_every_n_scans == 0) Flush();

  if (options_.loop_closure) {
    // Submaps finished by this scan: every earlier sampled scan near them.
    for (const auto& [j, submap] : inserted_into) {
      if (submap->finished()) builder_.FinishSubmap(j + tr.first_submap);
    }
    // This scan, if sampled, against every finished submap near it.
    builder_.SearchScan(i);
  }
}

bool PoseGraph2D::TakeClosures() {
  const std::vector<LoopClosure> taken = builder_.TakeClosures();
  static_cast<ConstraintBuilderStats&>(stats_) = builder_.stats();
  for (const LoopClosure& l : taken) {
    closures_.push_back(l);
    const int t = ScanTrajectory(l.scan);
    Trajectory& tr = trajectories_[static_cast<std::size_t>(t)];
    if (tr.joined_at < 0 && builder_.submap_trajectory(l.submap) != t) {
      // The trajectory's first closure to the map: moved to where it puts the scan.
      Join(t, Pose(SubmapKey(l.submap)) * l.relative * Pose(ScanKey(l.scan)).Inverse());
      tr.joined_at = scan_count();
    }
    FactorGraph& g = tr.joined_at < 0 ? tr.held_graph : pending_graph_;
    BetweenSE2& f = g.Add<BetweenSE2>(SubmapKey(l.submap), ScanKey(l.scan), l.relative,
                                      Noise(options_.loop_translation_sigma, options_.loop_rotation_sigma));
    f.set_loss(std::make_shared<HuberLoss>(options_.huber_delta));
    f.set_loop_closure(true);
  }
  return !taken.empty();
}

void PoseGraph2D::Export(FactorGraph* graph, Values* values) const {
  const int n = scan_count();
  const auto id = [n](Key k) -> Key {
    return SymbolLetter(k) == 's' ? SymbolIndex(k) : static_cast<Key>(n) + SymbolIndex(k);
  };
  for (int i = 0; i < n; ++i) values->Insert(static_cast<Key>(i), ScanPose(i));
  for (int j = 0; j < submap_count(); ++j) {
    const Key k = SubmapKey(j);
    if (smoother_.Estimate().Has(k) || pending_values_.Has(k)) values->Insert(static_cast<Key>(n + j), Pose(k));
  }
  std::vector<const Factor*> factors;
  for (const FactorGraph* g : {&smoother_.graph(), &pending_graph_}) {
    for (std::size_t f = 0; f < g->size(); ++f) factors.push_back(&g->at(f));
  }
  for (const Factor* f : factors) {
    const Factor& factor = *f;
    if (const auto* b = dynamic_cast<const BetweenSE2*>(&factor)) {
      BetweenSE2& c = graph->Add<BetweenSE2>(id(b->keys()[0]), id(b->keys()[1]), b->measured(), b->noise());
      c.set_loss(b->shared_loss());
      c.set_loop_closure(b->loop_closure());
    } else if (const auto* p = dynamic_cast<const PriorSE2*>(&factor)) {
      graph->Add<PriorSE2>(id(p->keys()[0]), SE2d(p->Measurement()[0], p->Measurement()[1], p->Measurement()[2]),
                           p->noise());
    }
  }
}

void PoseGraph2D::Finish() {
  TakeClosures();
  PlaceUnjoined();
  Flush();
  const auto t0 = std::chrono::steady_clock::now();
  smoother_.Finish();
  stats_.finish_seconds = SecondsSince(t0);
  stats_.optimize_seconds += stats_.finish_seconds;
}

}  // namespace lidar
}  // namespace tether
