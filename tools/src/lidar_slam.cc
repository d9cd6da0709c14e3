#include "tether/tools/lidar_slam.h"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <ostream>
#include <sstream>
#include <utility>

#include "tether/core/error.h"
#include "tether/core/graph_io.h"
#include "tether/core/output_file.h"
#include "tether/factors/between_se2.h"
#include "tether/factors/builtin.h"
#include "tether/frontends/lidar/lidar_log.h"
#include "tether/frontends/lidar/local_slam_2d.h"
#include "tether/frontends/lidar/occupancy_map.h"
#include "tether/frontends/lidar/pose_graph_2d.h"
#include "tether/frontends/lidar/tum_trajectory.h"
#include "tether/tools/commands.h"

namespace tether {

namespace {

double SecondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

std::string Fixed(double v, int digits) {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(digits);
  s << v;
  return s.str();
}

void SetPoseGraph(const LidarCommand& cmd, lidar::PoseGraphOptions* po) {
  po->local_translation_sigma = cmd.local_translation_sigma;
  po->local_rotation_sigma = cmd.local_rotation_sigma;
  po->consecutive_translation_sigma = cmd.consecutive_translation_sigma;
  po->consecutive_rotation_sigma = cmd.consecutive_rotation_sigma;
  po->local_huber_delta = cmd.local_huber_delta;
  po->loop_translation_sigma = cmd.loop_translation_sigma;
  po->loop_rotation_sigma = cmd.loop_rotation_sigma;
  po->huber_delta = cmd.huber_delta;
  po->rival_ratio = cmd.rival_ratio;
  po->max_search_distance = cmd.max_search_distance;
  po->search.linear_search_window = cmd.search_window;
  po->search_window_growth = cmd.search_window_growth;
  po->max_search_window = cmd.max_search_window;
  po->search_voxel_size = cmd.search_voxel_size;
  po->search.angular_search_window = cmd.search_angle_deg * M_PI / 180;
  po->update_every_n_scans = cmd.update_every;
  po->confirm_translation = cmd.confirm_translation;
  po->confirm_rotation = cmd.confirm_rotation;
}

void SetLocalMatching(const LidarCommand& cmd, lidar::LocalSlamOptions* lo) {
  lo->refiner.weights.translation = cmd.match_translation_weight;
  lo->refiner.weights.rotation = cmd.match_rotation_weight;
  lo->correlative.translation_delta_cost_weight = cmd.correlative_translation_weight;
  lo->correlative.rotation_delta_cost_weight = cmd.correlative_rotation_weight;
  lo->correlative.angular_search_window = cmd.correlative_angle_deg * M_PI / 180;
  lo->min_match_probability = cmd.min_match_probability;
  lo->still_distance = cmd.still_distance;
  lo->still_angle = cmd.still_angle;
}

}  // namespace

int RunLidar(const LidarCommand& cmd, std::ostream& out, std::ostream& err) {
  if (cmd.threads < 0 || cmd.max_scans < 0 || cmd.scans_per_submap < 2 || cmd.search_every < 1 ||
      !(cmd.resolution > 0) || !(cmd.min_score >= 0 && cmd.min_score < 1) || !(cmd.max_range >= 0)) {
    err << "tether lidar: --threads and --max-scans must not be negative, --scans-per-submap at least 2, "
           "--search-every at least 1, --resolution positive, --min-score in [0, 1), --max-range not negative\n";
    return kExitUsage;
  }
  {
    lidar::PoseGraphOptions po;
    SetPoseGraph(cmd, &po);
    std::string why;
    if (!po.IsValid(&why)) {
      err << "tether lidar: " << why << "\n";
      return kExitUsage;
    }
    lidar::LocalSlamOptions lo;
    SetLocalMatching(cmd, &lo);
    if (!lo.IsValid(&why)) {
      err << "tether lidar: local matching: " << why << "\n";
      return kExitUsage;
    }
  }
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(cmd.output_dir, ec);
  if (ec || !fs::is_directory(cmd.output_dir)) {
    err << "tether lidar: cannot make the output folder '" << cmd.output_dir << "' (" << ec.message()
        << "); give a folder that can be written\n";
    return kExitWriteFailed;
  }
  const auto in_dir = [&](const char* name) { return (fs::path(cmd.output_dir) / name).string(); };
  OutputSet outputs;
  OutputFile *tum = nullptr, *traj = nullptr, *graph_file = nullptr, *pgm = nullptr, *yaml = nullptr, *png = nullptr,
             *closures_file = nullptr;
  const int rc = CheckOutputs(
      "lidar", outputs,
      [&] {
        outputs.AddInput(cmd.log);
        tum = &outputs.Add(in_dir("trajectory.tum"), "trajectory");
        traj = &outputs.Add(in_dir("trajectory.g2o"), "trajectory (g2o)");
        graph_file = &outputs.Add(in_dir("pose_graph.g2o"), "pose graph");
        pgm = &outputs.Add(in_dir("map.pgm"), "map image");
        yaml = &outputs.Add(in_dir("map.yaml"), "map description");
        png = &outputs.Add(in_dir("map.png"), "map picture");
        closures_file = &outputs.Add(in_dir("loop_closures.txt"), "loop closures");
      },
      err);
  if (rc != 0) return rc;

  lidar::LidarReadOptions ro;
  ro.scan_topic = cmd.scan_topic;
  ro.odom_topic = cmd.odom_topic;
  ro.limits.max_range = cmd.max_range;
  lidar::LidarLog log;
  try {
    log = lidar::ReadLidarLog(cmd.log, ro);
  } catch (const IoError& e) {
    err << "error: " << e.what() << "\n";
    return kExitBadInput;
  } catch (const ParseError& e) {
    err << "error: " << e.what() << "\n";
    return kExitBadInput;
  }
  const std::size_t n =
      cmd.max_scans > 0 ? std::min(log.scans.size(), static_cast<std::size_t>(cmd.max_scans)) : log.scans.size();
  if (n == 0) {
    err << "error: " << cmd.log << " has no scans\n";
    return kExitBadInput;
  }

  lidar::LocalSlamOptions lo;
  lo.submaps.resolution = cmd.resolution;
  lo.submaps.scans_per_submap = cmd.scans_per_submap;
  lo.limits = ro.limits;
  SetLocalMatching(cmd, &lo);
  lidar::PoseGraphOptions po;
  po.loop_closure = cmd.loop_closure;
  po.threads = cmd.threads;
  po.search_every_n_scans = cmd.search_every;
  po.min_score = cmd.min_score;
  SetPoseGraph(cmd, &po);
  lidar::LocalSlam2D local(lo);
  lidar::PoseGraph2D graph(po);
  const auto t0 = std::chrono::steady_clock::now();
  double matching_seconds = 0, insert_seconds = 0, graph_seconds = 0;
  long untrusted = 0;  // matched scans whose match fell below min_match_probability
  for (std::size_t i = 0; i < n; ++i) {
    const lidar::LaserScan& scan = log.scans[i];
    lidar::LocalScanResult r = local.AddScan(scan);
    matching_seconds += r.correlative_seconds + r.refine_seconds;
    untrusted += r.matched && !r.trusted;
    insert_seconds += r.insert_seconds;
    const auto tg = std::chrono::steady_clock::now();
    graph.AddScan(r.pose, std::move(r.matching), r.inserted_into);
    graph_seconds += SecondsSince(tg);
    if (!cmd.quiet && cmd.progress_every > 0 && (i + 1) % static_cast<std::size_t>(cmd.progress_every) == 0) {
      const double logged = log.scans[i].stamp - log.scans[0].stamp;
      out << "scans " << i + 1 << " of " << n << ", submaps " << graph.submap_count() << ", loop closures "
          << graph.loop_closures().size() << " (searches " << graph.stats().searches << "), real-time factor "
          << Fixed(logged / std::max(SecondsSince(t0), 1e-9), 1) << "\n";
    }
  }
  const auto tf = std::chrono::steady_clock::now();
  graph.Finish();
  graph_seconds += SecondsSince(tf);
  const double total = SecondsSince(t0);

  // Outputs: the trajectory, the graph, the map with every scan at its final pose.
  // The trajectory as g2o: the poses chained by their relative poses (unit information), so
  // that it reads back as one connected graph.
  std::vector<lidar::StampedPose2> trajectory;
  Values poses;
  FactorGraph chain;
  for (std::size_t i = 0; i < n; ++i) {
    trajectory.push_back(lidar::StampedPose2{log.scans[i].stamp, graph.ScanPose(static_cast<int>(i))});
    poses.Insert(static_cast<Key>(i), trajectory.back().pose);
    if (i > 0) {
      chain.Add<BetweenSE2>(static_cast<Key>(i - 1), static_cast<Key>(i),
                            trajectory[i - 1].pose.Inverse() * trajectory[i].pose,
                            SqrtInformation::FromSigmas(Eigen::Vector3d::Ones()));
    }
  }
  FactorGraph exported;
  Values exported_values;
  graph.Export(&exported, &exported_values);
  ProbabilityGrid map(cmd.resolution);
  const lidar::ProbabilityGridInserter inserter(lo.submaps.insert, map.min_probability(), map.max_probability());
  const auto tm = std::chrono::steady_clock::now();
  for (std::size_t i = 0; i < n; ++i) {
    const lidar::LaserScan& scan = log.scans[i];
    const SE2d laser = trajectory[i].pose * scan.laser_in_robot;
    std::vector<Eigen::Vector2d> hits = lidar::ScanToPoints(scan, ro.limits);
    for (Eigen::Vector2d& p : hits) p = laser * p;
    inserter.Insert(&map, laser.translation(), hits);
  }
  const double map_seconds = SecondsSince(tm);
  // Loop-closure precision: a closure is kept when the final solution violates it by less than
  // 20 cm and 1 degree. Every closure, with its violation, goes to loop_closures.txt.
  std::size_t kept = 0;
  std::ostringstream closures;
  closures.precision(9);
  closures << "# scan submap score measured_x measured_y measured_theta solved_x solved_y solved_theta "
              "translation_violation_m rotation_violation_deg kept\n";
  for (const lidar::LoopClosure& c : graph.loop_closures()) {
    const SE2d solved = graph.SubmapPose(c.submap).Inverse() * graph.ScanPose(c.scan);
    const double dt = (solved.translation() - c.relative.translation()).norm();
    const double dr = std::abs(WrapAngle(solved.theta() - c.relative.theta())) * 180 / M_PI;
    const bool ok = dt < 0.2 && dr < 1;
    kept += ok ? 1 : 0;
    closures << c.scan << ' ' << c.submap << ' ' << c.score << ' ' << c.relative.x() << ' ' << c.relative.y() << ' '
             << c.relative.theta() << ' ' << solved.x() << ' ' << solved.y() << ' ' << solved.theta() << ' ' << dt
             << ' ' << dr << ' ' << (ok ? 1 : 0) << '\n';
  }
  try {
    closures_file->Stage([&](std::ostream& s) { s << closures.str(); });
    tum->Stage([&](std::ostream& s) { lidar::WriteTum(s, trajectory); });
    traj->Stage([&](std::ostream& s) { WriteG2o(s, poses, chain, DefaultRegistry()); });
    graph_file->Stage([&](std::ostream& s) { WriteG2o(s, exported_values, exported, DefaultRegistry()); });
    const lidar::OccupancyImage image = lidar::RenderOccupancy(map);
    pgm->Stage(lidar::PgmBytes(image));
    yaml->Stage(lidar::MapYaml(image, "map.pgm"));
    png->Stage(lidar::PngBytes(image));
    outputs.CommitAll();
  } catch (const Error& e) {
    err << "error: " << e.what() << "; nothing was written\n";
    return kExitWriteFailed;
  }
  const double logged = log.scans[n - 1].stamp - log.scans[0].stamp;
  const lidar::PoseGraphStats& st = graph.stats();
  out << "scans " << n << ", submaps " << graph.submap_count() << ", loop closures " << graph.loop_closures().size()
      << " of " << st.searches << " searches (" << st.ambiguous << " ambiguous, " << st.on_edge
      << " on the window's edge dropped, " << st.unconfirmed << " unconfirmed by a second match); precision "
      << (graph.loop_closures().empty()
              ? std::string("-")
              : Fixed(100.0 * static_cast<double>(kept) / static_cast<double>(graph.loop_closures().size()), 2) + "%")
      << " (" << kept << " kept by the final solution within 20 cm and 1 degree)\n"
      << "time " << Fixed(total, 2) << " s for " << Fixed(logged, 1) << " s of log: real-time factor "
      << Fixed(logged / std::max(total, 1e-9), 1) << "\n"
      << "  local matching " << Fixed(1e3 * matching_seconds / static_cast<double>(n), 3) << " ms per scan, insertion "
      << Fixed(1e3 * insert_seconds / static_cast<double>(n), 3) << " ms per scan; " << untrusted
      << " scans below the match probability took the odometry's prediction\n"
      << "  branch and bound "
      << Fixed(st.searches > 0 ? 1e3 * st.search_seconds / static_cast<double>(st.searches) : 0, 2)
      << " ms per search, " << Fixed(st.found > 0 ? 1e3 * st.search_seconds / static_cast<double>(st.found) : 0, 2)
      << " ms per constraint found (" << cmd.threads << " search threads; waited " << Fixed(st.wait_seconds, 2)
      << " s)\n"
      << "  optimisation " << Fixed(st.optimize_seconds, 2) << " s (" << st.updates
      << " smoother updates; the final solve " << Fixed(st.finish_seconds, 2) << " s), pose graph in all "
      << Fixed(graph_seconds, 2) << " s, map " << Fixed(map_seconds, 2) << " s\n"
      << "wrote " << cmd.output_dir
      << "/{trajectory.tum, trajectory.g2o, pose_graph.g2o, map.pgm, map.yaml, map.png, loop_closures.txt}\n";
  return 0;
}

}  // namespace tether
