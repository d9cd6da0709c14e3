#include "tether/frontends/lidar/mapping/constraint_builder_2d.h"

#include <chrono>
#include <cmath>
#include <limits>
#include <queue>
#include <utility>

#include "tether/core/error.h"
#include "tether/core/timing.h"
#include "tether/frontends/lidar/sensor/voxel_filter.h"

namespace tether {
namespace lidar {

namespace {

bool PositiveFinite(double v) { return std::isfinite(v) && v > 0; }

ConstraintBuilderOptions Checked(const ConstraintBuilderOptions& o) {
  std::string why;
  if (!o.IsValid(&why)) throw InvalidArgument("ConstraintBuilderOptions: " + why);
  return o;
}

}  // namespace

bool ConstraintBuilderOptions::IsValid(std::string* why) const {
  const auto fail = [&](const std::string& w) {
    if (why != nullptr) *why = w;
    return false;
  };
  if (!(min_score >= 0 && min_score < 1)) return fail("min_score must lie in [0, 1)");
  if (!(std::isfinite(max_search_distance) && max_search_distance >= 0)) {
    return fail("max_search_distance must be finite and not negative");
  }
  if (!(std::isfinite(search_angle_growth) && search_angle_growth >= 0 && std::isfinite(max_search_angle) &&
        max_search_angle >= 0 && max_search_angle <= M_PI)) {
    return fail("search_angle_growth must be finite and not negative, max_search_angle in [0, pi]");
  }
  if (!(std::isfinite(search_window_growth) && search_window_growth >= 0)) {
    return fail("search_window_growth must be finite and not negative");
  }
  if (!(std::isfinite(max_search_window) && max_search_window >= 0)) {
    return fail("max_search_window must be finite and not negative");
  }
  if (!(std::isfinite(search_voxel_size) && search_voxel_size >= 0)) {
    return fail("search_voxel_size must be finite and not negative");
  }
  if (!(std::isfinite(confirm_translation) && confirm_translation >= 0 && PositiveFinite(confirm_rotation) &&
        std::isfinite(confirm_min_translation) && confirm_min_translation >= 0 && std::isfinite(confirm_min_rotation) &&
        confirm_min_rotation >= 0 && confirm_max_scans >= 1)) {
    return fail(
        "confirm_translation and confirm_min_* must be finite and not negative, confirm_rotation positive and "
        "finite, confirm_max_scans at least 1");
  }
  if (search_every_n_scans < 1) return fail("search_every_n_scans must be at least 1");
  if (!(std::isfinite(search_every_metres) && search_every_metres >= 0)) {
    return fail("search_every_metres must be finite and not negative (0: by count only)");
  }
  if (threads < 0) return fail("threads must not be negative");
  if (global_search_every_n_scans < 1) return fail("global_search_every_n_scans must be at least 1");
  if (!(std::isfinite(global_search_margin) && global_search_margin >= 0) ||
      !(std::isfinite(global_angular_step) && global_angular_step > 0 && global_angular_step < 1)) {
    return fail("global_search_margin must be finite and not negative, global_angular_step in (0, 1) rad");
  }
  if (!(std::isfinite(join_min_separation) && join_min_separation >= 0) ||
      !(std::isfinite(global_rival_distance) && global_rival_distance > 0) ||
      !(std::isfinite(global_rival_angle) && global_rival_angle > 0)) {
    return fail(
        "join_min_separation must be finite and not negative, global_rival_distance and global_rival_angle "
        "positive and finite");
  }
  if (!(global_min_score >= 0 && global_min_score <= 1)) return fail("global_min_score must lie in [0, 1]");
  if (!(std::isfinite(join_drift) && join_drift >= 0) || !(std::isfinite(join_drift_angle) && join_drift_angle >= 0)) {
    return fail("join_drift and join_drift_angle must be finite and not negative");
  }
  if (!(rival_ratio >= 0 && rival_ratio <= 1)) return fail("rival_ratio must lie in [0, 1]");
  if (!PositiveFinite(rival_distance) || !PositiveFinite(rival_angle)) {
    return fail("rival_distance and rival_angle must be positive and finite");
  }
  std::string w;
  if (!search.IsValid(&w)) return fail("search: " + w);
  if (!refine.IsValid(&w)) return fail("refine: " + w);
  return true;
}

ConstraintBuilder2D::ConstraintBuilder2D(const ConstraintBuilderOptions& options, GraphEstimates estimates)
    : options_(Checked(options)), estimates_(std::move(estimates)) {
  if (!estimates_.scan || !estimates_.submap) {
    throw InvalidArgument("ConstraintBuilder2D: the graph's estimates of scans and submaps must both be given");
  }
  for (int t = 0; t < options_.threads; ++t) workers_.emplace_back([this] { Worker(); });
}

ConstraintBuilder2D::~ConstraintBuilder2D() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  work_.notify_all();
  for (std::thread& t : workers_) t.join();
}

void ConstraintBuilder2D::AddSubmap(std::shared_ptr<const Submap2D> submap) {
  if (submap == nullptr) throw InvalidArgument("ConstraintBuilder2D::AddSubmap: the submap is null");
  SubmapNode node;
  node.submap = std::move(submap);
  node.trajectory = trajectory_count() - 1;
  submaps_.push_back(std::move(node));
  links_.emplace_back();
}

void ConstraintBuilder2D::AddScan(const SE2d& local_pose, std::vector<Eigen::Vector2d> points,
                                  const std::vector<int>& submaps) {
  for (int j : submaps) {
    if (j < 0 || j >= submap_count()) {
      throw InvalidArgument("ConstraintBuilder2D::AddScan: submap " + std::to_string(j) + " was not added (" +
                            std::to_string(submap_count()) + " so far)");
    }
  }
  ScanNode scan;
  scan.local_pose = local_pose;
  scan.points = std::move(points);
  if (options_.search_voxel_size > 0) scan.search_points = VoxelFilter(scan.points, options_.search_voxel_size);
  scan.submaps = submaps;
  scan.trajectory = trajectory_count() - 1;
  for (int j : submaps) {
    SubmapNode& node = submaps_[static_cast<std::size_t>(j)];
    node.reach = std::max(node.reach, (local_pose.translation() - node.submap->local_pose().translation()).norm());
  }
  for (std::size_t a = 0; a < submaps.size(); ++a) {
    for (std::size_t b = a + 1; b < submaps.size(); ++b) Link(submaps[a], submaps[b]);
  }
  // Sampled: every search_every_n_scans-th scan since the last sampled one, or sooner where the
  // robot travelled search_every_metres since.
  const int i = scan_count();
  if (trajectory_started_) {
    scan.sampled = true;
    trajectory_started_ = false;
  } else {
    travel_since_sampled_ += (local_pose.translation() - scans_.back().local_pose.translation()).norm();
    scan.sampled = i - last_sampled_ >= options_.search_every_n_scans ||
                   (options_.search_every_metres > 0 && travel_since_sampled_ >= options_.search_every_metres);
  }
  if (scan.sampled) {
    last_sampled_ = i;
    travel_since_sampled_ = 0;
  }
  scans_.push_back(std::move(scan));
}

void ConstraintBuilder2D::StartTrajectory() {
  joined_.push_back(false);
  trajectory_started_ = true;
  travel_since_sampled_ = 0;
}

void ConstraintBuilder2D::FinishSubmap(int j) {
  if (j < 0 || j >= submap_count()) {
    throw InvalidArgument("ConstraintBuilder2D::FinishSubmap: submap " + std::to_string(j) + " was not added (" +
                          std::to_string(submap_count()) + " so far)");
  }
  SubmapNode& node = submaps_[static_cast<std::size_t>(j)];
  if (node.finished) return;
  if (!node.submap->finished()) {
    throw InvalidArgument("ConstraintBuilder2D::FinishSubmap: submap " + std::to_string(j) +
                          " is not finished (it still takes scans)");
  }
  node.finished = true;
  node.matcher = std::make_unique<LazyMatcher>();
  const std::vector<double> d = GraphDistances({j});
  // Scans of trajectories not yet joined, searched globally before: against this joined submap too.
  if (joined(node.trajectory)) {
    for (int k = 0; k < scan_count(); ++k) {
      const ScanNode& scan = scans_[static_cast<std::size_t>(k)];
      if (scan.global && !joined(scan.trajectory)) StartGlobalSearch(k, j);
    }
  }
  for (int k = 0; k < scan_count(); ++k) {
    if (!scans_[static_cast<std::size_t>(k)].sampled || !Windowed(k, j)) continue;
    double distance = std::numeric_limits<double>::infinity();
    for (int m : scans_[static_cast<std::size_t>(k)].submaps) distance = std::min(distance, d[m]);
    SearchNear(k, j, distance);
  }
}

void ConstraintBuilder2D::RestoreFinishedSubmap(int j) {
  if (j < 0 || j >= submap_count() || !submaps_[static_cast<std::size_t>(j)].submap->finished()) {
    throw InvalidArgument("ConstraintBuilder2D::RestoreFinishedSubmap: submap " + std::to_string(j) +
                          " was not added or is not finished");
  }
  SubmapNode& node = submaps_[static_cast<std::size_t>(j)];
  if (node.finished) return;
  node.finished = true;
  node.matcher = std::make_unique<LazyMatcher>();
}

void ConstraintBuilder2D::SearchScan(int i) {
  if (i < 0 || i >= scan_count()) {
    throw InvalidArgument("ConstraintBuilder2D::SearchScan: scan " + std::to_string(i) + " was not added (" +
                          std::to_string(scan_count()) + " so far)");
  }
  const ScanNode& scan = scans_[static_cast<std::size_t>(i)];
  if (!scan.sampled) return;
  const std::vector<double> d = GraphDistances(scan.submaps);
  const bool global =
      !joined(scan.trajectory) && (last_global_ < 0 || i - last_global_ >= options_.global_search_every_n_scans ||
                                   scans_[static_cast<std::size_t>(last_global_)].trajectory != scan.trajectory);
  if (global) {
    last_global_ = i;
    scans_[static_cast<std::size_t>(i)].global = true;
  }
  for (int j = 0; j < submap_count(); ++j) {
    const SubmapNode& submap = submaps_[static_cast<std::size_t>(j)];
    if (!submap.finished) continue;
    if (Windowed(i, j)) {
      SearchNear(i, j, d[static_cast<std::size_t>(j)]);
    } else if (global && joined(submap.trajectory)) {
      StartGlobalSearch(i, j);
    }
  }
}

bool ConstraintBuilder2D::Windowed(int k, int j) const {
  const int a = scans_[static_cast<std::size_t>(k)].trajectory;
  const int b = submaps_[static_cast<std::size_t>(j)].trajectory;
  return a == b || (joined(a) && joined(b));
}

void ConstraintBuilder2D::StartGlobalSearch(int k, int j) {
  // The scan anywhere its submap's own scans were taken from (and a margin), at any heading.
  const SubmapNode& node = submaps_[static_cast<std::size_t>(j)];
  const SE2d& origin = node.submap->local_pose();
  const SE2d guess(origin.x(), origin.y(), 0);
  StartSearch(k, j, node.reach + options_.global_search_margin, M_PI, &guess);
}

void ConstraintBuilder2D::SearchNear(int k, int j, double distance) {
  // Scan k against submap j, with the window for their graph distance (a scan in no submap,
  // before the first, is as near as the submaps it follows).
  const ScanNode& s = scans_[static_cast<std::size_t>(k)];
  if (std::find(s.submaps.begin(), s.submaps.end(), j) != s.submaps.end()) return;
  const double base = options_.search.linear_search_window;
  const double d = s.submaps.empty() ? 0.0 : distance;
  const double window = Window(d);
  const double reach = options_.max_search_distance + (window - base);
  if ((estimates_.scan(k).translation() - estimates_.submap(j).translation()).norm() <= reach) {
    StartSearch(k, j, window, Angle(d));
  }
}

void ConstraintBuilder2D::Link(int a, int b) {
  std::vector<int>& la = links_[static_cast<std::size_t>(a)];
  if (a == b || std::find(la.begin(), la.end(), b) != la.end()) return;
  la.push_back(b);
  links_[static_cast<std::size_t>(b)].push_back(a);
}

std::vector<double> ConstraintBuilder2D::GraphDistances(const std::vector<int>& from) const {
  const int n = submap_count();
  std::vector<Eigen::Vector2d> origin(static_cast<std::size_t>(n));
  for (int j = 0; j < n; ++j) origin[static_cast<std::size_t>(j)] = estimates_.submap(j).translation();
  std::vector<double> d(static_cast<std::size_t>(n), std::numeric_limits<double>::infinity());
  using Entry = std::pair<double, int>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> queue;
  for (int j : from) {
    d[static_cast<std::size_t>(j)] = 0;
    queue.emplace(0.0, j);
  }
  while (!queue.empty()) {
    const auto [dj, j] = queue.top();
    queue.pop();
    if (dj > d[static_cast<std::size_t>(j)]) continue;
    for (int m : links_[static_cast<std::size_t>(j)]) {
      const double dm = dj + (origin[static_cast<std::size_t>(m)] - origin[static_cast<std::size_t>(j)]).norm();
      if (dm < d[static_cast<std::size_t>(m)]) {
        d[static_cast<std::size_t>(m)] = dm;
        queue.emplace(dm, m);
      }
    }
  }
  return d;
}

double ConstraintBuilder2D::Angle(double distance) const {
  const double base = options_.search.angular_search_window;
  if (!(options_.search_angle_growth > 0)) return base;
  return std::max(base, std::min(options_.max_search_angle, base + options_.search_angle_growth * distance));
}

double ConstraintBuilder2D::Window(double distance) const {
  const double base = options_.search.linear_search_window;
  if (!(options_.search_window_growth > 0)) return base;
  return std::max(base, std::min(options_.max_search_window, base + options_.search_window_growth * distance));
}

void ConstraintBuilder2D::StartSearch(int scan, int submap, double window, double angle, const SE2d* global_guess) {
  auto s = std::make_unique<Search>();
  s->scan = scan;
  s->submap = submap;
  s->window = window;
  s->angle = angle;
  const SubmapNode& node = submaps_[static_cast<std::size_t>(submap)];
  s->matcher = node.matcher.get();
  s->grid = node.submap->grid();
  s->submap_local = node.submap->local_pose();
  const ScanNode& node_scan = scans_[static_cast<std::size_t>(scan)];
  s->points = &node_scan.points;
  s->search_points = node_scan.search_points.empty() ? &node_scan.points : &node_scan.search_points;
  // The scan's pose in the submap's grid (the local map frame it was built in).
  s->global = global_guess != nullptr;
  if (s->global) s->step = options_.global_angular_step;
  s->guess =
      s->global ? *global_guess : s->submap_local * (estimates_.submap(submap).Inverse() * estimates_.scan(scan));
  Search* raw = s.get();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    searches_.push_back(std::move(s));
    if (!workers_.empty()) queue_.push_back(raw);
  }
  if (workers_.empty()) {
    RunSearch(raw);
  } else {
    work_.notify_one();
  }
}

void ConstraintBuilder2D::RunSearch(Search* s) const {
  const auto t0 = std::chrono::steady_clock::now();
  // A search that throws (a degenerate scan) finds nothing; on a worker thread an exception
  // would end the program.
  try {
    std::call_once(s->matcher->once, [&] {
      s->matcher->matcher = std::make_unique<FastCorrelativeScanMatcher2D>(*s->grid, options_.search);
    });
    const FastMatch m = s->matcher->matcher->MatchChecked(
        s->guess, *s->search_points, s->global ? options_.global_min_score : options_.min_score,
        options_.rival_distance, options_.rival_angle, options_.rival_ratio, s->window, s->angle, s->step);
    if (m.found && m.on_edge) {
      s->on_edge = true;
    } else if (m.found && m.ambiguous) {
      s->ambiguous = true;
    } else if (m.found) {
      SE2d pose = m.pose;
      const ScanRefinement r = RefineScanPose(s->grid, m.pose, m.pose, *s->points, options_.refine);
      if (r.status == SolverStatus::kConverged || r.status == SolverStatus::kMaxIterations) pose = r.pose;
      s->found = true;
      s->result = LoopClosure{s->scan, s->submap, s->submap_local.Inverse() * pose, m.score};
    }
  } catch (const std::exception&) {
    s->found = false;
  }
  s->seconds = SecondsSince(t0);
  if (workers_.empty()) s->done = true;
}

void ConstraintBuilder2D::Worker() {
  for (;;) {
    Search* s = nullptr;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      work_.wait(lock, [this] { return stop_ || !queue_.empty(); });
      if (stop_ && queue_.empty()) return;
      s = queue_.front();
      queue_.pop_front();
    }
    RunSearch(s);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      s->done = true;
    }
    finished_.notify_all();
  }
}

// Waits for every search started so far and reads them all, in the order they were started
// (never a part: that would depend on the threads' timing).
std::vector<LoopClosure> ConstraintBuilder2D::TakeClosures() {
  const auto t0 = std::chrono::steady_clock::now();
  std::deque<std::unique_ptr<Search>> done;
  {
    std::unique_lock<std::mutex> lock(mutex_);
    finished_.wait(lock, [this] {
      return std::all_of(searches_.begin(), searches_.end(), [](const std::unique_ptr<Search>& s) { return s->done; });
    });
    done.swap(searches_);
  }
  stats_.wait_seconds += SecondsSince(t0);
  DropGlobalRivals(&done);
  std::vector<LoopClosure> closures;
  for (const std::unique_ptr<Search>& s : done) {
    ++stats_.searches;
    stats_.search_seconds += s->seconds;
    if (s->global) {
      ++stats_.global_searches;
      stats_.global_seconds += s->seconds;
    }
    if (s->ambiguous) ++stats_.ambiguous;
    if (s->on_edge) ++stats_.on_edge;
    if (!s->found) continue;
    ++stats_.found;
    stats_.found_seconds += s->seconds;
    const int c = static_cast<int>(candidates_.size());
    candidates_.push_back(Candidate{s->result, false});
    std::vector<int>& same_submap = candidates_of_submap_[s->result.submap];
    if (!(options_.confirm_translation > 0)) {
      Confirm(c, &closures);
    } else {
      // Confirmed by an earlier candidate that agrees with it: both become closures.
      for (int other : same_submap) {
        if (!Agree(candidates_[static_cast<std::size_t>(c)].closure,
                   candidates_[static_cast<std::size_t>(other)].closure)) {
          continue;
        }
        if (!candidates_[static_cast<std::size_t>(c)].added) Confirm(c, &closures);
        if (!candidates_[static_cast<std::size_t>(other)].added) Confirm(other, &closures);
      }
    }
    same_submap.push_back(c);
  }
  stats_.unconfirmed = stats_.found - confirmed_;
  return closures;
}

void ConstraintBuilder2D::DropGlobalRivals(std::deque<std::unique_ptr<Search>>* done) const {
  // A scan searched globally against several submaps whose matches put it in different places
  // of the map (a room like another, a corridor like another): none of them is taken.
  std::unordered_map<int, std::vector<Search*>> by_scan;
  for (const std::unique_ptr<Search>& s : *done) {
    if (s->global && s->found) by_scan[s->scan].push_back(s.get());
  }
  for (auto& [scan, found] : by_scan) {
    bool rivals = false;
    for (std::size_t a = 0; a < found.size() && !rivals; ++a) {
      const SE2d pa = estimates_.submap(found[a]->submap) * found[a]->result.relative;
      for (std::size_t b = a + 1; b < found.size() && !rivals; ++b) {
        const SE2d pb = estimates_.submap(found[b]->submap) * found[b]->result.relative;
        rivals = (pa.translation() - pb.translation()).norm() > options_.global_rival_distance ||
                 std::abs(WrapAngle(pa.theta() - pb.theta())) > options_.global_rival_angle;
      }
    }
    if (!rivals) continue;
    for (Search* s : found) {
      s->found = false;
      s->ambiguous = true;
    }
  }
}

bool ConstraintBuilder2D::Agree(const LoopClosure& a, const LoopClosure& b) const {
  if (a.submap != b.submap || a.scan == b.scan || std::abs(a.scan - b.scan) > options_.confirm_max_scans ||
      scan_trajectory(a.scan) != scan_trajectory(b.scan)) {
    return false;
  }
  // Local SLAM's relative pose between the two scans, and the one the two closures imply.
  const SE2d local = scans_[static_cast<std::size_t>(a.scan)].local_pose.Inverse() *
                     scans_[static_cast<std::size_t>(b.scan)].local_pose;
  if (local.translation().norm() < options_.confirm_min_translation &&
      std::abs(local.theta()) < options_.confirm_min_rotation) {
    return false;  // the same view again is no second opinion
  }
  const SE2d error = local.Inverse() * (a.relative.Inverse() * b.relative);
  return error.translation().norm() < options_.confirm_translation &&
         std::abs(error.theta()) < options_.confirm_rotation;
}

void ConstraintBuilder2D::Confirm(int candidate, std::vector<LoopClosure>* out) {
  Candidate& c = candidates_[static_cast<std::size_t>(candidate)];
  c.added = true;
  ++confirmed_;
  const LoopClosure& l = c.closure;
  const int t = scan_trajectory(l.scan);
  if (!joined(t) && joined(submap_trajectory(l.submap))) {
    HoldJoin(t, l, out);
    return;
  }
  out->push_back(l);
  for (int m : scans_[static_cast<std::size_t>(l.scan)].submaps) Link(m, l.submap);
}

bool ConstraintBuilder2D::PlaceAlike(const LoopClosure& a, const LoopClosure& b) const {
  const auto scan = [this](int i) -> const SE2d& { return scans_[static_cast<std::size_t>(i)].local_pose; };
  // The motion from a's scan to b's: local SLAM's, and the one the two closures imply.
  const SE2d local = scan(a.scan).Inverse() * scan(b.scan);
  const SE2d implied =
      (estimates_.submap(a.submap) * a.relative).Inverse() * (estimates_.submap(b.submap) * b.relative);
  const SE2d error = local.Inverse() * implied;
  double driven = 0;
  for (int i = std::min(a.scan, b.scan); i < std::max(a.scan, b.scan); ++i) {
    driven += (scan(i + 1).translation() - scan(i).translation()).norm();
  }
  return error.translation().norm() <= options_.global_rival_distance + options_.join_drift * driven &&
         std::abs(WrapAngle(error.theta())) <= options_.global_rival_angle + options_.join_drift_angle * driven;
}

void ConstraintBuilder2D::HoldJoin(int t, const LoopClosure& l, std::vector<LoopClosure>* out) {
  // A trajectory not yet joined is joined only where confirmed closures to two submaps at
  // least join_min_separation apart place it alike: look-alike rooms give a confirmed pair
  // each, but not one placement for the room and the corridor outside it.
  std::vector<LoopClosure>& held = held_joins_[t];
  held.push_back(l);
  const Eigen::Vector2d at = estimates_.submap(l.submap).translation();
  bool join = false;
  for (const LoopClosure& h : held) {
    join = join || ((estimates_.submap(h.submap).translation() - at).norm() >= options_.join_min_separation &&
                    PlaceAlike(h, l));
  }
  if (!join) return;
  joined_[static_cast<std::size_t>(t)] = true;
  // The closures that agree with this one join it; the others are dropped.
  for (const LoopClosure& h : held) {
    if (!PlaceAlike(h, l)) continue;
    out->push_back(h);
    for (int m : scans_[static_cast<std::size_t>(h.scan)].submaps) Link(m, h.submap);
  }
  held.clear();
}

}  // namespace lidar
}  // namespace tether
