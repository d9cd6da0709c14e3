// The front-ends as thin wrappers: tether.odometry (the two-wheel motion model, the odometry
// front-end), tether.ekf (EKF-SLAM, UKF-SLAM, the landmark world simulator), and
// tether.simulate (the CLI's pose-graph simulator).
#include "common.h"
#include "tether/frontends/ekf/ekf_slam.h"
#include "tether/frontends/ekf/experiment.h"
#include "tether/frontends/ekf/fast_slam.h"
#include "tether/frontends/ekf/invariant_ekf_slam.h"
#include "tether/frontends/ekf/landmark_graph.h"
#include "tether/frontends/ekf/landmark_simulator.h"
#include "tether/frontends/ekf/ukf_slam.h"
#include "tether/frontends/odometry/diff_drive.h"
#include "tether/frontends/odometry/odometry_front_end.h"
#include "tether/frontends/odometry/odometry_run.h"
#include "tether/frontends/simulation/simulate.h"

namespace tether {
namespace python {

namespace {

using odometry::Control;

Eigen::MatrixXd PosesArray(const std::vector<SE2d>& poses) {
  Eigen::MatrixXd a(static_cast<Eigen::Index>(poses.size()), 3);
  for (std::size_t i = 0; i < poses.size(); ++i)
    a.row(static_cast<Eigen::Index>(i)) << poses[i].x(), poses[i].y(), poses[i].theta();
  return a;
}

Eigen::MatrixXd PointsArray(const std::vector<Eigen::Vector2d>& points) {
  Eigen::MatrixXd a(static_cast<Eigen::Index>(points.size()), 2);
  for (std::size_t i = 0; i < points.size(); ++i) a.row(static_cast<Eigen::Index>(i)) = points[i].transpose();
  return a;
}

void BindOdometry(py::module_& od) {
  py::class_<Control>(od, "Control", "A two-wheel robot's control: forward speed v [m/s], turn rate w [rad/s].")
      .def(py::init([](double v, double w) {
             return Control{v, w};
           }),
           py::arg("v") = 0.0, py::arg("w") = 0.0)
      .def_readwrite("v", &Control::v)
      .def_readwrite("w", &Control::w)
      .def("__repr__",
           [](const Control& u) { return "Control(v=" + std::to_string(u.v) + ", w=" + std::to_string(u.w) + ")"; });
  od.def("from_wheel_speeds", &odometry::FromWheelSpeeds, py::arg("v_left"), py::arg("v_right"), py::arg("wheel_base"));
  od.def("from_ticks", &odometry::FromTicks, py::arg("ticks_left"), py::arg("ticks_right"), py::arg("meters_per_tick"),
         py::arg("wheel_base"), py::arg("dt"));
  od.def("control_covariance_from_wheels", &odometry::ControlCovarianceFromWheels, py::arg("sigma_left"),
         py::arg("sigma_right"), py::arg("wheel_base"), "(2, 2) covariance of (v, w).");
  od.def(
      "relative_motion", [](const Control& u, double dt) { return odometry::RelativeMotion(u, dt); }, py::arg("u"),
      py::arg("dt"), "(3,) = (dx, dy, dtheta) in the start frame: the exact arc.");
  od.def(
      "move",
      [](const SE2d& pose, const Control& u, double dt, bool jacobians) -> py::object {
        Eigen::Matrix3d dp;
        Eigen::Matrix<double, 3, 2> du;
        const SE2d next = odometry::Move(pose, u, dt, jacobians ? &dp : nullptr, jacobians ? &du : nullptr);
        if (!jacobians) return py::cast(next);
        return py::make_tuple(next, dp, du);
      },
      py::arg("pose"), py::arg("u"), py::arg("dt"), py::arg("jacobians") = false,
      "The pose after driving u for dt; with jacobians=True (pose, d/dpose (3, 3), d/du (3, 2)).");
  py::class_<odometry::OdometryNoise>(od, "OdometryNoise")
      .def(py::init<>())
      .def_readwrite("control", &odometry::OdometryNoise::control, "(2, 2) covariance of (v, w) per second")
      .def_readwrite("floor_sigma", &odometry::OdometryNoise::floor_sigma);
  py::class_<odometry::MotionIntegrator>(od, "MotionIntegrator",
                                         "Composes controls into one relative motion with its covariance.")
      .def(py::init<const odometry::OdometryNoise&>(), py::arg("noise") = odometry::OdometryNoise())
      .def("add", &odometry::MotionIntegrator::Add, py::arg("u"), py::arg("dt"))
      .def("add_motion", &odometry::MotionIntegrator::AddMotion, py::arg("delta"), py::arg("dt"),
           "A measured SE2 motion, composed exactly, with its arc control's covariance.")
      .def_property_readonly("relative", &odometry::MotionIntegrator::relative)
      .def_property_readonly("covariance", &odometry::MotionIntegrator::covariance)
      .def("information", &odometry::MotionIntegrator::Information)
      .def_property_readonly("steps", &odometry::MotionIntegrator::steps)
      .def("reset", &odometry::MotionIntegrator::Reset);
  py::class_<odometry::OdometryFrontEndOptions>(od, "OdometryFrontEndOptions")
      .def(py::init<>())
      .def_readwrite("noise", &odometry::OdometryFrontEndOptions::noise)
      .def_readwrite("controls_per_pose", &odometry::OdometryFrontEndOptions::controls_per_pose)
      .def_readwrite("letter", &odometry::OdometryFrontEndOptions::letter)
      .def_readwrite("start", &odometry::OdometryFrontEndOptions::start)
      .def_readwrite("prior_sigma", &odometry::OdometryFrontEndOptions::prior_sigma);
  py::class_<odometry::OdometryFrontEnd>(od, "OdometryFrontEnd",
                                         "Turns controls into poses and BetweenSE2 factors for the smoother.")
      .def(py::init<const odometry::OdometryFrontEndOptions&>(),
           py::arg("options") = odometry::OdometryFrontEndOptions())
      .def("add", &odometry::OdometryFrontEnd::Add, py::arg("u"), py::arg("dt"), "True where a new pose was made.")
      .def("add_motion", &odometry::OdometryFrontEnd::AddMotion, py::arg("delta"), py::arg("dt"),
           "A measured SE2 motion (wheel odometry's pose change); True where a new pose was made.")
      .def(
          "take_new",
          [](odometry::OdometryFrontEnd& f) {
            FactorGraph g;
            Values v;
            f.TakeNew(&g, &v);
            return py::make_tuple(std::move(g), std::move(v));
          },
          "(factors, values) made since the last call, for IncrementalSmoother.update.")
      .def_property_readonly("trajectory", &odometry::OdometryFrontEnd::trajectory)
      .def("pose_key", &odometry::OdometryFrontEnd::PoseKey, py::arg("i"));
  od.def("control_between", &odometry::ControlBetween, py::arg("start"), py::arg("end"), py::arg("dt"),
         "The control (v, w) that carries a robot from start to end along one arc in dt seconds.");
  py::class_<odometry::OdometryReport>(od, "OdometryReport")
      .def_readonly("messages", &odometry::OdometryReport::messages)
      .def_readonly("steps", &odometry::OdometryReport::steps)
      .def_readonly("merged", &odometry::OdometryReport::merged)
      .def_readonly("sideways", &odometry::OdometryReport::sideways)
      .def_readonly("poses", &odometry::OdometryReport::poses)
      .def_readonly("distance", &odometry::OdometryReport::distance)
      .def_readonly("turned", &odometry::OdometryReport::turned)
      .def_readonly("duration", &odometry::OdometryReport::duration)
      .def("__str__", &odometry::OdometryReport::Summary);
  od.def(
      "run_track",
      [](const std::vector<double>& stamps, const std::vector<SE2d>& poses,
         const odometry::OdometryFrontEndOptions& options) {
        odometry::OdometryRunResult r = odometry::RunOdometry(stamps, poses, options);
        return py::make_tuple(std::move(r.graph), std::move(r.values), std::move(r.stamps), std::move(r.report));
      },
      py::arg("stamps"), py::arg("poses"), py::arg("options") = odometry::OdometryFrontEndOptions(),
      "A whole odometry track (stamps, SE2 poses) through the front-end, as `tether odometry` runs it: (graph, "
      "values, stamps of the graph's poses, report). Each step becomes the arc's control (control_between).");
}

template <class Filter>
void BindFilter(py::module_& ek, const char* name, const char* doc) {
  py::class_<Filter>(ek, name, doc)
      .def(py::init<const SE2d&, const Eigen::Matrix3d&, const ekf::FilterOptions&>(), py::arg("start"),
           py::arg("start_cov"), py::arg("options") = ekf::FilterOptions())
      .def("predict", &Filter::Predict, py::arg("u"), py::arg("dt"))
      .def("update", &Filter::Update, py::arg("observations"),
           "Per observation the landmark index it was associated with (-1: dropped).")
      .def_property_readonly("pose", &Filter::pose)
      .def_property_readonly("pose_cov", &Filter::pose_cov)
      .def_property_readonly("landmark_count", &Filter::landmark_count)
      .def("landmark", &Filter::landmark, py::arg("i"))
      .def("landmark_cov", &Filter::landmark_cov, py::arg("i"))
      .def("creator_id", &Filter::creator_id, py::arg("i"))
      .def(
          "landmarks",
          [](const Filter& f) {
            std::vector<Eigen::Vector2d> p;
            for (int i = 0; i < f.landmark_count(); ++i) p.push_back(f.landmark(i));
            return PointsArray(p);
          },
          "(N, 2)")
      .def_property_readonly("mean", &Filter::mean, "(3 + 2N,) = pose, then landmarks")
      .def_property_readonly("cov", &Filter::cov)
      .def_property_readonly("wrong_associations", &Filter::wrong_associations)
      .def_property_readonly("dropped_observations", &Filter::dropped_observations)
      .def_property_readonly("near_observations", &Filter::near_observations,
                             "Observations not used because their range was below options.min_range.");
}

// The graph the filters seed (tether/frontends/ekf/landmark_graph.h).
void BindLandmarkGraph(py::module_& ek) {
  py::class_<ekf::Track>(ek, "Track",
                         "A run over a world: poses (steps + 1), per step and observation the landmark index it was "
                         "taken for (-1: dropped), per landmark the true id it was created from and its estimates.")
      .def_readonly("poses", &ekf::Track::poses)
      .def(
          "poses_array", [](const ekf::Track& t) { return PosesArray(t.poses); }, "(steps + 1, 3)")
      .def_readonly("association", &ekf::Track::association)
      .def_readonly("creator_id", &ekf::Track::creator_id)
      .def(
          "first_seen", [](const ekf::Track& t) { return PointsArray(t.first_seen); }, "(N, 2) initial values")
      .def(
          "landmarks", [](const ekf::Track& t) { return PointsArray(t.landmarks); }, "(N, 2) final estimates")
      .def_readonly("wrong_associations", &ekf::Track::wrong_associations)
      .def_readonly("dropped_observations", &ekf::Track::dropped_observations);
  ek.def(
      "run_filter", [](ekf::EkfSlam& f, const ekf::LandmarkWorld& w) { return ekf::RunFilter(&f, w); },
      py::arg("filter"), py::arg("world"));
  ek.def(
      "run_filter", [](ekf::UkfSlam& f, const ekf::LandmarkWorld& w) { return ekf::RunFilter(&f, w); },
      py::arg("filter"), py::arg("world"));
  ek.def(
      "run_filter", [](ekf::InvariantEkfSlam& f, const ekf::LandmarkWorld& w) { return ekf::RunFilter(&f, w); },
      py::arg("filter"), py::arg("world"), "Runs the filter over the world (predict, update per step); its Track.");
  ek.def("truth_track", &ekf::TruthTrack, py::arg("world"));
  ek.def("dead_reckoning_track", &ekf::DeadReckoningTrack, py::arg("world"));
  py::class_<ekf::LandmarkGraphOptions>(ek, "LandmarkGraphOptions")
      .def(py::init<>())
      .def_property(
          "control_cov", [](const ekf::LandmarkGraphOptions& o) { return Eigen::Matrix2d(o.odometry.control); },
          [](ekf::LandmarkGraphOptions& o, const Eigen::Matrix2d& c) { o.odometry.control = c; })
      .def_property(
          "floor_sigma", [](const ekf::LandmarkGraphOptions& o) { return o.odometry.floor_sigma; },
          [](ekf::LandmarkGraphOptions& o, double f) { o.odometry.floor_sigma = f; })
      .def_readwrite("measurement_cov", &ekf::LandmarkGraphOptions::measurement_cov)
      .def_readwrite("prior_sigma", &ekf::LandmarkGraphOptions::prior_sigma);
  ek.def("build_landmark_graph", &ekf::BuildLandmarkGraph, py::arg("world"), py::arg("association"),
         py::arg("options") = ekf::LandmarkGraphOptions(),
         "The graph from the world's odometry and the associated observations (keys x_i, l_j).");
  ek.def("seed_values", &ekf::SeedValues, py::arg("track"));
  py::class_<ekf::SmoothedTrack>(ek, "SmoothedTrack")
      .def_readonly("track", &ekf::SmoothedTrack::track)
      .def_readonly("chi2", &ekf::SmoothedTrack::chi2)
      .def_readonly("online_seconds", &ekf::SmoothedTrack::online_seconds)
      .def_readonly("finish_seconds", &ekf::SmoothedTrack::finish_seconds)
      .def_readonly("updates", &ekf::SmoothedTrack::updates)
      .def_readonly("finish", &ekf::SmoothedTrack::finish);
  ek.def(
      "smooth_landmark_run",
      [](const ekf::LandmarkWorld& w, const ekf::Track& seed, const ekf::LandmarkGraphOptions& o) {
        py::gil_scoped_release release;
        return ekf::SmoothLandmarkRun(w, seed, o);
      },
      py::arg("world"), py::arg("seed"), py::arg("options") = ekf::LandmarkGraphOptions(),
      "Feeds the graph to the incremental smoother step by step from the seed's values, then solves it to the batch "
      "optimum.");
  ek.def("trajectory_rmse", &ekf::TrajectoryRmse, py::arg("poses"), py::arg("truth"));
  ek.def("landmark_rmse", &ekf::LandmarkRmse, py::arg("track"), py::arg("truth"),
         "NaN where no landmark has a true id");
  ek.def("pose_key", &ekf::PoseKey, py::arg("i"));
  ek.def("landmark_key", &ekf::LandmarkKey, py::arg("j"));
}

// The experiment `tether ekf-demo` runs (tether/frontends/ekf/experiment.h).
void BindExperiment(py::module_& ek) {
  py::class_<EkfDemoSetup>(ek, "ExperimentSetup", "The world and what the experiment runs (steps, noise, ...).")
      .def(py::init<>())
      .def_readwrite("steps", &EkfDemoSetup::steps)
      .def_readwrite("range_sigma", &EkfDemoSetup::range_sigma)
      .def_readwrite("bearing_sigma", &EkfDemoSetup::bearing_sigma)
      .def_readwrite("consistency", &EkfDemoSetup::consistency)
      .def_readwrite("invariant_min_range", &EkfDemoSetup::invariant_min_range)
      .def_readwrite("min_range", &EkfDemoSetup::min_range)
      .def_readwrite("invariant_iterations", &EkfDemoSetup::invariant_iterations)
      .def_readwrite("graphs", &EkfDemoSetup::graphs)
      .def_readwrite("fastslam_particles", &EkfDemoSetup::fastslam_particles,
                     "FastSLAM 1.0 and 2.0 rows, one per particle count (empty: none)")
      .def_readwrite("fastslam_one", &EkfDemoSetup::fastslam_one)
      .def_readwrite("fastslam_two", &EkfDemoSetup::fastslam_two);
  py::class_<EkfDemoRow>(ek, "ExperimentRow", "One method's figures, one entry per seed.")
      .def_readonly("method", &EkfDemoRow::method)
      .def_readonly("trajectory_rmse", &EkfDemoRow::trajectory_rmse)
      .def_readonly("landmark_rmse", &EkfDemoRow::landmark_rmse)
      .def_readonly("wrong_associations", &EkfDemoRow::wrong_associations)
      .def_readonly("seconds", &EkfDemoRow::seconds)
      .def_readonly("failures", &EkfDemoRow::failures)
      .def_readonly("failure_note", &EkfDemoRow::failure_note);
  py::class_<EkfDemoConfig>(ek, "ExperimentResult", "One experiment and association over the seeds.")
      .def_readonly("experiment", &EkfDemoConfig::experiment)
      .def_readonly("nearest_neighbour", &EkfDemoConfig::nearest_neighbour)
      .def_readonly("observations", &EkfDemoConfig::observations)
      .def_readonly("rows", &EkfDemoConfig::rows)
      .def(
          "table", [](const EkfDemoConfig& c) { return EkfDemoTable({c}); }, "The ekf-demo table (markdown).");
  ek.def(
      "run_experiment",
      [](int experiment, bool nearest_neighbour, int seeds, std::uint64_t first_seed, const EkfDemoSetup& setup) {
        if (experiment != 1 && experiment != 2) throw InvalidArgument("experiment must be 1 or 2");
        if (seeds < 1) throw InvalidArgument("seeds must be at least 1");
        py::gil_scoped_release release;
        return RunEkfExperiment(experiment, nearest_neighbour, seeds, first_seed, setup);
      },
      py::arg("experiment") = 1, py::arg("nearest_neighbour") = false, py::arg("seeds") = 20, py::arg("first_seed") = 1,
      py::arg("setup") = EkfDemoSetup(),
      "Runs dead reckoning, the EKF, UKF and invariant EKF and the graphs they seed over the seeds, as "
      "`tether ekf-demo` does.");
  ek.def(
      "experiment_svg",
      [](int experiment, bool nearest_neighbour, std::uint64_t seed, const EkfDemoSetup& setup) {
        py::gil_scoped_release release;
        return EkfDemoSvg(experiment, nearest_neighbour, seed, setup);
      },
      py::arg("experiment") = 1, py::arg("nearest_neighbour") = false, py::arg("seed") = 1,
      py::arg("setup") = EkfDemoSetup(), "The picture `tether ekf-demo --plot` draws, as SVG text.");
}

// FastSLAM 1.0 and 2.0 (tether/frontends/ekf/fast_slam.h), step by step.
void BindFastSlam(py::module_& ek) {
  py::class_<ekf::FastSlamOptions>(ek, "FastSlamOptions")
      .def(py::init<>())
      .def_readwrite("filter", &ekf::FastSlamOptions::filter, "noise, association and its thresholds, min_range")
      .def_property(
          "version", [](const ekf::FastSlamOptions& o) { return std::string(ToString(o.version)); },
          [](ekf::FastSlamOptions& o, const std::string& s) {
            if (!FromString(s, &o.version)) {
              throw InvalidArgument("unknown FastSLAM version '" + s + "'; use " +
                                    EnumNameList<ekf::FastSlamVersion>());
            }
          },
          "1.0 (samples the motion) or 2.0 (the proposal sees the observations)")
      .def_readwrite("particles", &ekf::FastSlamOptions::particles)
      .def_readwrite("resample_fraction", &ekf::FastSlamOptions::resample_fraction,
                     "resample where the effective sample size falls below this share of the particles")
      .def_readwrite("new_landmark_d2", &ekf::FastSlamOptions::new_landmark_d2)
      .def_readwrite("motion_floor", &ekf::FastSlamOptions::motion_floor)
      .def_readwrite("seed", &ekf::FastSlamOptions::seed);
  py::class_<ekf::FastSlam>(ek, "FastSlam",
                            "FastSLAM: per particle a path sample and one 2x2 EKF per landmark (shared between "
                            "particles until changed). predict(u, dt), then update(observations), each step.")
      .def(py::init([](const SE2d& start, const Eigen::Matrix3d& start_cov, const ekf::FastSlamOptions& o) {
             return std::make_unique<ekf::FastSlam>(start, start_cov, o);
           }),
           py::arg("start"), py::arg("start_cov") = Eigen::Matrix3d::Zero(),
           py::arg("options") = ekf::FastSlamOptions())
      .def("predict", &ekf::FastSlam::Predict, py::arg("u"), py::arg("dt"),
           "Resamples where the weights call for it, then moves the particles (1.0 samples; 2.0 predicts).")
      .def("update", &ekf::FastSlam::Update, py::arg("observations"),
           "Weighs and corrects; per observation the landmark index the heaviest particle took it for (-1: none).")
      .def_property_readonly(
          "particles",
          [](const ekf::FastSlam& f) {
            std::vector<SE2d> p;
            for (int i = 0; i < f.particle_count(); ++i) p.push_back(f.particle_pose(i));
            return PosesArray(p);
          },
          "(N, 3) particle poses (x, y, theta)")
      .def_property_readonly(
          "weights",
          [](const ekf::FastSlam& f) {
            const std::vector<double> w = f.weights();
            return Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(w.data(), static_cast<Eigen::Index>(w.size())));
          },
          "(N,) normalised weights")
      .def_property_readonly("effective_sample_size", &ekf::FastSlam::effective_sample_size)
      .def_property_readonly("best_particle", &ekf::FastSlam::best_particle)
      .def_property_readonly("pose", &ekf::FastSlam::pose, "the weighted mean")
      .def_property_readonly("pose_cov", &ekf::FastSlam::pose_cov, "the weighted covariance (x, y, theta)")
      .def(
          "landmarks",
          [](const ekf::FastSlam& f, int particle) {
            if (particle < 0) particle = f.best_particle();
            if (particle >= f.particle_count()) throw InvalidArgument("no particle " + std::to_string(particle));
            std::vector<Eigen::Vector2d> p;
            for (int j = 0; j < f.landmark_count(particle); ++j) p.push_back(f.landmark(particle, j).mean);
            return PointsArray(p);
          },
          py::arg("particle") = -1, "(L, 2) one particle's landmark means (-1: the heaviest)")
      .def(
          "landmark_covs",
          [](const ekf::FastSlam& f, int particle) {
            if (particle < 0) particle = f.best_particle();
            if (particle >= f.particle_count()) throw InvalidArgument("no particle " + std::to_string(particle));
            std::vector<Eigen::Matrix2d> c;
            for (int j = 0; j < f.landmark_count(particle); ++j) c.push_back(f.landmark(particle, j).cov);
            return c;
          },
          py::arg("particle") = -1, "one particle's landmark covariances (-1: the heaviest)")
      .def_property_readonly(
          "best_path", [](const ekf::FastSlam& f) { return PosesArray(f.best_path()); },
          "(steps + 1, 3) the heaviest particle's path")
      .def_property_readonly("wrong_associations", &ekf::FastSlam::wrong_associations)
      .def_property_readonly("dropped_observations", &ekf::FastSlam::dropped_observations)
      .def_property_readonly("resamplings", &ekf::FastSlam::resamplings);
  ek.def(
      "run_fast_slam", [](ekf::FastSlam& f, const ekf::LandmarkWorld& w) { return ekf::RunFastSlam(&f, w); },
      py::arg("filter"), py::arg("world"), "The whole world through the filter, as ekf-demo runs it: a Track.");
}

void BindEkf(py::module_& ek) {
  BindExperiment(ek);
  py::class_<ekf::Observation>(ek, "Observation", "A range [m] and bearing [rad] to a landmark; id -1 where unknown.")
      .def(py::init([](double r, double b, int id) {
             return ekf::Observation{r, b, id};
           }),
           py::arg("range"), py::arg("bearing"), py::arg("id") = -1)
      .def_readwrite("range", &ekf::Observation::range)
      .def_readwrite("bearing", &ekf::Observation::bearing)
      .def_readwrite("id", &ekf::Observation::id);
  py::class_<ekf::FilterOptions>(ek, "FilterOptions")
      .def(py::init<>())
      .def_readwrite("control_cov", &ekf::FilterOptions::control_cov)
      .def_readwrite("measurement_cov", &ekf::FilterOptions::measurement_cov)
      .def_property(
          "association", [](const ekf::FilterOptions& o) { return std::string(ToString(o.association)); },
          [](ekf::FilterOptions& o, const std::string& s) {
            if (!FromString(s, &o.association)) {
              throw InvalidArgument("unknown association '" + s + "'; use " + EnumNameList<ekf::DataAssociation>());
            }
          },
          "known, or nearest (nearest neighbour with a Mahalanobis gate; also nn)")
      .def_readwrite("gate", &ekf::FilterOptions::gate)
      .def_readwrite("new_landmark", &ekf::FilterOptions::new_landmark)
      .def_readwrite("update_iterations", &ekf::FilterOptions::update_iterations,
                     "InvariantEkfSlam: Gauss-Newton iterations per correction (1: the plain update).")
      .def_readwrite("min_range", &ekf::FilterOptions::min_range,
                     "Observations whose measured range is below this are not used (every filter).");
  BindFilter<ekf::EkfSlam>(ek, "EkfSlam", "EKF-SLAM with range-bearing landmarks.");
  BindFilter<ekf::UkfSlam>(ek, "UkfSlam", "UKF-SLAM with range-bearing landmarks.");
  BindFilter<ekf::InvariantEkfSlam>(
      ek, "InvariantEkfSlam",
      "The right-invariant EKF for SLAM: the EKF's problem with the error defined on the group of the robot and "
      "landmarks; consistent where the EKF is overconfident (docs/front_ends.md).");

  BindFastSlam(ek);

  py::class_<ekf::LandmarkWorldOptions>(ek, "LandmarkWorldOptions")
      .def(py::init<>())
      .def_readwrite("steps", &ekf::LandmarkWorldOptions::steps)
      .def_readwrite("dt", &ekf::LandmarkWorldOptions::dt)
      .def_readwrite("command", &ekf::LandmarkWorldOptions::command)
      .def_readwrite("landmarks", &ekf::LandmarkWorldOptions::landmarks)
      .def_readwrite("map_size", &ekf::LandmarkWorldOptions::map_size)
      .def_readwrite("max_range", &ekf::LandmarkWorldOptions::max_range)
      .def_readwrite("control_sigma", &ekf::LandmarkWorldOptions::control_sigma)
      .def_readwrite("measurement_sigma", &ekf::LandmarkWorldOptions::measurement_sigma)
      .def_readwrite("seed", &ekf::LandmarkWorldOptions::seed);
  py::class_<ekf::LandmarkWorld>(ek, "LandmarkWorld")
      .def_readonly("dt", &ekf::LandmarkWorld::dt)
      .def_readonly("truth", &ekf::LandmarkWorld::truth, "steps + 1 true poses")
      .def(
          "truth_array", [](const ekf::LandmarkWorld& w) { return PosesArray(w.truth); }, "(steps + 1, 3)")
      .def(
          "landmarks", [](const ekf::LandmarkWorld& w) { return PointsArray(w.landmarks); }, "(L, 2) true positions")
      .def_readonly("odometry", &ekf::LandmarkWorld::odometry, "the controls as measured")
      .def_readonly("observations", &ekf::LandmarkWorld::observations, "per step, the observations");
  ek.def(
      "simulate_landmark_world",
      [](const ekf::LandmarkWorldOptions& o) {
        std::string why;
        if (!o.IsValid(&why)) throw InvalidArgument("LandmarkWorldOptions: " + why);
        return ekf::SimulateLandmarkWorld(o);
      },
      py::arg("options") = ekf::LandmarkWorldOptions());
  ek.def("dead_reckoning", &ekf::DeadReckoning, py::arg("world"));
  BindLandmarkGraph(ek);
}

}  // namespace

void BindFrontends(py::module_& m) {
  py::module_ od = m.def_submodule("odometry", "The two-wheel motion model and the odometry front-end.");
  BindOdometry(od);
  py::module_ ek = m.def_submodule("ekf", "EKF-SLAM and UKF-SLAM with range-bearing landmarks.");
  BindEkf(ek);
  m.def(
      "simulate",
      [](const std::string& world, int poses, std::uint64_t seed, double translation_sigma, double rotation_sigma,
         double loop_closure_probability, int landmarks, double landmark_range) {
        SimulateOptions o;
        if (!FromString(world, &o.world)) {
          throw InvalidArgument("unknown world '" + world + "'; use " + EnumNameList<SimWorld>());
        }
        o.poses = poses;
        o.seed = seed;
        o.translation_sigma = translation_sigma;
        o.rotation_sigma = rotation_sigma;
        o.loop_closure_probability = loop_closure_probability;
        o.landmarks = landmarks;
        o.landmark_range = landmark_range;
        std::string why;
        if (!o.IsValid(&why)) throw InvalidArgument("simulate: " + why);
        SimulatedGraph s = Simulate(o);
        return py::make_tuple(std::move(s.graph), std::move(s.initial), std::move(s.ground_truth));
      },
      py::arg("world") = "manhattan", py::arg("poses") = 500, py::arg("seed") = 1, py::arg("translation_sigma") = 0.05,
      py::arg("rotation_sigma") = 0.01, py::arg("loop_closure_probability") = 0.3, py::arg("landmarks") = 100,
      py::arg("landmark_range") = 4.0,
      "(graph, initial, ground_truth) of a simulated world, as `tether simulate` makes it: 'manhattan' (SE2 "
      "grid walk), 'sphere' (SE3), 'landmarks' (SE2 poses and 2D points).");
}
TETHER_PYTHON_PART(50, BindFrontends);

}  // namespace python
}  // namespace tether
