// tether.lidar: 2D LiDAR SLAM (LidarSlam2D) over scans from NumPy arrays or a log file, the
// poses and the occupancy map back as arrays, the same files `tether lidar` writes.
#include <filesystem>
#include <fstream>
#include <limits>

#include "common.h"
#include "tether/core/output_file.h"
#include "tether/frontends/lidar/io/lidar_log.h"
#include "tether/frontends/lidar/io/occupancy_map.h"
#include "tether/frontends/lidar/lidar_slam_2d.h"
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
          "map_image",
          [](const LidarSlam2D& s) {
            const lidar::OccupancyImage image = lidar::RenderOccupancy(s.map());
            py::array_t<std::uint8_t> a({image.height, image.width});
            std::copy(image.pixels.begin(), image.pixels.end(), a.mutable_data());
            return py::make_tuple(a, image.resolution, py::make_tuple(image.origin.x(), image.origin.y()));
          },
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
          py::arg("folder"), "Writes the files `tether lidar -o FOLDER` writes (all or nothing).");
}

}  // namespace python
}  // namespace tether
