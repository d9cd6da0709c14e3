#include "tether/frontends/lidar/lidar_slam_2d.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>
#include <utility>

#include "tether/core/error.h"
#include "tether/core/graph_io.h"
#include "tether/core/registry.h"
#include "tether/core/timing.h"
#include "tether/factors/between_se2.h"
#include "tether/factors/builtin.h"
#include "tether/frontends/lidar/eval/kidnap_report.h"
#include "tether/frontends/lidar/io/occupancy_map.h"
#include "tether/frontends/lidar/io/tum_trajectory.h"
#include "tether/frontends/lidar/mapping/probability_grid_inserter.h"

namespace tether {
namespace lidar {

namespace {

std::string Fixed(double v, int digits) { return FormatFixed(v, digits); }

std::string Percent(long part, long whole) {
  return whole == 0 ? std::string("-") : Fixed(100.0 * static_cast<double>(part) / static_cast<double>(whole), 2) + "%";
}

// The poses chained by their relative poses (unit information): scan i is vertex i.
void ChainGraph(const std::vector<StampedPose2>& t, FactorGraph* graph, Values* values) {
  for (std::size_t i = 0; i < t.size(); ++i) {
    values->Insert(static_cast<Key>(i), t[i].pose);
    if (i > 0) {
      graph->Add<BetweenSE2>(static_cast<Key>(i - 1), static_cast<Key>(i), t[i - 1].pose.Inverse() * t[i].pose,
                             SqrtInformation::FromSigmas(Eigen::Vector3d::Ones()));
    }
  }
}

const LidarSlamOptions& Checked(const LidarSlamOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("LidarSlamOptions: " + why);
  return options;
}

}  // namespace

bool LidarSlamOptions::IsValid(std::string* why) const {
  std::string inner;
  const auto fail = [why](const std::string& what) {
    if (why != nullptr) *why = what;
    return false;
  };
  if (!local.IsValid(&inner)) return fail("local matching: " + inner);
  if (!pose_graph.IsValid(&inner)) return fail("pose graph: " + inner);
  if (!self_check.IsValid(&inner)) return fail("self-check: " + inner);
  if (!mask.IsValid(&inner)) return fail("body mask: " + inner);
  if (!(std::isfinite(kept_translation) && kept_translation > 0 && std::isfinite(kept_rotation_deg) &&
        kept_rotation_deg > 0)) {
    return fail("kept_translation and kept_rotation_deg must be finite and positive");
  }
  return true;
}

std::string LidarSlamReport::KidnapSummary() const {
  std::ostringstream out;
  long kidnaps = 0;
  for (std::size_t t = 1; t < trajectories.size(); ++t) {
    const TrajectoryReport& r = trajectories[t];
    kidnaps += !r.session;
    out << (r.session ? "a new session (the log after the saved state) at scan " : "kidnap detected at scan ")
        << r.first_scan + 1 << " (t = " << Fixed(r.first_stamp - first_stamp, 2) << " s): trajectory " << t
        << " starts there; ";
    if (r.joined_scan >= 0) {
      out << "joined the map at scan " << r.joined_scan + 1 << " (" << r.joined_scan - r.first_scan << " scans, "
          << Fixed(r.joined_stamp - r.first_stamp, 1) << " s after " << (r.session ? "its start" : "the kidnap")
          << ")\n";
    } else {
      out << "never joined the map: placed beside it\n";
    }
  }
  if (kidnaps == 0) {
    out << "no kidnap detected (the filtered match cost rose at most " << Fixed(max_kidnap_ratio, 3) << " times";
    if (max_kidnap_ratio_scan >= 0) out << ", at scan " << max_kidnap_ratio_scan + 1;
    out << "; threshold " << Fixed(kidnap_threshold, 3) << ")\n";
  }
  const auto list = [&out](const std::vector<long>& scans) {
    for (std::size_t i = 0; i < scans.size() && i < 8; ++i) out << (i > 0 ? ", " : " ") << scans[i] + 1;
    if (scans.size() > 8) out << ", ...";
  };
  if (!relocations.empty()) {
    out << "  lost and found again in the current submap near the last pose (no kidnap) at " << relocations.size()
        << " scan" << (relocations.size() == 1 ? "" : "s");
    list(relocations);
    out << "\n";
  }
  out << "  the two signals alone: the cost rule (Algorithm 13) at " << cost_rises.size() << " scan"
      << (cost_rises.size() == 1 ? "" : "s");
  list(cost_rises);
  out << "; a break with the scan before (under " << Fixed(100 * max_overlap, 0) << "% of its points near) at "
      << breaks.size() << " scan" << (breaks.size() == 1 ? "" : "s");
  list(breaks);
  out << "\n";
  return out.str();
}

std::string LidarSlamReport::Summary(int threads) const {
  std::ostringstream out;
  const long n = std::max(scans, 1L);
  out << "scans " << scans << ", submaps " << submaps << ", loop closures " << loop_closures << " of " << graph.searches
      << " searches (" << graph.ambiguous << " ambiguous, " << graph.on_edge << " on the window's edge dropped, "
      << graph.unconfirmed << " unconfirmed by a second match); kept by the "
      << "solution " << Percent(closures_kept, loop_closures) << " (" << closures_kept
      << " within 20 cm and 1 degree of the final poses: agreement, not accuracy)\n";
  out << "self-check: " << self_check.judged.size() << " of " << self_check.sampled
      << " sampled scans overlap the map made at other times, "
      << Percent(self_check.fitting, static_cast<long>(self_check.judged.size())) << " of them fit it";
  if (self_check.stretches.empty()) {
    out << "; no misplaced stretch\n";
  } else {
    out << "; " << self_check.stretches.size() << " misplaced stretch" << (self_check.stretches.size() > 1 ? "es" : "")
        << ":";
    for (const MisfitStretch& s : self_check.stretches) {
      out << " scans " << s.first_scan + 1 << "-" << s.last_scan + 1 << " (" << s.samples << " samples)";
    }
    out << "\n";
  }
  out << KidnapSummary();
  out << "time " << Fixed(total_seconds, 2) << " s for " << Fixed(logged_seconds, 1) << " s of log: real-time factor "
      << Fixed(logged_seconds / std::max(total_seconds, 1e-9), 1) << "\n"
      << "  local matching " << Fixed(1e3 * matching_seconds / static_cast<double>(n), 3) << " ms per scan, insertion "
      << Fixed(1e3 * insert_seconds / static_cast<double>(n), 3) << " ms per scan; ";
  if (scan_only > 0) {
    out << scan_only << " scans without odometry: " << scan_to_scan
        << " predicted by scan-to-scan matching, the others by constant velocity (" << widened
        << " searched again wider)";
    if (imu_turns > 0) out << ", " << imu_turns << " turned by the IMU";
    out << "; ";
  }
  out << untrusted << " scans below the match probability took the prediction";
  if (untrusted_scan_only > 0) out << " (" << untrusted_scan_only << " of them without odometry)";
  if (masked_beams > 0) {
    out << "; the body mask made " << masked_beams << " returns no return ("
        << Fixed(static_cast<double>(masked_beams) / static_cast<double>(n), 1) << " per scan)";
  }
  out << "\n"
      << "  branch and bound "
      << Fixed(graph.searches > 0 ? 1e3 * graph.search_seconds / static_cast<double>(graph.searches) : 0, 2)
      << " ms per search, "
      << Fixed(graph.found > 0 ? 1e3 * graph.search_seconds / static_cast<double>(graph.found) : 0, 2)
      << " ms per constraint found (" << threads << " search threads; waited " << Fixed(graph.wait_seconds, 2)
      << " s)\n"
      << "  optimisation " << Fixed(graph.optimize_seconds, 2) << " s (" << graph.updates
      << " smoother updates; the final solve " << Fixed(graph.finish_seconds, 2) << " s), pose graph in all "
      << Fixed(graph_seconds, 2) << " s, map " << Fixed(map_seconds, 2) << " s, self-check " << Fixed(check_seconds, 2)
      << " s\n";
  return out.str();
}

LidarSlam2D::LidarSlam2D(const LidarSlamOptions& options)
    : options_(Checked(options)),
      local_(std::make_unique<LocalSlam2D>(options_.local)),
      graph_(std::make_unique<PoseGraph2D>(options_.pose_graph)) {
  report_.kidnap_threshold = options_.local.kidnap.threshold;
  report_.max_overlap = options_.local.kidnap.max_overlap;
}

LidarSlam2D::~LidarSlam2D() = default;

namespace {

// The kidnap record of a scan's local result.
KidnapRecord RecordOf(const LocalScanResult& r) {
  KidnapRecord k;
  k.matched = r.matched;
  k.cost = r.match_cost;
  k.filtered = r.kidnap.filtered;
  k.ratio = r.kidnap.ratio;
  k.hit_fraction = r.hit_fraction;
  k.overlap = r.overlap;
  k.cost_rule = r.kidnap.cost_rule;
  k.broke = r.kidnap.broke;
  k.detected = r.kidnap.detected;
  k.relocated = r.kidnap.relocated;
  return k;
}

}  // namespace

void LidarSlam2D::AddScan(const LaserScan& scan) {
  if (finished_) throw InvalidArgument("LidarSlam2D::AddScan after Finish(): make a new LidarSlam2D for another run");
  if (!failed_.empty()) {
    throw InvalidArgument("LidarSlam2D::AddScan: scan " + std::to_string(added_) + " failed part-way (" + failed_ +
                          "); make a new LidarSlam2D for another run");
  }
  const std::string why = ScanProblem(scan);
  if (!why.empty()) throw InvalidArgument("LidarSlam2D::AddScan: scan " + std::to_string(added_) + ": " + why);
  const auto t0 = std::chrono::steady_clock::now();
  Staged st;
  st.scan = scan;
  // The robot's body masked.
  if (!options_.mask.empty()) report_.masked_beams += static_cast<long>(ApplyBodyMask(options_.mask, &st.scan));
  if (added_ == 0) {
    report_.first_stamp = scan.stamp;
    report_.trajectories.push_back(TrajectoryReport{0, scan.stamp, 0, scan.stamp});
  } else if (continued_) {
    continued_ = false;
    report_.trajectories.push_back(TrajectoryReport{added_, scan.stamp, -1, 0, true});
  }
  try {
    st.result = local_->AddScan(st.scan);
    st.record = RecordOf(st.result);
    if (st.result.kidnapped) Restart(&st);
    st.record.scan = added_;
    st.record.stamp = scan.stamp;
    st.record.trajectory = static_cast<int>(report_.trajectories.size()) - 1;
    ++added_;
    staged_.push_back(std::move(st));
    // The last filter_size - 1 scans wait: a kidnap declared at the next scans began at them.
    const std::size_t lag =
        options_.local.kidnap.detect ? static_cast<std::size_t>(options_.local.kidnap.filter_size - 1) : 0;
    while (staged_.size() > lag) Commit();
  } catch (const std::exception& e) {
    failed_ = e.what();
    throw;
  }
  report_.total_seconds += SecondsSince(t0);
}

void LidarSlam2D::Continue(const LidarState& state) {
  if (added_ > 0 || finished_) throw InvalidArgument("LidarSlam2D::Continue: before the first scan only");
  graph_->Restore(state);
  if (state.scans.empty()) return;
  for (const SavedScan& s : state.scans) {
    ScanRecord record;
    record.stamp = s.stamp;
    record.laser_in_robot = s.laser_in_robot;
    record.points = s.points;
    scans_.push_back(std::move(record));
    KidnapRecord k;
    k.scan = added_++;
    k.stamp = s.stamp;
    kidnap_records_.push_back(k);
  }
  report_.first_stamp = state.scans.front().stamp;
  report_.trajectories.push_back(TrajectoryReport{0, report_.first_stamp, 0, report_.first_stamp});
  continued_ = true;
}

void LidarSlam2D::Restart(Staged* st) {
  // The kidnap began at the scan that opened the detector's window: the scans from there on
  // (still staged) go to the new trajectory with the detecting one.
  const std::size_t redo = std::min(staged_.size(), static_cast<std::size_t>(options_.local.kidnap.filter_size - 1));
  while (staged_.size() > redo) Commit();
  graph_->StartTrajectory(local_->FinishTrajectory());
  local_ = std::make_unique<LocalSlam2D>(options_.local);
  const int t = static_cast<int>(report_.trajectories.size());
  report_.trajectories.push_back(TrajectoryReport{added_ - static_cast<long>(redo),
                                                  redo > 0 ? staged_.front().scan.stamp : st->scan.stamp, -1, 0});
  for (Staged& s : staged_) {
    s.result = local_->AddScan(s.scan);
    s.record.trajectory = t;
  }
  st->result = local_->AddScan(st->scan);
}

void LidarSlam2D::Commit() {
  Staged& s = staged_.front();
  const LocalScanResult& r = s.result;
  report_.matching_seconds += r.scan_to_scan_seconds + r.correlative_seconds + r.refine_seconds;
  report_.scan_to_scan += r.scan_to_scan;
  report_.insert_seconds += r.insert_seconds;
  report_.untrusted += r.matched && !r.trusted;
  report_.untrusted_scan_only += r.matched && !r.trusted && r.scan_only;
  report_.scan_only += r.scan_only;
  report_.widened += r.widened;
  report_.imu_turns += r.imu_turn;
  const auto tg = std::chrono::steady_clock::now();
  graph_->AddScan(r.pose, std::move(s.result.matching), r.inserted_into);
  report_.graph_seconds += SecondsSince(tg);
  NoteJoins(s.scan.stamp);
  const KidnapRecord& k = s.record;
  if (k.broke) report_.breaks.push_back(k.scan);
  if (k.relocated) report_.relocations.push_back(k.scan);
  if (k.cost_rule && (kidnap_records_.empty() || !kidnap_records_.back().cost_rule)) {
    report_.cost_rises.push_back(k.scan);
  }
  if (k.ratio > report_.max_kidnap_ratio) {
    report_.max_kidnap_ratio = k.ratio;
    report_.max_kidnap_ratio_scan = k.scan;
  }
  kidnap_records_.push_back(k);
  ScanRecord record;
  record.stamp = s.scan.stamp;
  record.laser_in_robot = s.scan.laser_in_robot;
  record.points = ScanToPoints(s.scan, options_.local.limits);
  scans_.push_back(std::move(record));
  staged_.pop_front();
}

void LidarSlam2D::NoteJoins(double stamp) {
  for (std::size_t t = 1; t < report_.trajectories.size(); ++t) {
    TrajectoryReport& r = report_.trajectories[t];
    const int at = graph_->TrajectoryJoinedAt(static_cast<int>(t));
    if (r.joined_scan >= 0 || at < 0) continue;
    r.joined_scan = at - 1;
    r.joined_stamp = stamp;
  }
}

void LidarSlam2D::Run(const LidarLog& log, long max_scans, long progress_every,
                      const std::function<void(long)>& progress) {
  ForEachScan(
      log, max_scans, [this](const LaserScan& scan) { AddScan(scan); }, progress_every, progress);
  try {
    Finish();
  } catch (const Error& e) {
    throw ParseError(log.path + ": after the last scan: " + e.what());
  }
}

void LidarSlam2D::Finish() {
  if (finished_) return;
  finished_ = true;
  const auto t0 = std::chrono::steady_clock::now();
  try {
    while (!staged_.empty()) Commit();
  } catch (const std::exception& e) {
    failed_ = e.what();
    throw;
  }
  graph_->Finish();
  if (!scans_.empty()) NoteJoins(scans_.back().stamp);
  report_.graph_seconds += SecondsSince(t0);
  const std::vector<StampedPose2> trajectory = Trajectory();

  // The map: every scan at its final pose.
  const auto tm = std::chrono::steady_clock::now();
  map_ = std::make_shared<ProbabilityGrid>(options_.local.submaps.resolution);
  const ProbabilityGridInserter inserter(options_.local.submaps.insert, map_->min_probability(),
                                         map_->max_probability());
  std::vector<SE2d> lasers(scans_.size());
  std::vector<const std::vector<Eigen::Vector2d>*> points(scans_.size());
  std::vector<Eigen::Vector2d> hits;
  for (std::size_t i = 0; i < scans_.size(); ++i) {
    lasers[i] = trajectory[i].pose * scans_[i].laser_in_robot;
    points[i] = &scans_[i].points;
    hits = scans_[i].points;
    for (Eigen::Vector2d& p : hits) p = lasers[i] * p;
    inserter.Insert(map_.get(), lasers[i].translation(), hits);
  }
  report_.map_seconds = SecondsSince(tm);

  // The loop closures against the final poses.
  for (const LoopClosure& c : graph_->loop_closures()) {
    LoopClosureCheck check;
    check.closure = c;
    check.solved = graph_->SubmapPose(c.submap).Inverse() * graph_->ScanPose(c.scan);
    check.translation_violation = (check.solved.translation() - c.relative.translation()).norm();
    check.rotation_violation_deg = std::abs(WrapAngle(check.solved.theta() - c.relative.theta())) * 180 / M_PI;
    check.kept = check.translation_violation < options_.kept_translation &&
                 check.rotation_violation_deg < options_.kept_rotation_deg;
    report_.closures_kept += check.kept ? 1 : 0;
    checks_.push_back(check);
  }
  const auto tc = std::chrono::steady_clock::now();
  report_.self_check = CheckSelfConsistency(lasers, points, options_.self_check);
  report_.check_seconds = SecondsSince(tc);

  report_.scans = static_cast<long>(scans_.size());
  report_.submaps = graph_->submap_count();
  report_.loop_closures = static_cast<long>(graph_->loop_closures().size());
  report_.graph = graph_->stats();
  report_.logged_seconds = scans_.empty() ? 0 : scans_.back().stamp - scans_.front().stamp;
  report_.total_seconds += SecondsSince(t0);
}

std::vector<StampedPose2> LidarSlam2D::Trajectory() const {
  std::vector<StampedPose2> t;
  t.reserve(scans_.size());
  for (std::size_t i = 0; i < scans_.size(); ++i) {
    t.push_back(StampedPose2{scans_[i].stamp, graph_->ScanPose(static_cast<int>(i))});
  }
  return t;
}

void LidarSlam2D::TrajectoryGraph(FactorGraph* graph, Values* values) const { ChainGraph(Trajectory(), graph, values); }

const ProbabilityGrid& LidarSlam2D::map() const {
  if (map_ == nullptr) throw InvalidArgument("LidarSlam2D::map: the map is built by Finish(); call it first");
  return *map_;
}

std::vector<LidarOutput> LidarSlam2D::OutputNames() {
  return {{"trajectory.tum", "trajectory", ""},          {"trajectory.g2o", "trajectory (g2o)", ""},
          {"pose_graph.g2o", "pose graph", ""},          {"map.pgm", "map image", ""},
          {"map.yaml", "map description", ""},           {"map.png", "map picture", ""},
          {"loop_closures.txt", "loop closures", ""},    {"self_check.png", "self-check picture", ""},
          {"trajectory.csv", "trajectory with ids", ""}, {"kidnap.csv", "kidnap signals", ""},
          {"kidnap.svg", "kidnap picture", ""}};
}

LidarState LidarSlam2D::State() const {
  if (!finished_) throw InvalidArgument("LidarSlam2D::State: call Finish() first");
  const PoseGraph2D& g = *graph_;
  LidarState state;
  state.trajectories = g.trajectory_count();
  state.scans.resize(scans_.size());
  for (std::size_t i = 0; i < scans_.size(); ++i) {
    const int k = static_cast<int>(i);
    SavedScan& s = state.scans[i];
    s.stamp = scans_[i].stamp;
    s.trajectory = g.ScanTrajectory(k);
    s.pose = g.ScanPose(k);
    s.local_pose = g.LocalPose(k);
    s.laser_in_robot = scans_[i].laser_in_robot;
    s.submaps = g.ScanSubmaps(k);
    s.points = scans_[i].points;
  }
  state.submaps.resize(static_cast<std::size_t>(g.submap_count()));
  for (int j = 0; j < g.submap_count(); ++j) {
    SavedSubmap& m = state.submaps[static_cast<std::size_t>(j)];
    m.trajectory = g.SubmapTrajectory(j);
    m.pose = g.SubmapPose(j);
    m.local_pose = g.submap(j)->local_pose();
    m.num_scans = g.submap(j)->num_scans();
    m.grid = g.submap(j)->grid();
  }
  for (const LoopClosure& c : g.loop_closures()) {
    state.closures.push_back(SavedClosure{c.scan, c.submap, c.relative, c.score});
  }
  state.map = map_;
  return state;
}

LidarOutput LidarSlam2D::StateOutput() const {
  LidarOutput o = StateOutputName();
  o.bytes = LidarStateBytes(State());
  return o;
}

std::vector<LidarOutput> LidarSlam2D::Outputs() const {
  if (!finished_) throw InvalidArgument("LidarSlam2D::Outputs: call Finish() first");
  std::vector<LidarOutput> out = OutputNames();
  const auto set = [&out](const char* name, std::string bytes) {
    for (LidarOutput& o : out) {
      if (o.name == name) o.bytes = std::move(bytes);
    }
  };
  const std::vector<StampedPose2> t = Trajectory();
  std::ostringstream s;
  WriteTum(s, t);
  set("trajectory.tum", s.str());
  {
    FactorGraph chain;
    Values poses;
    ChainGraph(t, &chain, &poses);
    std::ostringstream g;
    WriteG2o(g, poses, chain, DefaultRegistry());
    set("trajectory.g2o", g.str());
  }
  {
    FactorGraph exported;
    Values values;
    graph_->Export(&exported, &values);
    std::ostringstream g;
    WriteG2o(g, values, exported, DefaultRegistry());
    set("pose_graph.g2o", g.str());
  }
  const OccupancyImage image = RenderOccupancy(*map_);
  set("map.pgm", PgmBytes(image));
  set("map.yaml", MapYaml(image, "map.pgm"));
  set("map.png", PngBytes(image));
  {
    std::ostringstream c;
    c.precision(9);
    c << "# scan submap score measured_x measured_y measured_theta solved_x solved_y solved_theta "
         "translation_violation_m rotation_violation_deg kept\n";
    for (const LoopClosureCheck& k : checks_) {
      c << k.closure.scan << ' ' << k.closure.submap << ' ' << k.closure.score << ' ' << k.closure.relative.x() << ' '
        << k.closure.relative.y() << ' ' << k.closure.relative.theta() << ' ' << k.solved.x() << ' ' << k.solved.y()
        << ' ' << k.solved.theta() << ' ' << k.translation_violation << ' ' << k.rotation_violation_deg << ' '
        << (k.kept ? 1 : 0) << '\n';
    }
    set("loop_closures.txt", c.str());
  }
  {
    std::ostringstream c;
    c.precision(17);
    c << "# scan stamp trajectory x y theta\n";
    for (std::size_t i = 0; i < t.size(); ++i) {
      c << i + 1 << ' ' << t[i].stamp << ' ' << kidnap_records_[i].trajectory << ' ' << t[i].pose.x() << ' '
        << t[i].pose.y() << ' ' << t[i].pose.theta() << '\n';
    }
    set("trajectory.csv", c.str());
  }
  set("kidnap.csv", KidnapCsv(kidnap_records_, report_.first_stamp));
  set("kidnap.svg", KidnapSvg(kidnap_records_, options_.local.kidnap));
  // The self-check picture: the map in grey, each judged sample's points green where the scan
  // fits the map made at other times and red where it does not.
  {
    std::vector<std::uint8_t> rgb(3 * image.pixels.size());
    for (std::size_t i = 0; i < image.pixels.size(); ++i)
      rgb[3 * i] = rgb[3 * i + 1] = rgb[3 * i + 2] = image.pixels[i];
    for (const ScanFit& f : report_.self_check.judged) {
      const std::size_t i = static_cast<std::size_t>(f.scan);
      const SE2d laser = t[i].pose * scans_[i].laser_in_robot;
      for (const Eigen::Vector2d& p : scans_[i].points) {
        const Eigen::Vector2d q = laser * p;
        const int column = static_cast<int>(std::floor((q.x() - image.origin.x()) / image.resolution));
        const int row = image.height - 1 - static_cast<int>(std::floor((q.y() - image.origin.y()) / image.resolution));
        if (column < 0 || row < 0 || column >= image.width || row >= image.height) continue;
        const std::size_t k = 3 * (static_cast<std::size_t>(row) * static_cast<std::size_t>(image.width) +
                                   static_cast<std::size_t>(column));
        rgb[k] = f.fits ? 0 : 230;
        rgb[k + 1] = f.fits ? 170 : 0;
        rgb[k + 2] = 0;
      }
    }
    set("self_check.png", PngBytesRgb(image.width, image.height, rgb));
  }
  return out;
}

}  // namespace lidar
}  // namespace tether
