// tether.localization: Monte Carlo localisation in a known map -- the map from a NumPy image or
// a map_server YAML, the particle filter step by step (predict, update, resample; the particles
// as an (N, 4) array), and a whole log's localisation (MclLocalization2D, the class behind
// `tether mcl`).
#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "common.h"
#include "tether/core/output_file.h"
#include "tether/core/registry.h"
#include "tether/frontends/lidar/io/lidar_log.h"
#include "tether/frontends/lidar/io/tum_trajectory.h"
#include "tether/frontends/localization/mcl_localization_2d.h"
#include "tether/frontends/localization/measurement_model.h"
#include "tether/frontends/localization/monte_carlo_localizer_2d.h"
#include "tether/frontends/localization/motion_model.h"
#include "tether/frontends/localization/occupancy_map_2d.h"

namespace tether {
namespace python {

namespace {

using namespace localization;  // NOLINT(build/namespaces)

using MapPtr = std::shared_ptr<OccupancyMap2D>;
using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

constexpr const char* kFilter = "MonteCarloLocalizer2D";
constexpr const char* kRun = "MclLocalization2D";

template <class E>
E NamedEnum(const std::string& s, const char* what) {
  E e;
  if (!FromString(s, &e))
    throw InvalidArgument("unknown " + std::string(what) + " '" + s + "'; use " + EnumNameList<E>());
  return e;
}

template <class O>
py::tuple Validity(const O& o) {
  std::string why;
  const bool ok = o.IsValid(&why);
  return py::make_tuple(ok, why);
}

const char* StateName(CellState s) {
  switch (s) {
    case CellState::kFree:
      return "free";
    case CellState::kOccupied:
      return "occupied";
    default:
      return "unknown";
  }
}

// A str or os.PathLike as a path.
std::string PathOf(const py::object& path) {
  return py::str(py::module_::import("os").attr("fspath")(path)).cast<std::string>();
}

void CheckCell(const OccupancyMap2D& map, int i, int j) {
  if (i < 0 || j < 0 || i >= map.width() || j >= map.height()) {
    throw InvalidArgument("cell (" + std::to_string(i) + ", " + std::to_string(j) + ") is outside the " +
                          std::to_string(map.width()) + " x " + std::to_string(map.height()) + " map");
  }
}

// The map of a (H, W) uint8 image, rows top first (map_server's convention).
MapPtr MapFromImage(const py::array& image, double resolution, const py::object& origin, double occupied_thresh,
                    double free_thresh, bool negate) {
  if (image.ndim() != 2 || image.dtype().kind() != 'u' || image.dtype().itemsize() != 1) {
    std::string got = "an array of dtype " + std::string(py::str(image.dtype())) + " and " +
                      std::to_string(image.ndim()) + " dimensions";
    throw InvalidArgument("OccupancyMap2D: the image must be a 2-D uint8 array (rows top first), got " + got);
  }
  if (image.shape(0) < 1 || image.shape(1) < 1) throw InvalidArgument("OccupancyMap2D: an empty image");
  if (image.shape(0) * image.shape(1) > (py::ssize_t{1} << 28)) {
    throw InvalidArgument("OccupancyMap2D: an image above 2^28 pixels");
  }
  if (!(free_thresh >= 0 && free_thresh < occupied_thresh && occupied_thresh <= 1)) {
    throw InvalidArgument("OccupancyMap2D: the thresholds must keep 0 <= free_thresh < occupied_thresh <= 1, got " +
                          FormatDouble(free_thresh) + " and " + FormatDouble(occupied_thresh));
  }
  const std::vector<double> o = origin.cast<std::vector<double>>();
  if (o.size() != 2 && o.size() != 3) throw InvalidArgument("OccupancyMap2D: origin must be (x, y)");
  if (o.size() == 3 && o[2] != 0) {
    throw InvalidArgument("OccupancyMap2D: a rotated origin (yaw " + FormatDouble(o[2]) + ") is not supported");
  }
  const auto pixels = py::array_t<std::uint8_t, py::array::c_style | py::array::forcecast>::ensure(image);
  lidar::OccupancyImage im;
  im.height = static_cast<int>(image.shape(0));
  im.width = static_cast<int>(image.shape(1));
  im.pixels.assign(pixels.data(), pixels.data() + pixels.size());
  im.resolution = resolution;
  im.origin = Eigen::Vector2d(o[0], o[1]);
  return std::make_shared<OccupancyMap2D>(im, occupied_thresh, free_thresh, negate);
}

Eigen::Vector3d PoseArray(const SE2d& p) { return Eigen::Vector3d(p.x(), p.y(), p.theta()); }

RowMatrix ParticlesArray(const std::vector<Particle>& particles) {
  RowMatrix a(static_cast<Eigen::Index>(particles.size()), 4);
  for (std::size_t i = 0; i < particles.size(); ++i) {
    const Particle& p = particles[i];
    a.row(static_cast<Eigen::Index>(i)) << p.x, p.y, p.theta, p.weight;
  }
  return a;
}

std::vector<Particle> ParticlesFrom(const DoubleArray& a) {
  if (a.ndim() != 2 || (a.shape(1) != 3 && a.shape(1) != 4) || a.shape(0) < 1) {
    std::string got = "(";
    for (py::ssize_t i = 0; i < a.ndim(); ++i) got += (i ? ", " : "") + std::to_string(a.shape(i));
    throw InvalidArgument(
        "set_particles: an (N, 4) array (x, y, theta, weight) or (N, 3) (equal weights), N >= 1, "
        "got shape " +
        got + (a.ndim() == 1 ? ",)" : ")"));
  }
  const py::ssize_t n = a.shape(0), c = a.shape(1);
  std::vector<Particle> out(static_cast<std::size_t>(n));
  for (py::ssize_t i = 0; i < n; ++i) {
    const double* r = a.data() + i * c;
    const std::string why = lidar::PoseProblem(r[0], r[1], r[2]);
    if (!why.empty()) throw InvalidArgument("set_particles: particle " + std::to_string(i) + ": " + why);
    Particle& p = out[static_cast<std::size_t>(i)];
    p.x = r[0];
    p.y = r[1];
    p.theta = WrapAngle(r[2]);
    p.weight = c == 4 ? r[3] : 1.0;
    if (!(p.weight >= 0) || !std::isfinite(p.weight)) {
      throw InvalidArgument("set_particles: particle " + std::to_string(i) + " has weight " + FormatDouble(p.weight) +
                            " (weights must be finite and not negative)");
    }
  }
  return out;
}

py::array_t<bool> BoolArray(const std::vector<bool>& v) {
  py::array_t<bool> a(static_cast<py::ssize_t>(v.size()));
  bool* d = a.mutable_data();
  for (std::size_t i = 0; i < v.size(); ++i) d[i] = v[i];
  return a;
}

RowMatrix TrajectoryArray(const std::vector<lidar::StampedPose2>& t) {
  RowMatrix a(static_cast<Eigen::Index>(t.size()), 4);
  for (std::size_t i = 0; i < t.size(); ++i) {
    a.row(static_cast<Eigen::Index>(i)) << t[i].stamp, t[i].pose.x(), t[i].pose.y(), t[i].pose.theta();
  }
  return a;
}

std::vector<lidar::StampedPose2> TrajectoryFrom(const DoubleArray& a, const char* what) {
  if (a.ndim() != 2 || a.shape(1) != 4) {
    throw InvalidArgument(std::string(what) + " must be an (N, 4) array of stamp, x, y, theta");
  }
  std::vector<lidar::StampedPose2> out(static_cast<std::size_t>(a.shape(0)));
  for (py::ssize_t i = 0; i < a.shape(0); ++i) {
    const double* r = a.data() + 4 * i;
    if (!std::isfinite(r[0]) || !lidar::PoseProblem(r[1], r[2], r[3]).empty()) {
      throw InvalidArgument(std::string(what) + " row " + std::to_string(i) + " is not a finite stamp and pose");
    }
    out[static_cast<std::size_t>(i)] = {r[0], SE2d(r[1], r[2], r[3])};
  }
  return out;
}

void RequireParticles(const MonteCarloLocalizer2D& f, const char* call) {
  if (f.particles().empty()) {
    throw InvalidArgument(std::string(call) +
                          ": the filter has no particles yet; call initialize_global(), initialize_gaussian() or "
                          "set_particles() first");
  }
}

// The scan arguments of update and add_scan, keyword-only after the ranges.
#define TETHER_SCAN_ARGS                                                                                    \
  py::arg("ranges"), py::kw_only(), py::arg("angle_min"), py::arg("angle_increment"), py::arg("range_max"), \
      py::arg("range_min") = 0.0, py::arg("stamp") = 0.0, py::arg("odometry") = py::none(),                 \
      py::arg("laser_offset") = py::none()

#define TETHER_SCAN_DOC                                                                                      \
  "The scan as LidarSlam2D.add_scan takes it: ranges (N,) [m] (no return: NaN, inf, or outside [range_min, " \
  "range_max)), beam i at angle_min + i angle_increment [rad] in the laser's frame, the stamp [s], the "     \
  "robot's odometry pose (x, y, theta), the laser's pose on the robot (None: at its centre)."

void BindMap(py::module_& lo) {
  py::class_<OccupancyMap2D, MapPtr>(
      lo, "OccupancyMap2D",
      "The map a robot localises in: free, occupied and unknown cells, each cell's distance to the nearest occupied "
      "cell. Cell (i, j): column i from the left (x), row j from the bottom (y); it covers [origin_x + i r, "
      "origin_x + (i + 1) r) x [origin_y + j r, ...) for resolution r.")
      .def(py::init(&MapFromImage), py::arg("image"), py::arg("resolution"), py::arg("origin") = py::make_tuple(0, 0),
           py::arg("occupied_thresh") = 0.65, py::arg("free_thresh") = 0.196, py::arg("negate") = false,
           "From a (H, W) uint8 image in map_server's convention: rows top first (the first row is the largest y), "
           "a pixel v is p = (255 - v) / 255 (v / 255 where negate), occupied above occupied_thresh, free below "
           "free_thresh, unknown between. origin: (x, y) of the lower-left corner [m].")
      .def_static(
          "read",
          [](const py::object& path) { return std::make_shared<OccupancyMap2D>(OccupancyMap2D::Read(PathOf(path))); },
          py::arg("yaml_path"), "Reads a map_server YAML and the PGM it names (as `tether lidar` writes them).")
      .def_property_readonly("width", &OccupancyMap2D::width, "Columns (x)")
      .def_property_readonly("height", &OccupancyMap2D::height, "Rows (y)")
      .def_property_readonly("resolution", &OccupancyMap2D::resolution, "Metres per cell")
      .def_property_readonly(
          "origin", [](const OccupancyMap2D& m) { return py::make_tuple(m.origin().x(), m.origin().y()); },
          "(x, y) of the lower-left corner of cell (0, 0) [m]")
      .def(
          "state",
          [](const OccupancyMap2D& m, int i, int j) {
            CheckCell(m, i, j);
            return StateName(m.State(i, j));
          },
          py::arg("i"), py::arg("j"), "'free', 'occupied' or 'unknown'")
      .def(
          "distance",
          [](const OccupancyMap2D& m, int i, int j) {
            CheckCell(m, i, j);
            return static_cast<double>(m.Distance(i, j));
          },
          py::arg("i"), py::arg("j"),
          "Metres from the cell's centre to the nearest occupied cell's centre (inf without one)")
      .def_property_readonly(
          "distances",
          [](const OccupancyMap2D& m) {
            RowMatrix a(m.height(), m.width());
            for (int j = 0; j < m.height(); ++j)
              for (int i = 0; i < m.width(); ++i) a(j, i) = m.Distance(i, j);
            return a;
          },
          "(height, width) float64: distances[j, i] = distance(i, j), so row 0 is the BOTTOM row (the smallest y); "
          "np.flipud gives the image's orientation")
      .def_property_readonly(
          "states",
          [](const OccupancyMap2D& m) {
            py::array_t<std::uint8_t> a({m.height(), m.width()});
            std::uint8_t* d = a.mutable_data();
            for (int j = 0; j < m.height(); ++j)
              for (int i = 0; i < m.width(); ++i)
                d[static_cast<std::size_t>(j) * static_cast<std::size_t>(m.width()) + static_cast<std::size_t>(i)] =
                    static_cast<std::uint8_t>(m.State(i, j));
            return a;
          },
          "(height, width) uint8: 0 free, 1 occupied, 2 unknown; row 0 the bottom row, as distances")
      .def(
          "cell_of",
          [](const OccupancyMap2D& m, double x, double y) -> py::object {
            int i, j;
            if (!m.CellOf(Eigen::Vector2d(x, y), &i, &j)) return py::none();
            return py::make_tuple(i, j);
          },
          py::arg("x"), py::arg("y"), "(i, j) of the cell holding the point, or None outside the map")
      .def(
          "cell_centre",
          [](const OccupancyMap2D& m, int i, int j) {
            CheckCell(m, i, j);
            const Eigen::Vector2d c = m.CellCentre(i, j);
            return py::make_tuple(c.x(), c.y());
          },
          py::arg("i"), py::arg("j"))
      .def_property_readonly(
          "free_count", [](const OccupancyMap2D& m) { return m.free_cells().size(); }, "Free cells")
      .def_property_readonly("occupied_count", &OccupancyMap2D::occupied_count, "Occupied cells")
      .def("__repr__", [](const OccupancyMap2D& m) {
        return "OccupancyMap2D(" + std::to_string(m.width()) + " x " + std::to_string(m.height()) + " cells of " +
               FormatDouble(m.resolution()) + " m, " + std::to_string(m.free_cells().size()) + " free, " +
               std::to_string(m.occupied_count()) + " occupied)";
      });

  py::class_<Costmap2D>(lo, "Costmap2D",
                        "Where the robot's centre may be: free cells at least robot_radius from every occupied cell "
                        "(the costmap of cmcl and acmcl).")
      .def(py::init<const OccupancyMap2D&, double>(), py::arg("map"), py::arg("robot_radius"))
      .def(
          "valid", [](const Costmap2D& c, double x, double y) { return c.Valid(Eigen::Vector2d(x, y)); }, py::arg("x"),
          py::arg("y"))
      .def(
          "path_valid",
          [](const Costmap2D& c, const py::object& a, const py::object& b) {
            const std::vector<double> p = a.cast<std::vector<double>>(), q = b.cast<std::vector<double>>();
            if (p.size() < 2 || q.size() < 2) throw InvalidArgument("path_valid: points are (x, y)");
            return c.PathValid(Eigen::Vector2d(p[0], p[1]), Eigen::Vector2d(q[0], q[1]));
          },
          py::arg("a"), py::arg("b"), "True where the straight move from a to b stays in valid cells")
      .def_property_readonly(
          "valid_count", [](const Costmap2D& c) { return c.valid_cells().size(); }, "Valid cells")
      .def_property_readonly("robot_radius", &Costmap2D::robot_radius);
}

void BindModelOptions(py::module_& lo) {
  py::class_<OdometryMotionModel>(lo, "OdometryMotionModel",
                                  "The sampled odometry motion model's noise (Probabilistic Robotics 5.4): rot1, "
                                  "trans and rot2 each get variance alpha1 rot^2 + alpha2 trans^2 (turns) or "
                                  "alpha3 trans^2 + alpha4 (rot1^2 + rot2^2) (the move).")
      .def(py::init<>())
      .def_readwrite("alpha1", &OdometryMotionModel::alpha1, "Rotation noise from rotation")
      .def_readwrite("alpha2", &OdometryMotionModel::alpha2, "Rotation noise from translation")
      .def_readwrite("alpha3", &OdometryMotionModel::alpha3, "Translation noise from translation")
      .def_readwrite("alpha4", &OdometryMotionModel::alpha4, "Translation noise from rotation")
      .def("is_valid", &Validity<OdometryMotionModel>, "(ok, why)");
  lo.def(
      "decompose_odometry",
      [](const py::object& from, const py::object& to) {
        const OdometryMotion m = DecomposeOdometry(PoseFromTuple(from, "from"), PoseFromTuple(to, "to"));
        return py::make_tuple(m.rot1, m.trans, m.rot2);
      },
      py::arg("odom_from"), py::arg("odom_to"), "(rot1, trans, rot2) of the odometry's motion");

  py::class_<LikelihoodFieldOptions>(lo, "LikelihoodFieldOptions",
                                     "The likelihood field: a beam's end point at distance d from the nearest "
                                     "obstacle scores z_hit exp(-d^2 / (2 sigma_hit^2)) + z_rand / range_max.")
      .def(py::init<>())
      .def_readwrite("sigma_hit", &LikelihoodFieldOptions::sigma_hit, "[m]")
      .def_readwrite("z_hit", &LikelihoodFieldOptions::z_hit)
      .def_readwrite("z_rand", &LikelihoodFieldOptions::z_rand)
      .def_readwrite("max_distance", &LikelihoodFieldOptions::max_distance, "Distances beyond count as this [m]")
      .def_property(
          "combination", [](const LikelihoodFieldOptions& o) { return std::string(ToString(o.combination)); },
          [](LikelihoodFieldOptions& o, const std::string& s) {
            o.combination = NamedEnum<BeamCombination>(s, "combination");
          },
          "'product' (the beams independent) or 'sum-of-cubes' (ROS amcl's rule)")
      .def("is_valid", &Validity<LikelihoodFieldOptions>, "(ok, why)");

  py::class_<BeamModelOptions>(lo, "BeamModelOptions",
                               "The beam model's mixture: hit (Gaussian around the cast range), short, max, random.")
      .def(py::init<>())
      .def_readwrite("z_hit", &BeamModelOptions::z_hit)
      .def_readwrite("z_short", &BeamModelOptions::z_short)
      .def_readwrite("z_max", &BeamModelOptions::z_max)
      .def_readwrite("z_rand", &BeamModelOptions::z_rand)
      .def_readwrite("sigma_hit", &BeamModelOptions::sigma_hit, "[m]")
      .def_readwrite("lambda_short", &BeamModelOptions::lambda_short, "[1/m]")
      .def_property(
          "combination", [](const BeamModelOptions& o) { return std::string(ToString(o.combination)); },
          [](BeamModelOptions& o, const std::string& s) {
            o.combination = NamedEnum<BeamCombination>(s, "combination");
          },
          "'product' or 'sum-of-cubes'")
      .def("is_valid", &Validity<BeamModelOptions>, "(ok, why)");

  py::class_<KldOptions>(lo, "KldOptions", "KLD sampling: the particle count follows the belief's spread (Fox 2003).")
      .def(py::init<>())
      .def_readwrite("enabled", &KldOptions::enabled)
      .def_readwrite("epsilon", &KldOptions::epsilon, "The bound on the KL divergence")
      .def_readwrite("delta", &KldOptions::delta, "... held with probability 1 - delta")
      .def_readwrite("min_particles", &KldOptions::min_particles)
      .def_readwrite("max_particles", &KldOptions::max_particles);

  py::class_<BeamModel>(lo, "BeamModel", "The beam model; here mostly its ray caster, to simulate scans in a map.")
      .def(py::init<const OccupancyMap2D&, const BeamModelOptions&>(), py::arg("map"),
           py::arg("options") = BeamModelOptions(), py::keep_alive<1, 2>())
      .def(
          "cast_ray",
          [](const BeamModel& b, double x, double y, double angle, double range_max) {
            return b.CastRay(Eigen::Vector2d(x, y), angle, range_max);
          },
          py::arg("x"), py::arg("y"), py::arg("angle"), py::arg("range_max"),
          "The range from (x, y) along the world angle to the first occupied cell, at most range_max")
      .def(
          "cast_rays",
          [](const BeamModel& b, const py::object& pose, const DoubleArray& angles, double range_max,
             const py::object& laser_offset) {
            if (angles.ndim() != 1) throw InvalidArgument("cast_rays: angles must be a 1-D array");
            if (!(range_max > 0) || !std::isfinite(range_max)) {
              throw InvalidArgument("cast_rays: range_max must be positive and finite");
            }
            SE2d laser = PoseFromTuple(pose, "pose");
            if (!laser_offset.is_none()) laser = laser * PoseFromTuple(laser_offset, "laser_offset");
            DoubleArray out(angles.shape(0));
            double* r = out.mutable_data();
            const double* a = angles.data();
            const Eigen::Vector2d origin = laser.translation();
            const double theta = laser.theta();
            {
              py::gil_scoped_release release;
              for (py::ssize_t i = 0; i < angles.shape(0); ++i) r[i] = b.CastRay(origin, theta + a[i], range_max);
            }
            return out;
          },
          py::arg("pose"), py::arg("angles"), py::arg("range_max"), py::arg("laser_offset") = py::none(),
          "The ranges a laser at robot pose (x, y, theta) measures along `angles` (the laser's frame) [m]: a "
          "simulated scan without noise (range_max where the ray meets nothing)")
      .def("probability", &BeamModel::BeamProbability, py::arg("z"), py::arg("expected"), py::arg("range_max"),
           "One beam's p(z | z*)");
}

void BindOptions(py::module_& lo) {
  lo.def(
      "methods", [] { return EnumNameVector<MclMethod>(); },
      "The methods' names: 'mcl' (plain), 'amcl' (Augmented MCL), 'cmcl' (costmap), 'acmcl' (both), 'auto' "
      "(acmcl until localised, then amcl: the default)");
  py::class_<MclOptions>(lo, "MclOptions",
                         "The options of MonteCarloLocalizer2D (frontends/localization/monte_carlo_localizer_2d.h); "
                         "the defaults are `tether mcl`'s. The nested options (motion, likelihood_field, beam, kld) "
                         "are changed in place: options.kld.enabled = True.")
      .def(py::init<>())
      .def_property(
          "method", [](const MclOptions& o) { return std::string(ToString(o.method)); },
          [](MclOptions& o, const std::string& s) { o.method = NamedEnum<MclMethod>(s, "method"); },
          "'mcl', 'amcl' (default), 'cmcl' or 'acmcl'")
      .def_readwrite("particles", &MclOptions::particles, "The count (the first count with KLD sampling)")
      .def_readwrite("motion", &MclOptions::motion, "OdometryMotionModel")
      .def_property(
          "motion_alphas",
          [](const MclOptions& o) {
            return py::make_tuple(o.motion.alpha1, o.motion.alpha2, o.motion.alpha3, o.motion.alpha4);
          },
          [](MclOptions& o, const std::vector<double>& a) {
            if (a.size() != 4) throw InvalidArgument("motion_alphas must be four numbers (alpha1..alpha4)");
            o.motion = {a[0], a[1], a[2], a[3]};
          },
          "(alpha1, alpha2, alpha3, alpha4) of motion, as tether mcl --motion-alphas")
      .def_property(
          "model", [](const MclOptions& o) { return std::string(ToString(o.model)); },
          [](MclOptions& o, const std::string& s) { o.model = NamedEnum<MeasurementModelType>(s, "model"); },
          "The measurement model: 'likelihood-field' (default) or 'beam'")
      .def_readwrite("likelihood_field", &MclOptions::likelihood_field, "LikelihoodFieldOptions")
      .def_readwrite("beam", &MclOptions::beam, "BeamModelOptions")
      .def_readwrite("max_beams", &MclOptions::max_beams, "Beams scored per scan (0: all)")
      .def_readwrite("range_cap", &MclOptions::range_cap, "The scans' maximum range capped at this [m] (0: not)")
      .def_readwrite("alpha_slow", &MclOptions::alpha_slow, "Augmented MCL's slow filter")
      .def_readwrite("alpha_fast", &MclOptions::alpha_fast, "... and fast filter (alpha_slow < alpha_fast <= 1)")
      .def_readwrite("kld", &MclOptions::kld, "KldOptions")
      .def_readwrite("robot_radius", &MclOptions::robot_radius, "The costmap's inflation (cmcl, acmcl) [m]")
      .def_readwrite("update_min_translation", &MclOptions::update_min_translation,
                     "add_scan updates once the odometry moved this far [m] ...")
      .def_readwrite("update_min_rotation", &MclOptions::update_min_rotation, "... or turned this much [rad]")
      .def_readwrite("cluster_xy", &MclOptions::cluster_xy, "Bins of the estimate's clusters and of KLD sampling [m]")
      .def_readwrite("cluster_theta", &MclOptions::cluster_theta, "[rad]")
      .def_readwrite("threads", &MclOptions::threads,
                     "Threads weighting the particles (0: every core; the result does not depend on it)")
      .def_readwrite("seed", &MclOptions::seed, "The random stream's seed")
      .def("is_valid", &Validity<MclOptions>, "(ok, why)");

  py::class_<MclRunOptions>(lo, "MclRunOptions", "The options of MclLocalization2D: the filter's and the start.")
      .def(py::init<>())
      .def_readwrite("filter", &MclRunOptions::filter, "MclOptions (changed in place)")
      .def_property(
          "initial_pose",
          [](const MclRunOptions& o) -> py::object {
            if (!o.has_initial_pose) return py::none();
            return py::make_tuple(o.initial_pose.x(), o.initial_pose.y(), o.initial_pose.theta());
          },
          [](MclRunOptions& o, const py::object& p) {
            o.has_initial_pose = !p.is_none();
            o.initial_pose = o.has_initial_pose ? PoseFromTuple(p, "initial_pose") : SE2d();
          },
          "(x, y, theta) where the robot starts in the map; None (default): a global start")
      .def_readwrite("initial_sigma", &MclRunOptions::initial_sigma,
                     "(3,) standard deviations around the initial pose [m, m, rad]")
      .def_readwrite("start_time", &MclRunOptions::start_time, "Scans from this many seconds into the log on [s]")
      .def_readwrite("snapshot_scans", &MclRunOptions::snapshot_scans,
                     "The picture's particle clouds at these scans (counted from 1); [] : `snapshots` spread out")
      .def_readwrite("snapshots", &MclRunOptions::snapshots)
      .def("is_valid", &Validity<MclRunOptions>, "(ok, why)");
}

void BindStep(py::module_& lo) {
  py::class_<MclStep>(lo, "MclStep", "What one add_scan did, and the estimate at that scan.")
      .def_readonly("updated", &MclStep::updated,
                    "False: the robot had not moved enough; the estimate followed the odometry")
      .def_readonly("redrawn", &MclStep::redrawn, "Particles the costmap re-drew")
      .def_readonly("injected", &MclStep::injected, "Random particles the resampling injected")
      .def_readonly("particles", &MclStep::particles, "The count after the step")
      .def_readonly("w_avg", &MclStep::w_avg, "Log of the update's average likelihood (per beam)")
      .def_readonly("w_slow", &MclStep::w_slow, "Log of the slow filter after the update")
      .def_readonly("w_fast", &MclStep::w_fast, "Log of the fast filter after the update")
      .def_property_readonly(
          "pose", [](const MclStep& s) { return PoseArray(s.estimate.pose); }, "(3,) x, y, theta of the estimate")
      .def_property_readonly(
          "covariance", [](const MclStep& s) { return Eigen::Matrix3d(s.estimate.covariance); }, "(3, 3)")
      .def_property_readonly(
          "cluster_weight", [](const MclStep& s) { return s.estimate.cluster_weight; },
          "The share of the weight in the cluster the estimate comes from")
      .def_property_readonly(
          "clusters", [](const MclStep& s) { return s.estimate.clusters; }, "Clusters found")
      .def("as_dict",
           [](const MclStep& s) {
             py::dict d;
             d["updated"] = s.updated;
             d["redrawn"] = s.redrawn;
             d["injected"] = s.injected;
             d["particles"] = s.particles;
             d["w_avg"] = s.w_avg;
             d["w_slow"] = s.w_slow;
             d["w_fast"] = s.w_fast;
             d["pose"] = PoseArray(s.estimate.pose);
             d["covariance"] = Eigen::Matrix3d(s.estimate.covariance);
             d["cluster_weight"] = s.estimate.cluster_weight;
             d["clusters"] = s.estimate.clusters;
             return d;
           })
      .def("__repr__", [](const MclStep& s) {
        return std::string("MclStep(updated=") + (s.updated ? "True" : "False") + ", pose=(" +
               FormatDouble(s.estimate.pose.x()) + ", " + FormatDouble(s.estimate.pose.y()) + ", " +
               FormatDouble(s.estimate.pose.theta()) + "), particles=" + std::to_string(s.particles) +
               ", injected=" + std::to_string(s.injected) + ", redrawn=" + std::to_string(s.redrawn) + ")";
      });
}

void BindFilter(py::module_& lo) {
  lo.def("kld_sample_count", &KldSampleCount, py::arg("k"), py::arg("epsilon"), py::arg("delta"),
         "The samples KLD sampling asks for where they fill k bins");
  lo.def(
      "low_variance_resample",
      [](const DoubleArray& weights, int count, double u) {
        if (weights.ndim() != 1 || weights.shape(0) < 1) {
          throw InvalidArgument("low_variance_resample: weights must be a 1-D array of 1 or more");
        }
        if (count < 0) throw InvalidArgument("low_variance_resample: count must not be negative");
        if (!(u >= 0 && u < 1)) throw InvalidArgument("low_variance_resample: u must lie in [0, 1)");
        std::vector<double> w(weights.data(), weights.data() + weights.shape(0));
        double sum = 0;
        for (const double x : w) {
          if (!(x >= 0) || !std::isfinite(x)) {
            throw InvalidArgument("low_variance_resample: weights must be finite and not negative");
          }
          sum += x;
        }
        if (!(sum > 0)) throw InvalidArgument("low_variance_resample: the weights sum to 0");
        for (double& x : w) x /= sum;
        const std::vector<int> idx = LowVarianceResample(w, count, u);
        py::array_t<int> out(static_cast<py::ssize_t>(idx.size()));
        std::copy(idx.begin(), idx.end(), out.mutable_data());
        return out;
      },
      py::arg("weights"), py::arg("count"), py::arg("u"),
      "Low-variance (systematic) resampling: the indices of `count` draws from `weights` (normalised here) with "
      "one uniform number u in [0, 1)");

  py::class_<MonteCarloLocalizer2D>(
      lo, "MonteCarloLocalizer2D",
      "The particle filter over poses (x, y, theta) in a known map, step by step: initialize_global() or "
      "initialize_gaussian(), then per scan predict(odom_from, odom_to), update(ranges, ...), resample() -- or "
      "add_scan(...), which does the three as the robot moves. update and add_scan release the GIL; any other call "
      "on the filter meanwhile raises tether.InUseError.")
      .def(py::init([](const MapPtr& map, const MclOptions& options) {
             return std::make_unique<MonteCarloLocalizer2D>(map, options);
           }),
           py::arg("map"), py::arg("options") = MclOptions())
      .def(
          "initialize_global",
          [](MonteCarloLocalizer2D& f) {
            InUse::Check(&f, kFilter, InUse::Access::kWrite);
            f.InitializeGlobal();
          },
          "Particles spread uniformly over the free space (cmcl, acmcl: the costmap's valid cells), equal weights")
      .def(
          "initialize_gaussian",
          [](MonteCarloLocalizer2D& f, const py::object& mean, const Eigen::Matrix3d& covariance) {
            InUse::Check(&f, kFilter, InUse::Access::kWrite);
            f.InitializeGaussian(PoseFromTuple(mean, "mean"), covariance);
          },
          py::arg("mean"), py::arg("covariance"),
          "Particles drawn from a Gaussian around mean (x, y, theta) with the (3, 3) covariance")
      .def(
          "set_particles",
          [](MonteCarloLocalizer2D& f, const DoubleArray& particles) {
            std::vector<Particle> p = ParticlesFrom(particles);
            InUse::Check(&f, kFilter, InUse::Access::kWrite);
            f.SetParticles(p);
          },
          py::arg("particles"),
          "(N, 4) x, y, theta, weight (normalised here; all equal where they sum to 0), or (N, 3) with equal weights")
      .def_property_readonly(
          "particles",
          [](const MonteCarloLocalizer2D& f) {
            InUse::Check(&f, kFilter, InUse::Access::kRead);
            return ParticlesArray(f.particles());
          },
          "(N, 4) float64 copy: x, y, theta, weight (the weights sum to 1)")
      .def(
          "predict",
          [](MonteCarloLocalizer2D& f, const py::object& from, const py::object& to) {
            const SE2d a = PoseFromTuple(from, "odom_from"), b = PoseFromTuple(to, "odom_to");
            InUse::Check(&f, kFilter, InUse::Access::kWrite);
            RequireParticles(f, "predict");
            f.Predict(a, b);
          },
          py::arg("odom_from"), py::arg("odom_to"),
          "Moves every particle by the odometry's motion from odom_from to odom_to (x, y, theta each), with noise")
      .def(
          "update",
          [](MonteCarloLocalizer2D& f, const DoubleArray& ranges, double angle_min, double angle_increment,
             double range_max, double range_min, double stamp, const py::object& odometry,
             const py::object& laser_offset) {
            const lidar::LaserScan scan =
                MakeScan(ranges, angle_min, angle_increment, stamp, range_min, range_max, odometry, laser_offset);
            const InUse::Scope updating(&f, kFilter, "MonteCarloLocalizer2D.update", InUse::Access::kWrite);
            RequireParticles(f, "update");
            py::gil_scoped_release release;
            f.Update(scan);
          },
          TETHER_SCAN_ARGS,
          "Weights the particles by the scan (cmcl, acmcl: re-drawing those in the invalid zone "
          "first). " TETHER_SCAN_DOC)
      .def(
          "resample",
          [](MonteCarloLocalizer2D& f) {
            InUse::Check(&f, kFilter, InUse::Access::kWrite);
            RequireParticles(f, "resample");
            f.Resample();
          },
          "Low-variance resampling (amcl, acmcl: with random particles at injection_probability; with KLD sampling "
          "to the count the spread needs)")
      .def(
          "add_scan",
          [](MonteCarloLocalizer2D& f, const DoubleArray& ranges, double angle_min, double angle_increment,
             double range_max, double range_min, double stamp, const py::object& odometry,
             const py::object& laser_offset) {
            if (odometry.is_none()) {
              throw InvalidArgument(
                  "add_scan: the scan has no odometry; Monte Carlo localisation moves its particles by the robot's "
                  "odometry (give odometry=(x, y, theta))");
            }
            const lidar::LaserScan scan =
                MakeScan(ranges, angle_min, angle_increment, stamp, range_min, range_max, odometry, laser_offset);
            const InUse::Scope adding(&f, kFilter, "MonteCarloLocalizer2D.add_scan", InUse::Access::kWrite);
            py::gil_scoped_release release;
            return f.AddScan(scan);
          },
          TETHER_SCAN_ARGS,
          "One step of a log: the first call initialises (globally unless particles were set) and updates; later ones "
          "predict by the odometry since the last update and update and resample once the robot moved enough. "
          "Returns an MclStep. " TETHER_SCAN_DOC)
      .def(
          "estimate",
          [](const MonteCarloLocalizer2D& f) {
            InUse::Check(&f, kFilter, InUse::Access::kRead);
            RequireParticles(f, "estimate");
            const PoseEstimate e = f.Estimate();
            return py::make_tuple(PoseArray(e.pose), Eigen::Matrix3d(e.covariance));
          },
          "(pose (3,), covariance (3, 3)): the weighted mean of the heaviest cluster and its covariance")
      .def_property_readonly(
          "redrawn",
          [](const MonteCarloLocalizer2D& f) {
            InUse::Check(&f, kFilter, InUse::Access::kRead);
            return BoolArray(f.redrawn());
          },
          "(N,) bool: re-drawn by the costmap in the last update")
      .def_property_readonly(
          "injected",
          [](const MonteCarloLocalizer2D& f) {
            InUse::Check(&f, kFilter, InUse::Access::kRead);
            return BoolArray(f.injected());
          },
          "(N,) bool: injected at random by the last resample")
      .def_property_readonly("injection_probability", Reads(&MonteCarloLocalizer2D::InjectionProbability, kFilter),
                             "The probability with which the next resample injects a random particle")
      .def_property_readonly("log_w_slow", Reads(&MonteCarloLocalizer2D::log_w_slow, kFilter),
                             "Log of the slow filter (-inf before the first update)")
      .def_property_readonly("log_w_fast", Reads(&MonteCarloLocalizer2D::log_w_fast, kFilter),
                             "Log of the fast filter (-inf before the first update)")
      .def(
          "set_recovery_filters",
          [](MonteCarloLocalizer2D& f, double log_w_slow, double log_w_fast) {
            InUse::Check(&f, kFilter, InUse::Access::kWrite);
            f.SetRecoveryFilters(log_w_slow, log_w_fast);
          },
          py::arg("log_w_slow"), py::arg("log_w_fast"), "Sets the recovery filters (their logs)")
      .def_property_readonly(
          "options",
          [](const MonteCarloLocalizer2D& f) {
            InUse::Check(&f, kFilter, InUse::Access::kRead);
            return f.options();
          },
          "A copy of the options")
      .def_property_readonly(
          "costmap",
          [](const MonteCarloLocalizer2D& f) -> py::object {
            InUse::Check(&f, kFilter, InUse::Access::kRead);
            if (f.costmap() == nullptr) return py::none();
            return py::cast(*f.costmap());
          },
          "A copy of the costmap (cmcl, acmcl), or None");
}

py::dict ErrorDict(const LocalizationError& e) {
  py::dict d;
  d["matched"] = e.matched;
  d["mean_error"] = e.mean_error;
  d["max_error"] = e.max_error;
  d["mean_heading_error"] = e.mean_heading_error;
  d["converged_index"] = e.converged_index;
  d["converged_stamp"] = e.converged_stamp;
  d["mean_error_converged"] = e.mean_error_converged;
  d["mean_heading_error_converged"] = e.mean_heading_error_converged;
  return d;
}

void BindRun(py::module_& lo) {
  py::class_<MclLocalization2D>(
      lo, "MclLocalization2D",
      "Monte Carlo localisation of a whole log (the class behind `tether mcl`): run(log_path) or add_scan(...), "
      "then trajectory(), summary(), outputs() or write(folder). run and add_scan release the GIL; any other call "
      "meanwhile raises tether.InUseError.")
      .def(py::init([](const MapPtr& map, const MclRunOptions& options) {
             return std::make_unique<MclLocalization2D>(map, options);
           }),
           py::arg("map"), py::arg("options") = MclRunOptions())
      .def(
          "add_scan",
          [](MclLocalization2D& r, const DoubleArray& ranges, double angle_min, double angle_increment,
             double range_max, double range_min, double stamp, const py::object& odometry,
             const py::object& laser_offset, long scan_number) {
            const lidar::LaserScan scan =
                MakeScan(ranges, angle_min, angle_increment, stamp, range_min, range_max, odometry, laser_offset);
            const InUse::Scope adding(&r, kRun, "MclLocalization2D.add_scan", InUse::Access::kWrite);
            if (scan_number <= 0) scan_number = static_cast<long>(r.steps().size()) + 1;
            py::gil_scoped_release release;
            return r.AddScan(scan, scan_number);
          },
          py::arg("ranges"), py::kw_only(), py::arg("angle_min"), py::arg("angle_increment"), py::arg("range_max"),
          py::arg("range_min") = 0.0, py::arg("stamp") = 0.0, py::arg("odometry") = py::none(),
          py::arg("laser_offset") = py::none(), py::arg("scan_number") = 0,
          "The next scan (its odometry is required); scan_number counts the scans from 1 for the records (0: the "
          "next). Returns an MclStep. " TETHER_SCAN_DOC)
      .def(
          "run",
          [](MclLocalization2D& r, const py::object& log_path, long max_scans, const std::string& scan_topic,
             const std::string& odom_topic) {
            const std::string path = PathOf(log_path);
            lidar::LidarReadOptions ro;
            ro.scan_topic = scan_topic;
            ro.odom_topic = odom_topic;
            std::string why;
            if (!ro.IsValid(&why)) throw InvalidArgument("run: " + why);
            const InUse::Scope running(&r, kRun, "MclLocalization2D.run", InUse::Access::kWrite);
            py::gil_scoped_release release;
            const lidar::LidarLog log = lidar::ReadLidarLog(path, ro);
            r.Run(log, max_scans);
          },
          py::arg("log"), py::arg("max_scans") = 0, py::arg("scan_topic") = "/scan", py::arg("odom_topic") = "/odom",
          "Reads a CARMEN log or ROS 1 bag (as tether mcl does) and localises its scans from start_time on (the first "
          "max_scans; 0: all). A scan the filter refuses raises tether.ParseError naming its file:line.")
      .def(
          "trajectory",
          [](const MclLocalization2D& r) {
            InUse::Check(&r, kRun, InUse::Access::kRead);
            return TrajectoryArray(r.Trajectory());
          },
          "(N, 4) float64: stamp, x, y, theta of the estimate at every scan given")
      .def(
          "summary",
          [](const MclLocalization2D& r) {
            InUse::Check(&r, kRun, InUse::Access::kRead);
            return r.report().Summary();
          },
          "The lines `tether mcl` prints")
      .def_property_readonly(
          "report",
          [](const MclLocalization2D& r) {
            InUse::Check(&r, kRun, InUse::Access::kRead);
            const MclRunReport& p = r.report();
            py::dict d;
            d["scans"] = p.scans;
            d["skipped"] = p.skipped;
            d["updates"] = p.updates;
            d["injected"] = p.injected;
            d["redrawn"] = p.redrawn;
            d["particle_beams"] = p.particle_beams;
            d["logged_seconds"] = p.logged_seconds;
            d["total_seconds"] = p.total_seconds;
            d["update_seconds"] = p.update_seconds;
            d["final_particles"] = p.final_particles;
            return d;
          },
          "The run's figures as a dict (scans, skipped, updates, injected, redrawn, ...)")
      .def_property_readonly(
          "particles",
          [](const MclLocalization2D& r) {
            InUse::Check(&r, kRun, InUse::Access::kRead);
            return ParticlesArray(r.filter().particles());
          },
          "(N, 4) the filter's particles now: x, y, theta, weight")
      .def(
          "outputs",
          [](const MclLocalization2D& r) {
            InUse::Check(&r, kRun, InUse::Access::kRead);
            py::dict d;
            for (const lidar::LidarOutput& o : r.Outputs()) d[py::str(o.name)] = py::bytes(o.bytes);
            return d;
          },
          "{file name: bytes}: trajectory.tum, mcl_steps.csv and mcl.png, as tether mcl writes them")
      .def(
          "write",
          [](const MclLocalization2D& r, const py::object& folder_path) {
            const std::string folder = PathOf(folder_path);
            InUse::Check(&r, kRun, InUse::Access::kRead);
            std::filesystem::create_directories(folder);
            OutputSet outputs;
            std::vector<std::pair<OutputFile*, std::string>> staged;
            for (lidar::LidarOutput& o : r.Outputs()) {
              staged.emplace_back(&outputs.Add((std::filesystem::path(folder) / o.name).string(), o.what),
                                  std::move(o.bytes));
            }
            for (auto& [file, bytes] : staged) file->Stage(bytes);
            outputs.CommitAll();
          },
          py::arg("folder"), "Writes the files `tether mcl -o FOLDER` writes (all or nothing).");

  lo.def(
      "compare_with_reference",
      [](const DoubleArray& estimate, const DoubleArray& reference, double converged_metres, double converged_radians,
         double tolerance) {
        return ErrorDict(CompareWithReference(TrajectoryFrom(estimate, "estimate"),
                                              TrajectoryFrom(reference, "reference"), converged_metres,
                                              converged_radians, tolerance));
      },
      py::arg("estimate"), py::arg("reference"), py::arg("converged_metres") = 0.5,
      py::arg("converged_radians") = 10 * M_PI / 180, py::arg("tolerance") = 1e-3,
      "A localisation's poses against a reference, both (N, 4) stamp, x, y, theta in the map's frame, matched by "
      "stamp within tolerance [s]: a dict of matched, mean_error, max_error [m], mean_heading_error [rad], "
      "converged_index (-1: never within the bounds to the end), converged_stamp, mean_error_converged, "
      "mean_heading_error_converged");
  lo.def(
      "read_tum", [](const py::object& path) { return TrajectoryArray(lidar::ReadTumFile(PathOf(path))); },
      py::arg("path"), "A TUM trajectory file as an (N, 4) array: stamp, x, y, theta");
}

#undef TETHER_SCAN_ARGS
#undef TETHER_SCAN_DOC

}  // namespace

void BindLocalization(py::module_& m) {
  py::module_ lo = m.def_submodule(
      "localization",
      "Monte Carlo localisation in a known map: OccupancyMap2D, the filter step by step (MonteCarloLocalizer2D) "
      "and a whole log (MclLocalization2D, the class behind `tether mcl`)");
  BindMap(lo);
  BindModelOptions(lo);
  BindOptions(lo);
  BindStep(lo);
  BindFilter(lo);
  BindRun(lo);
}
TETHER_PYTHON_PART(80, BindLocalization);

}  // namespace python
}  // namespace tether
