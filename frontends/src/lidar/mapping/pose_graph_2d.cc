#include "tether/frontends/lidar/mapping/pose_graph_2d.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <queue>
#include <utility>

#include "tether/core/error.h"
#include "tether/core/robust_kernels.h"
#include "tether/core/timing.h"
#include "tether/factors/between_se2.h"
#include "tether/factors/prior.h"
#include "tether/frontends/lidar/sensor/voxel_filter.h"

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
  if (search_every_n_scans < 1 || apply_every_n_scans < 1 || update_every_n_scans < 1) {
    return fail("search_every_n_scans, apply_every_n_scans and update_every_n_scans must be at least 1");
  }
  if (!(std::isfinite(search_every_metres) && search_every_metres >= 0)) {
    return fail("search_every_metres must be finite and not negative (0: by count only)");
  }
  if (threads < 0) return fail("threads must not be negative");
  if (!(rival_ratio >= 0 && rival_ratio <= 1)) return fail("rival_ratio must lie in [0, 1]");
  if (!PositiveFinite(rival_distance) || !PositiveFinite(rival_angle)) {
    return fail("rival_distance and rival_angle must be positive and finite");
  }
  std::string w;
  if (!search.IsValid(&w)) return fail("search: " + w);
  if (!refine.IsValid(&w)) return fail("refine: " + w);
  if (!smoother.IsValid(&w)) return fail("smoother: " + w);
  return true;
}

PoseGraph2D::PoseGraph2D(const PoseGraphOptions& options) : options_(Checked(options)), smoother_(options.smoother) {
  for (int t = 0; t < options_.threads; ++t) workers_.emplace_back([this] { Worker(); });
}

PoseGraph2D::~PoseGraph2D() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  work_.notify_all();
  for (std::thread& t : workers_) t.join();
}

SE2d PoseGraph2D::Pose(Key k) const {
  return pending_values_.Has(k) ? pending_values_.At<SE2d>(k) : smoother_.Estimate().At<SE2d>(k);
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
  if (scans_.empty()) return SE2d();
  return ScanPose(scan_count() - 1) * scans_.back().local_pose.Inverse();
}

void PoseGraph2D::AddScan(const SE2d& local_pose, std::vector<Eigen::Vector2d> points,
                          const InsertedSubmaps& inserted_into) {
  int next = submap_count();  // the index a new submap must have
  for (const auto& [j, submap] : inserted_into) {
    if (submap == nullptr || j < 0 || j > next) {
      throw InvalidArgument("PoseGraph2D::AddScan: submap " + std::to_string(j) + " is null or skips an index (" +
                            std::to_string(submap_count()) + " so far; give new submaps in increasing order)");
    }
    if (j == next) ++next;
  }
  const int i = scan_count();
  const SE2d global_from_local = GlobalFromLocal();
  FactorGraph& g = pending_graph_;
  Values& v = pending_values_;
  for (const auto& [j, submap] : inserted_into) {
    if (j == submap_count()) {
      submaps_.push_back(SubmapNode{});
      links_.emplace_back();
    }
    SubmapNode& node = submaps_[static_cast<std::size_t>(j)];
    if (node.submap == nullptr) {
      node.submap = submap;
      v.Insert(SubmapKey(j), global_from_local * submap->local_pose());
    }
  }
  v.Insert(ScanKey(i), global_from_local * local_pose);
  if (i == 0) g.Add<PriorSE2>(ScanKey(0), local_pose, Noise(1e-3, 1e-3));
  ScanNode scan;
  scan.local_pose = local_pose;
  scan.points = std::move(points);
  if (options_.search_voxel_size > 0) scan.search_points = VoxelFilter(scan.points, options_.search_voxel_size);
  if (!inserted_into.empty()) {
    active_.clear();
    for (const auto& [j, submap] : inserted_into) active_.push_back(j);
    for (std::size_t a = 0; a < active_.size(); ++a) {
      for (std::size_t b = a + 1; b < active_.size(); ++b) Link(active_[a], active_[b]);
    }
  }
  // A scan left out of the submaps (the motion filter; no points) was matched against the
  // active ones all the same: it is tied to them as an inserted scan would be. Tied to the scan
  // before it instead, a run of such scans hung from one end only, and a single loop closure
  // on it could bend it away from the scans after it (Intel: a 1.34 m tear at 388 s).
  const auto local_loss = [&](Factor& f) {
    if (options_.local_huber_delta > 0) f.set_loss(std::make_shared<HuberLoss>(options_.local_huber_delta));
  };
  for (const int j : active_) {
    local_loss(g.Add<BetweenSE2>(SubmapKey(j), ScanKey(i),
                                 submaps_[static_cast<std::size_t>(j)].submap->local_pose().Inverse() * local_pose,
                                 Noise(options_.local_translation_sigma, options_.local_rotation_sigma)));
    scan.submaps.push_back(j);
  }
  // Tied to the scan before it by the local poses: always with the consecutive ties on, and
  // before the first submap (then as a local constraint, quadratic) where they are off.
  const bool consecutive = options_.consecutive_translation_sigma > 0;
  if (i > 0 && (consecutive || active_.empty())) {
    Factor& f = g.Add<BetweenSE2>(
        ScanKey(i - 1), ScanKey(i), scans_.back().local_pose.Inverse() * local_pose,
        consecutive ? Noise(options_.consecutive_translation_sigma, options_.consecutive_rotation_sigma)
                    : Noise(options_.local_translation_sigma, options_.local_rotation_sigma));
    if (consecutive) local_loss(f);
  }
  // Sampled for the loop-closure search: every search_every_n_scans-th scan since the last
  // sampled one, or sooner where the robot travelled search_every_metres since.
  if (scans_.empty()) {
    scan.sampled = true;
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
  // The searches started before this scan are applied with its update: one update for both.
  const bool closures = i > 0 && i % options_.apply_every_n_scans == 0 && ApplyFinishedSearches();
  if (closures || i % options_.update_every_n_scans == 0) Flush();

  if (options_.loop_closure) {
    // Submaps finished by this scan: every earlier sampled scan near them.
    for (const auto& [j, submap] : inserted_into) {
      if (submaps_[static_cast<std::size_t>(j)].finished || !submap->finished()) continue;
      SearchNewlyFinished(j, i);
    }
    // This scan, if sampled, against every finished submap near it.
    if (scans_.back().sampled) {
      const std::vector<double> d = GraphDistances(scans_.back().submaps);
      for (int j = 0; j < submap_count(); ++j) {
        if (submaps_[static_cast<std::size_t>(j)].finished) SearchNear(i, j, d[static_cast<std::size_t>(j)]);
      }
    }
  }
}

void PoseGraph2D::SearchNear(int k, int j, double distance) {
  // Scan k against submap j, with the window for their graph distance (a scan in no submap,
  // before the first, is as near as the submaps it follows).
  const ScanNode& s = scans_[static_cast<std::size_t>(k)];
  if (std::find(s.submaps.begin(), s.submaps.end(), j) != s.submaps.end()) return;
  const double base = options_.search.linear_search_window;
  const double d = s.submaps.empty() ? 0.0 : distance;
  const double window = Window(d);
  const double reach = options_.max_search_distance + (window - base);
  if ((ScanPose(k).translation() - SubmapPose(j).translation()).norm() <= reach) StartSearch(k, j, window, Angle(d));
}

void PoseGraph2D::SearchNewlyFinished(int j, int before) {
  SubmapNode& node = submaps_[static_cast<std::size_t>(j)];
  node.finished = true;
  node.matcher = std::make_unique<LazyMatcher>();
  const std::vector<double> d = GraphDistances({j});
  for (int k = 0; k < before; ++k) {
    if (!scans_[static_cast<std::size_t>(k)].sampled) continue;
    double distance = std::numeric_limits<double>::infinity();
    for (int m : scans_[static_cast<std::size_t>(k)].submaps) distance = std::min(distance, d[m]);
    SearchNear(k, j, distance);
  }
}

void PoseGraph2D::Link(int a, int b) {
  std::vector<int>& la = links_[static_cast<std::size_t>(a)];
  if (a == b || std::find(la.begin(), la.end(), b) != la.end()) return;
  la.push_back(b);
  links_[static_cast<std::size_t>(b)].push_back(a);
}

std::vector<double> PoseGraph2D::GraphDistances(const std::vector<int>& from) const {
  const int n = submap_count();
  std::vector<Eigen::Vector2d> origin(static_cast<std::size_t>(n));
  for (int j = 0; j < n; ++j) origin[static_cast<std::size_t>(j)] = SubmapPose(j).translation();
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

double PoseGraph2D::Angle(double distance) const {
  const double base = options_.search.angular_search_window;
  if (!(options_.search_angle_growth > 0)) return base;
  return std::max(base, std::min(options_.max_search_angle, base + options_.search_angle_growth * distance));
}

double PoseGraph2D::Window(double distance) const {
  const double base = options_.search.linear_search_window;
  if (!(options_.search_window_growth > 0)) return base;
  return std::max(base, std::min(options_.max_search_window, base + options_.search_window_growth * distance));
}

void PoseGraph2D::StartSearch(int scan, int submap, double window, double angle) {
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
  s->guess = s->submap_local * (SubmapPose(submap).Inverse() * ScanPose(scan));
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

void PoseGraph2D::RunSearch(Search* s) const {
  const auto t0 = std::chrono::steady_clock::now();
  // A search that throws (a degenerate scan) finds nothing; on a worker thread an exception
  // would end the program.
  try {
    std::call_once(s->matcher->once, [&] {
      s->matcher->matcher = std::make_unique<FastCorrelativeScanMatcher2D>(*s->grid, options_.search);
    });
    const FastMatch m =
        s->matcher->matcher->MatchChecked(s->guess, *s->search_points, options_.min_score, options_.rival_distance,
                                          options_.rival_angle, options_.rival_ratio, s->window, s->angle);
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

void PoseGraph2D::Worker() {
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

// Waits for every search started so far and applies them all, in the order they were started
// (never a part: that would depend on the threads' timing).
bool PoseGraph2D::ApplyFinishedSearches() {
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
  bool added = false;
  for (const std::unique_ptr<Search>& s : done) {
    ++stats_.searches;
    stats_.search_seconds += s->seconds;
    if (s->ambiguous) ++stats_.ambiguous;
    if (s->on_edge) ++stats_.on_edge;
    if (!s->found) continue;
    ++stats_.found;
    stats_.found_seconds += s->seconds;
    const int c = static_cast<int>(candidates_.size());
    candidates_.push_back(Candidate{s->result, false});
    std::vector<int>& same_submap = candidates_of_submap_[s->result.submap];
    if (!(options_.confirm_translation > 0)) {
      AddClosure(c);
    } else {
      // Confirmed by an earlier candidate that agrees with it: both are added.
      for (int other : same_submap) {
        if (!Agree(candidates_[static_cast<std::size_t>(c)].closure,
                   candidates_[static_cast<std::size_t>(other)].closure)) {
          continue;
        }
        if (!candidates_[static_cast<std::size_t>(c)].added) AddClosure(c);
        if (!candidates_[static_cast<std::size_t>(other)].added) AddClosure(other);
      }
    }
    same_submap.push_back(c);
    added = added || candidates_[static_cast<std::size_t>(c)].added;
  }
  stats_.unconfirmed = stats_.found - static_cast<long>(closures_.size());
  return added;
}

bool PoseGraph2D::Agree(const LoopClosure& a, const LoopClosure& b) const {
  if (a.submap != b.submap || a.scan == b.scan || std::abs(a.scan - b.scan) > options_.confirm_max_scans) return false;
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

void PoseGraph2D::AddClosure(int candidate) {
  Candidate& c = candidates_[static_cast<std::size_t>(candidate)];
  c.added = true;
  const LoopClosure& l = c.closure;
  closures_.push_back(l);
  for (int m : scans_[static_cast<std::size_t>(l.scan)].submaps) Link(m, l.submap);
  BetweenSE2& f = pending_graph_.Add<BetweenSE2>(SubmapKey(l.submap), ScanKey(l.scan), l.relative,
                                                 Noise(options_.loop_translation_sigma, options_.loop_rotation_sigma));
  f.set_loss(std::make_shared<HuberLoss>(options_.huber_delta));
  f.set_loop_closure(true);
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
  ApplyFinishedSearches();
  Flush();
  const auto t0 = std::chrono::steady_clock::now();
  smoother_.Finish();
  stats_.finish_seconds = SecondsSince(t0);
  stats_.optimize_seconds += stats_.finish_seconds;
}

}  // namespace lidar
}  // namespace tether
