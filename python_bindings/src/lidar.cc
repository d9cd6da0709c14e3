// tether.lidar: 2D LiDAR SLAM (LidarSlam2D) over scans from NumPy arrays or a log file, the
// poses and the occupancy map back as arrays, the same files `tether lidar` writes.
#include <filesystem>
#include <fstream>
#include <limits>

#include "common.h"
#include "tether/core/output_file.h"
#include "tether/frontends/lidar/io/lidar_log.h"
#include "tether/frontends/lidar/io/lidar_state.h"
#include "tether/frontends/lidar/io/occupancy_map.h"
#include "tether/frontends/lidar/lidar_slam_2d.h"
#include "tether/frontends/lidar/localizer_2d.h"
#include "tether/frontends/lidar/rbpf_slam_2d.h"
#include "tether/frontends/lidar/sensor/sensor_preset.h"

namespace tether {
namespace python {

namespace {

using lidar::LidarSlam2D;
using lidar::LidarSlamOptions;

lidar::SensorClass SensorNamed(const std::string& name) {
  lidar::SensorClass c;
  if (!FromString(name, &c)) {
    throw InvalidArgument("unknown sensor class '" + name + "'; use " + EnumNameList<lidar::SensorClass>());
  }
  return c;
}

}  // namespace

SE2d PoseFromTuple(const py::handle& h, const char* what) {
  std::vector<double> v;
  try {
    if (py::isinstance<SE2d>(h)) {
      const SE2d& p = h.cast<const SE2d&>();
      v = {p.x(), p.y(), p.theta()};
    } else {
      v = h.cast<std::vector<double>>();
    }
  } catch (const py::cast_error&) {
    throw InvalidArgument(std::string(what) + " must be (x, y, theta), got a " +
                          std::string(py::str(h.get_type().attr("__name__"))));
  }
  if (v.size() != 3) throw InvalidArgument(std::string(what) + " must be (x, y, theta)");
  const std::string why = lidar::PoseProblem(v[0], v[1], v[2]);
  if (!why.empty()) throw InvalidArgument(std::string(what) + ": " + why);
  return SE2d(v[0], v[1], v[2]);
}

lidar::LaserScan MakeScan(const DoubleArray& ranges, double angle_min, double angle_increment, double stamp,
                          double range_min, double range_max, const py::object& odometry,
                          const py::object& laser_offset) {
  if (ranges.ndim() != 1 || ranges.shape(0) < 2) throw InvalidArgument("ranges must be a 1-D array of 2 or more");
  if (!std::isfinite(angle_min) || !std::isfinite(angle_increment) || angle_increment == 0) {
    throw InvalidArgument("angle_min and angle_increment must be finite, angle_increment not 0");
  }
  if (!std::isfinite(stamp)) throw InvalidArgument("stamp must be finite");
  if (!(range_min >= 0) || !(range_max > range_min) || !std::isfinite(range_max)) {
    throw InvalidArgument("range_min must not be negative and range_max finite and above it");
  }
  lidar::LaserScan s;
  s.stamp = s.logger_stamp = stamp;
  s.angle_min = angle_min;
  s.angle_increment = angle_increment;
  s.range_min = range_min;
  s.range_max = range_max;
  s.ranges.resize(static_cast<std::size_t>(ranges.shape(0)));
  for (py::ssize_t i = 0; i < ranges.shape(0); ++i) {
    // Beyond float's range: no return (a cast would be undefined).
    const double r = ranges.at(i);
    s.ranges[static_cast<std::size_t>(i)] = std::abs(r) > std::numeric_limits<float>::max() && std::isfinite(r)
                                                ? std::numeric_limits<float>::infinity()
                                                : static_cast<float>(r);
  }
  if (!odometry.is_none()) {
    s.odometry = PoseFromTuple(odometry, "odometry");
    s.odometry_origin = lidar::OdometryOrigin::kScanLine;
  }
  if (!laser_offset.is_none()) s.laser_in_robot = PoseFromTuple(laser_offset, "laser_offset");
  return s;
}

namespace {

// Writes one file whole or not at all.
void WriteBytes(const std::string& path, const std::string& what, const std::string& bytes) {
  OutputSet outputs;
  OutputFile& file = outputs.Add(path, what);
  file.Stage(bytes);
  outputs.CommitAll();
}

py::dict ResultDict(const lidar::LocalizedScan& r) {
  py::dict d;
  d["scan"] = r.scan;
  d["stamp"] = r.stamp;
  d["localized"] = r.localized;
  d["pose"] = py::make_tuple(r.pose.x(), r.pose.y(), r.pose.theta());
  d["tracked"] = r.tracked;
  d["outside"] = r.outside;
  d["score"] = r.score;
  d["fix"] = r.fix;
  return d;
}

void BindSavedMaps(py::module_& li) {
  py::class_<lidar::LidarState>(li, "LidarState",
                                "A saved LiDAR SLAM state (lidar_state.h): LidarSlam2D.state(), read_state(path)")
      .def_property_readonly("trajectories", [](const lidar::LidarState& s) { return s.trajectories; })
      .def_property_readonly("scan_count", [](const lidar::LidarState& s) { return s.scans.size(); })
      .def_property_readonly("submap_count", [](const lidar::LidarState& s) { return s.submaps.size(); })
      .def_property_readonly("loop_closure_count", [](const lidar::LidarState& s) { return s.closures.size(); })
      .def_property_readonly(
          "poses",
          [](const lidar::LidarState& s) {
            Eigen::MatrixXd a(static_cast<Eigen::Index>(s.scans.size()), 3);
            for (std::size_t i = 0; i < s.scans.size(); ++i) {
              const SE2d& p = s.scans[i].pose;
              a.row(static_cast<Eigen::Index>(i)) << p.x(), p.y(), p.theta();
            }
            return a;
          },
          "(N, 3) = x, y, theta of each saved scan's pose in the map")
      .def(
          "write",
          [](const lidar::LidarState& s, const std::string& path) {
            WriteBytes(path, "saved state", lidar::LidarStateBytes(s));
          },
          py::arg("path"), "Writes the state file (all or nothing).");
  li.def("read_state", &lidar::ReadLidarState, py::arg("path"),
         "Reads a saved state (state.tether); raises ValueError naming the file and what is wrong for a damaged one "
         "or another version.");

  py::class_<lidar::Localizer2D>(li, "Localizer2D",
                                 "Localisation in a saved map (the library class behind `tether localize`): global "
                                 "localisation until the first fix, then tracking against the map.")
      .def(py::init([](const lidar::LidarState& state, const py::object& initial_pose, int global_every_n_scans,
                       double global_min_score, double track_min_score) {
             lidar::LocalizationOptions o;
             if (!initial_pose.is_none()) {
               o.has_initial_pose = true;
               o.initial_pose = PoseFromTuple(initial_pose, "initial_pose");
             }
             o.global_every_n_scans = global_every_n_scans;
             o.global_min_score = global_min_score;
             o.track_min_score = track_min_score;
             return std::make_unique<lidar::Localizer2D>(state, o);
           }),
           py::arg("state"), py::arg("initial_pose") = py::none(), py::arg("global_every_n_scans") = 5,
           py::arg("global_min_score") = 0.6, py::arg("track_min_score") = 0.5, py::keep_alive<1, 2>())
      .def(
          "add_scan",
          [](lidar::Localizer2D& l, const DoubleArray& ranges, double angle_min, double angle_increment, double stamp,
             double range_max, double range_min, const py::object& odometry, const py::object& laser_offset) {
            return ResultDict(l.AddScan(
                MakeScan(ranges, angle_min, angle_increment, stamp, range_min, range_max, odometry, laser_offset)));
          },
          py::arg("ranges"), py::arg("angle_min"), py::arg("angle_increment"), py::arg("stamp"), py::arg("range_max"),
          py::arg("range_min") = 0.0, py::arg("odometry") = py::none(), py::arg("laser_offset") = py::none(),
          "One scan (as LidarSlam2D.add_scan); returns a dict: scan, stamp, localized, pose (x, y, theta in the "
          "map), tracked, outside, score, fix.")
      .def(
          "run_log",
          [](lidar::Localizer2D& l, const std::string& path, long start_scan, long max_scans) {
            lidar::LidarReadOptions ro;
            ro.limits = l.options().local.limits;
            l.Run(lidar::ReadLidarLog(path, ro), start_scan, max_scans);
          },
          py::arg("path"), py::arg("start_scan") = 0, py::arg("max_scans") = 0,
          "Reads a CARMEN log or ROS 1 bag and localises its scans from start_scan (max_scans of them; 0: to the "
          "end).")
      .def_property_readonly(
          "poses",
          [](const lidar::Localizer2D& l) {
            const std::vector<lidar::StampedPose2> t = l.Trajectory();
            Eigen::MatrixXd a(static_cast<Eigen::Index>(t.size()), 4);
            for (std::size_t i = 0; i < t.size(); ++i)
              a.row(static_cast<Eigen::Index>(i)) << t[i].stamp, t[i].pose.x(), t[i].pose.y(), t[i].pose.theta();
            return a;
          },
          "(N, 4) = stamp, x, y, theta of each localised scan run_log added")
      .def_property_readonly("first_fix_scan", [](const lidar::Localizer2D& l) { return l.report().first_fix_scan; })
      .def_property_readonly("first_fix_seconds",
                             [](const lidar::Localizer2D& l) { return l.report().first_fix_seconds; })
      .def_property_readonly("localized", [](const lidar::Localizer2D& l) { return l.report().localized; })
      .def_property_readonly("scan_count", [](const lidar::Localizer2D& l) { return l.report().scans; })
      .def("summary", [](const lidar::Localizer2D& l) { return l.report().Summary(); });
}

// (image (H, W) uint8, resolution, origin (x, y)): a grid as map_image gives it.
py::tuple MapImage(const ProbabilityGrid& grid) {
  const lidar::OccupancyImage image = lidar::RenderOccupancy(grid);
  py::array_t<std::uint8_t> a({image.height, image.width});
  std::copy(image.pixels.begin(), image.pixels.end(), a.mutable_data());
  return py::make_tuple(a, image.resolution, py::make_tuple(image.origin.x(), image.origin.y()));
}

// Grid-based particle filter SLAM (frontends/lidar/rbpf_slam_2d.h), scan by scan.
void BindRbpf(py::module_& li) {
  using lidar::RbpfSlam2D;
  using lidar::RbpfSlamOptions;
  py::class_<RbpfSlamOptions>(li, "RbpfSlamOptions", "The options of RbpfSlam2D; the defaults are `tether pf-slam`'s.")
      .def(py::init<>())
      .def_readwrite("particles", &RbpfSlamOptions::particles)
      .def_readwrite("resolution", &RbpfSlamOptions::resolution)
      .def_readwrite("max_range", &RbpfSlamOptions::max_range)
      .def_readwrite("linear_update", &RbpfSlamOptions::linear_update)
      .def_readwrite("angular_update", &RbpfSlamOptions::angular_update)
      .def_readwrite("likelihood_points", &RbpfSlamOptions::likelihood_points)
      .def_readwrite("min_known_fraction", &RbpfSlamOptions::min_known_fraction)
      .def_readwrite("odometry_check_translation", &RbpfSlamOptions::odometry_check_translation)
      .def_readwrite("odometry_check_rotation", &RbpfSlamOptions::odometry_check_rotation)
      .def_readwrite("resample_fraction", &RbpfSlamOptions::resample_fraction)
      .def_readwrite("threads", &RbpfSlamOptions::threads)
      .def_readwrite("seed", &RbpfSlamOptions::seed);
  py::class_<RbpfSlam2D>(li, "RbpfSlam2D",
                         "Grid-based Rao-Blackwellised particle filter SLAM: add scans with odometry one at a time "
                         "(add_scan) or a whole log (run_log); the particles, their weights, the heaviest one's "
                         "trajectory and map.")
      .def(py::init<const RbpfSlamOptions&>(), py::arg("options") = RbpfSlamOptions())
      .def(
          "add_scan",
          [](RbpfSlam2D& s, const DoubleArray& ranges, double angle_min, double angle_increment, double stamp,
             double range_max, const py::object& odometry, double range_min, const py::object& laser_offset) {
            s.AddScan(
                MakeScan(ranges, angle_min, angle_increment, stamp, range_min, range_max, odometry, laser_offset));
          },
          py::arg("ranges"), py::arg("angle_min"), py::arg("angle_increment"), py::arg("stamp"), py::arg("range_max"),
          py::arg("odometry"), py::arg("range_min") = 0.0, py::arg("laser_offset") = py::none(),
          "One scan as LidarSlam2D.add_scan takes it; the odometry pose (x, y, theta) is required.")
      .def(
          "run_log",
          [](RbpfSlam2D& s, const std::string& path, long max_scans) { s.Run(lidar::ReadLidarLog(path), max_scans); },
          py::arg("path"), py::arg("max_scans") = 0, "Reads a CARMEN log or ROS 1 bag and adds its scans.")
      .def_property_readonly(
          "particles",
          [](const RbpfSlam2D& s) {
            Eigen::MatrixXd a(s.particle_count(), 3);
            for (int i = 0; i < s.particle_count(); ++i) {
              const SE2d p = s.particle_pose(i);
              a.row(i) << p.x(), p.y(), p.theta();
            }
            return a;
          },
          "(N, 3) the particles' poses at the last processed scan")
      .def_property_readonly(
          "weights",
          [](const RbpfSlam2D& s) {
            const std::vector<double> w = s.weights();
            return Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(w.data(), static_cast<Eigen::Index>(w.size())));
          },
          "(N,) normalised weights")
      .def_property_readonly("best_particle", &RbpfSlam2D::best_particle)
      .def(
          "poses",
          [](const RbpfSlam2D& s, int particle) {
            const std::vector<lidar::StampedPose2> t = s.Trajectory(particle);
            Eigen::MatrixXd a(static_cast<Eigen::Index>(t.size()), 4);
            for (std::size_t i = 0; i < t.size(); ++i)
              a.row(static_cast<Eigen::Index>(i)) << t[i].stamp, t[i].pose.x(), t[i].pose.y(), t[i].pose.theta();
            return a;
          },
          py::arg("particle") = -1, "(scans, 4) = stamp, x, y, theta along a particle's trajectory (-1: the heaviest)")
      .def(
          "map_image", [](const RbpfSlam2D& s, int particle) { return MapImage(s.Map(particle)); },
          py::arg("particle") = -1, "A particle's map (-1: the heaviest), as LidarSlam2D.map_image")
      .def("summary", [](const RbpfSlam2D& s) { return s.report().Summary(); })
      .def_property_readonly("resamplings", [](const RbpfSlam2D& s) { return s.report().resamplings; })
      .def_property_readonly("distinct_tiles", [](const RbpfSlam2D& s) { return s.report().distinct_tiles; });
}

}  // namespace

void BindLidar(py::module_& m) {
  py::module_ li = m.def_submodule("lidar", "2D LiDAR SLAM: LidarSlam2D (the library class behind `tether lidar`)");
  py::class_<LidarSlamOptions>(li, "LidarSlamOptions",
                               "The options of LidarSlam2D (frontends/lidar/lidar_slam_2d.h); the defaults are "
                               "`tether lidar`'s.")
      .def(py::init<>())
      .def_property(
          "resolution", [](const LidarSlamOptions& o) { return o.local.submaps.resolution; },
          [](LidarSlamOptions& o, double v) { o.local.submaps.resolution = v; }, "Grid cells [m]")
      .def_property(
          "scans_per_submap", [](const LidarSlamOptions& o) { return o.local.submaps.scans_per_submap; },
          [](LidarSlamOptions& o, int v) { o.local.submaps.scans_per_submap = v; })
      .def_property(
          "max_submap_travel", [](const LidarSlamOptions& o) { return o.local.submaps.max_submap_travel; },
          [](LidarSlamOptions& o, double v) { o.local.submaps.max_submap_travel = v; },
          "A submap is also finished once the robot travelled this far over its scans [m] (0: by scans only)")
      .def_property(
          "loop_closure", [](const LidarSlamOptions& o) { return o.pose_graph.loop_closure; },
          [](LidarSlamOptions& o, bool v) { o.pose_graph.loop_closure = v; })
      .def_property(
          "threads", [](const LidarSlamOptions& o) { return o.pose_graph.threads; },
          [](LidarSlamOptions& o, int v) { o.pose_graph.threads = v; },
          "Loop-closure search threads (default: the machine's cores; the result does not depend on it)")
      .def_property(
          "search_every", [](const LidarSlamOptions& o) { return o.pose_graph.search_every_n_scans; },
          [](LidarSlamOptions& o, int v) { o.pose_graph.search_every_n_scans = v; })
      .def_property(
          "search_every_metres", [](const LidarSlamOptions& o) { return o.pose_graph.search_every_metres; },
          [](LidarSlamOptions& o, double v) { o.pose_graph.search_every_metres = v; },
          "A scan is also searched where the robot travelled this far since the last searched one [m] (0: by count)")
      .def_property(
          "min_score", [](const LidarSlamOptions& o) { return o.pose_graph.min_score; },
          [](LidarSlamOptions& o, double v) { o.pose_graph.min_score = v; })
      .def_property(
          "max_range", [](const LidarSlamOptions& o) { return o.local.limits.max_range; },
          [](LidarSlamOptions& o, double v) { o.local.limits.max_range = v; }, "Drop ranges beyond this [m] (0: none)")
      .def_property(
          "kidnap_detection", [](const LidarSlamOptions& o) { return o.local.kidnap.detect; },
          [](LidarSlamOptions& o, bool v) { o.local.kidnap.detect = v; },
          "Act on a detected kidnap: end the trajectory and start a new one (docs/lidar_slam.md)")
      .def_property(
          "kidnap_relocate_window", [](const LidarSlamOptions& o) { return o.local.kidnap.relocate_window; },
          [](LidarSlamOptions& o, double v) { o.local.kidnap.relocate_window = v; },
          "Before acting on a kidnap, search the scan in the current submap within this distance [m] of the last "
          "pose before the break; where it fits as well as the scans before, go on from there (0: never)")
      .def_property(
          "self_check_every", [](const LidarSlamOptions& o) { return o.self_check.sample_every; },
          [](LidarSlamOptions& o, int v) { o.self_check.sample_every = v; })
      .def_property(
          "min_range", [](const LidarSlamOptions& o) { return o.mask.min_range; },
          [](LidarSlamOptions& o, double v) { o.mask.min_range = v; },
          "The robot's body: returns nearer than this are dropped before matching and mapping [m] (0: none)")
      .def_property(
          "mask_angles", [](const LidarSlamOptions& o) { return lidar::FormatAngleSectors(o.mask.sectors); },
          [](LidarSlamOptions& o, const std::string& v) {
            if (v.empty()) {
              o.mask.sectors.clear();
              return;
            }
            std::string why;
            if (!lidar::ParseAngleSectors(v, &o.mask.sectors, &why)) throw InvalidArgument("mask_angles: " + why);
          },
          "The robot's body: returns at these angles of the laser are dropped, 'from:to[,from:to]' counter-clockwise "
          "in degrees ('': none)")
      .def_static(
          "for_sensor", [](const std::string& name) { return lidar::ForSensor(SensorNamed(name)); }, py::arg("sensor"),
          "The settings of a class of scanner: 'lds' (low-cost 360-degree), 'sick' (SICK LMS-class: the defaults) or "
          "'hokuyo' (UTM-30LX-class); tether lidar --sensor")
      .def("is_valid", [](const LidarSlamOptions& o) {
        std::string why;
        const bool ok = o.IsValid(&why);
        return py::make_tuple(ok, why);
      });

  li.def(
      "sensor_classes", [] { return EnumNameVector<lidar::SensorClass>(); },
      "The sensor classes' names: 'auto' (chosen from a log) and the classes LidarSlamOptions.for_sensor takes.");
  li.def(
      "choose_sensor",
      [](const std::string& path, long max_scans) {
        const lidar::LidarLog log = lidar::ReadLidarLog(path);
        const lidar::SensorChoice c = lidar::ChooseSensor(lidar::ComputeScanStatistics(log.scans, max_scans));
        return py::make_tuple(std::string(ToString(c.sensor)), c.why);
      },
      py::arg("path"), py::arg("max_scans") = 0,
      "(class, why): the sensor class a log's scans point to (its first max_scans; 0: all), as tether lidar --sensor "
      "auto chooses it.");

  py::class_<LidarSlam2D>(li, "LidarSlam2D",
                          "2D LiDAR SLAM: add scans (add_scan, or run_log for a CARMEN log or ROS 1 bag), finish(), "
                          "then poses, the map and the report.")
      .def(py::init<const LidarSlamOptions&>(), py::arg("options") = LidarSlamOptions())
      .def(
          "add_scan",
          [](LidarSlam2D& s, const DoubleArray& ranges, double angle_min, double angle_increment, double stamp,
             double range_max, double range_min, const py::object& odometry, const py::object& laser_offset) {
            s.AddScan(
                MakeScan(ranges, angle_min, angle_increment, stamp, range_min, range_max, odometry, laser_offset));
          },
          py::arg("ranges"), py::arg("angle_min"), py::arg("angle_increment"), py::arg("stamp"), py::arg("range_max"),
          py::arg("range_min") = 0.0, py::arg("odometry") = py::none(), py::arg("laser_offset") = py::none(),
          "One scan: ranges (N,) [m] (no return: NaN, inf, or outside [range_min, range_max)), beam i at angle_min "
          "+ i angle_increment [rad], the stamp [s], the robot's odometry pose (x, y, theta) where there is one "
          "(None: scan-only), the laser's pose on the robot.")
      .def(
          "run_log",
          [](LidarSlam2D& s, const std::string& path, long max_scans, const std::string& imu_topic) {
            lidar::LidarReadOptions ro;
            ro.limits = s.options().local.limits;
            ro.imu_topic = imu_topic;
            const lidar::LidarLog log = lidar::ReadLidarLog(path, ro);
            s.Run(log, max_scans);
          },
          py::arg("path"), py::arg("max_scans") = 0, py::arg("imu_topic") = "",
          "Reads a CARMEN log or ROS 1 bag, adds its scans (the first max_scans; 0: all) and finishes. imu_topic: a "
          "bag's sensor_msgs/Imu topic, whose yaw rate turns the scans without odometry.")
      .def("finish", &LidarSlam2D::Finish, "The final solve, the map and the checks (once).")
      .def_property_readonly("finished", &LidarSlam2D::finished)
      .def_property_readonly("scan_count", &LidarSlam2D::scan_count)
      .def_property_readonly(
          "poses",
          [](const LidarSlam2D& s) {
            const std::vector<lidar::StampedPose2> t = s.Trajectory();
            Eigen::MatrixXd a(static_cast<Eigen::Index>(t.size()), 3);
            for (std::size_t i = 0; i < t.size(); ++i)
              a.row(static_cast<Eigen::Index>(i)) << t[i].pose.x(), t[i].pose.y(), t[i].pose.theta();
            return a;
          },
          "(N, 3) = x, y, theta of each scan's robot pose")
      .def_property_readonly("stamps",
                             [](const LidarSlam2D& s) {
                               const std::vector<lidar::StampedPose2> t = s.Trajectory();
                               Eigen::VectorXd a(static_cast<Eigen::Index>(t.size()));
                               for (std::size_t i = 0; i < t.size(); ++i) a[static_cast<Eigen::Index>(i)] = t[i].stamp;
                               return a;
                             })
      .def(
          "map_image", [](const LidarSlam2D& s) { return MapImage(s.map()); },
          "(image (H, W) uint8 with the top row the map's largest y, resolution [m], origin (x, y) of the "
          "lower-left corner): the map_server convention (occupied dark, free light, unknown 205)")
      .def_property_readonly("loop_closures", [](const LidarSlam2D& s) { return s.report().loop_closures; })
      .def_property_readonly("closures_kept", [](const LidarSlam2D& s) { return s.report().closures_kept; })
      .def_property_readonly(
          "self_check_fit", [](const LidarSlam2D& s) { return s.report().self_check.FitShare(); },
          "Share of the judged self-check scans that fit the map made at other times")
      .def_property_readonly(
          "misplaced_stretches",
          [](const LidarSlam2D& s) {
            py::list l;
            for (const lidar::MisfitStretch& m : s.report().self_check.stretches)
              l.append(py::make_tuple(m.first_scan, m.last_scan));
            return l;
          },
          "(first scan, last scan) of each stretch the self-check found misplaced")
      .def_property_readonly(
          "trajectories",
          [](const LidarSlam2D& s) {
            py::list l;
            for (const lidar::TrajectoryReport& t : s.report().trajectories) {
              py::dict d;
              d["first_scan"] = t.first_scan;
              d["first_stamp"] = t.first_stamp;
              d["joined_scan"] = t.joined_scan;
              d["joined_stamp"] = t.joined_stamp;
              l.append(d);
            }
            return l;
          },
          "One dict per trajectory (a kidnap starts a new one): first_scan, first_stamp, joined_scan (the scan "
          "whose closures joined it to the map; -1: never), joined_stamp")
      .def_property_readonly(
          "relocations", [](const LidarSlam2D& s) { return s.report().relocations; },
          "The scans (from 0) where a declared kidnap was withdrawn: the scan fitted the current submap near the "
          "last pose before the break (kidnap_relocate_window), and the trajectory went on")
      .def("summary", [](const LidarSlam2D& s) { return s.report().Summary(s.options().pose_graph.threads); })
      .def(
          "write",
          [](const LidarSlam2D& s, const std::string& folder) {
            std::filesystem::create_directories(folder);
            OutputSet outputs;
            std::vector<std::pair<OutputFile*, std::string>> staged;
            for (lidar::LidarOutput& o : s.Outputs()) {
              staged.emplace_back(&outputs.Add((std::filesystem::path(folder) / o.name).string(), o.what),
                                  std::move(o.bytes));
            }
            for (auto& [file, bytes] : staged) file->Stage(bytes);
            outputs.CommitAll();
          },
          py::arg("folder"), "Writes the files `tether lidar -o FOLDER` writes (all or nothing).")
      .def(
          "save_state",
          [](const LidarSlam2D& s, const std::string& path) { WriteBytes(path, "saved state", s.StateOutput().bytes); },
          py::arg("path"),
          "Writes the run's saved state (what `tether lidar --save-state` writes as state.tether) to path; after "
          "finish().")
      .def("continue_from", &LidarSlam2D::Continue, py::arg("state"),
           "Multi-session mapping: before the first scan, go on from a saved state (read_state, or state() of an "
           "earlier run); the scans added next form a new trajectory joined to it by the global search.")
      .def(
          "state", [](const LidarSlam2D& s) { return s.State(); },
          "The run's saved state as a LidarState (after finish()).");
  BindSavedMaps(li);
  BindRbpf(li);
}
TETHER_PYTHON_PART(60, BindLidar);

}  // namespace python
}  // namespace tether
