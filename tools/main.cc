// tether: the command-line program. `tether --help` lists the commands.
#include <CLI/CLI.hpp>
#include <csignal>
#include <iostream>

#include "tether/tools/bench.h"
#include "tether/tools/commands.h"
#include "tether/tools/ekf_demo.h"
#include "tether/tools/lidar_degrade.h"
#include "tether/tools/lidar_eval.h"
#include "tether/tools/lidar_simulate.h"
#include "tether/tools/lidar_slam.h"
#include "tether/tools/option_checks.h"
#include "tether/tools/replay.h"

int main(int argc, char** argv) {
  // A reader that goes away (`tether optimize ... | head -1`) must not end the run: writes to
  // it fail quietly and the outputs are still written. A file-size limit (ulimit -f) becomes
  // an error naming the file, not a signal that leaves it half written.
  std::signal(SIGPIPE, SIG_IGN);
  std::signal(SIGXFSZ, SIG_IGN);
  CLI::App app{"tether: factor-graph optimisation for SLAM"};
  app.require_subcommand(1);

  tether::OptimizeCommand opt;
  CLI::App* optimize = app.add_subcommand("optimize", "Optimise a g2o or TORO graph file");
  optimize->add_option("input", opt.input, "Graph file (.g2o, TORO .graph, or iSAM landmark text; see --format)")
      ->required();
  optimize->add_option("-o,--output", opt.output, "Write the optimised graph (g2o)");
  optimize->add_option("--solver", opt.solver, "gn | lm | dogleg | ceres (Ceres' Levenberg-Marquardt)")
      ->capture_default_str();
  optimize->add_option("--linear", opt.linear, "cholmod | ldlt | qr | a plugin's linear solver (pcg)")
      ->capture_default_str();
  optimize->add_option("--covariance", opt.covariance,
                       "After the solve, marginal covariances of these ids (comma-separated) or of all");
  optimize->add_option("--covariance-out", opt.covariance_output, "Covariance file (default: OUTPUT.cov)")
      ->needs("--covariance");
  optimize->add_option("--init", opt.init, "initial guess: file | spanning-tree | chordal")->capture_default_str();
  optimize->add_option("--max-iterations", opt.max_iterations, "Iteration limit")->capture_default_str();
  optimize->add_option("--time-limit", opt.time_limit, "Seconds (0: none)")->capture_default_str();
  optimize->add_option("--threads", opt.threads, "Threads assembling the normal equations (1 to 256)")
      ->capture_default_str();
  optimize
      ->add_option("--max-reuse-iterations", opt.max_reuse_iterations,
                   "Conjugate-gradient iterations a step may take with an earlier factorisation before H is "
                   "factorised afresh (0: factorise every step)")
      ->capture_default_str();
  optimize
      ->add_option("--format", opt.format,
                   "auto (by name and content), g2o, toro or isam (iSAM's ODOMETRY/EDGE2/LANDMARK lines; "
                   "docs/landmarks.md)")
      ->capture_default_str();
  optimize
      ->add_option("--isam-noise", opt.isam_noise,
                   "iSAM files: sqrt-information (iSAM's reading of the numbers) or covariance (GTSAM's)")
      ->capture_default_str();
  optimize
      ->add_option("--repair-information", opt.repair_information,
                   "none | nearest-pd | isotropic: what to do with information matrices that are not "
                   "positive definite")
      ->capture_default_str();
  optimize->add_option("--plot", opt.plot, "Write an SVG of the file's start and the result (and the ground truth)");
  optimize->add_option("--ground-truth", opt.ground_truth,
                       "g2o file with the true values: report the absolute trajectory error of the start and "
                       "the result, and draw the truth in --plot");
  optimize->add_flag("-q,--quiet", opt.quiet, "No iteration table");
  optimize
      ->add_option("--plugin", opt.plugins,
                   "Load a plugin (factor types, linear solvers; .so path or name) first; repeatable")
      ->allow_extra_args(false);
  optimize->add_flag("--allow-partial-vertices", opt.allow_partial_vertices,
                     "Give vertices without a VERTEX line initial values composed from edges");
  optimize
      ->add_option("--robust", opt.robust,
                   "Robust loss rule SELECTOR=KERNEL:SCALE: loop=huber:1.0 (edges between non-consecutive poses), "
                   "all=cauchy:2, or a g2o tag (EDGE_SE2=dcs:1); kernels huber, cauchy, tukey, gm, dcs; repeatable")
      ->allow_extra_args(false);
  CLI::Option* gnc = optimize->add_flag("--gnc", opt.gnc,
                                        "Graduated non-convexity on the loop closures (edges between non-consecutive "
                                        "poses); reports the closures it rejects");
  optimize
      ->add_option("--gnc-kernel", opt.gnc_kernel, "With --gnc: gm (Geman-McClure) or tls (truncated least squares)")
      ->capture_default_str()
      ->needs(gnc);
  optimize
      ->add_option("--gnc-start", opt.gnc_start,
                   "With --gnc: chunked (DCS solved chunk by chunk in id order) or least-squares (the classic start)")
      ->capture_default_str()
      ->needs(gnc);
  optimize->add_flag("--switchable", opt.switchable,
                     "Switchable constraints on the loop closures (a switch variable per closure with a prior); "
                     "reports the closures it switches off");
  optimize
      ->add_option("--switch-prior-sigma", opt.switch_prior_sigma,
                   "With --switchable: the switch prior's sigma (0: from the chi2 0.99 quantile of the closure's "
                   "dimension; 1 is Sünderhauf's)")
      ->capture_default_str();
  optimize->add_option("--rejected-out", opt.rejected_output,
                       "With --gnc or --switchable: write the rejected loop closures here (default: "
                       "OUTPUT.rejected.g2o)");

  tether::SimulateCommand sim;
  CLI::App* simulate = app.add_subcommand("simulate", "Write a synthetic graph with known ground truth");
  simulate->add_option("world", sim.world, "manhattan | sphere | landmarks | lidar")->required();
  simulate->add_option("--poses", sim.poses, "Number of poses")->capture_default_str();
  simulate->add_option("--seed", sim.seed, "Random seed")->capture_default_str();
  simulate->add_option("-o,--output", sim.output, "Output g2o file (initial values: composed odometry)")->required();
  simulate->add_option("--ground-truth", sim.ground_truth, "Also write the true values to this g2o file");
  tether::SimulateLidarCommand slc;
  simulate->add_option("--truth", slc.truth, "lidar: write the true trajectory here (TUM text)");
  simulate->add_option("--scans", slc.scans, "lidar: scans at 10 Hz (default 3000)");
  simulate->add_option("--beams", slc.beams, "lidar: beams over 360 degrees (default 360)");
  simulate->add_flag("--no-odometry", slc.no_odometry, "lidar: scans without odometry");
  simulate->add_option("--preset", slc.preset, "lidar: lds (6 m, 0.02 m noise, 5% of the beams dropped, 5 Hz)");

  tether::PluginsListCommand plist;
  CLI::App* plugins = app.add_subcommand("plugins", "Factor plugins");
  plugins->require_subcommand(1);
  CLI::App* list = plugins->add_subcommand("list", "List loaded plugins and every registered factor type");
  list->add_option("--plugin", plist.plugins, "Load this plugin first; repeatable")->allow_extra_args(false);

  tether::BenchCommand bc;
  CLI::App* bench = app.add_subcommand(
      "bench", "Time solver configurations on graph files, or replays (--replay) (docs/benchmarking.md)");
  bench->add_option("files", bc.files, "Graph files (.g2o, TORO .graph, or iSAM landmark text)");
  bench->add_option("--solvers", bc.solvers, "Comma-separated: gn, lm, dogleg, ceres")->capture_default_str();
  bench->add_option("--linear", bc.linear, "Comma-separated: cholmod, ldlt, qr")->capture_default_str();
  bench->add_option("--init", bc.init, "Comma-separated: file, spanning-tree, chordal")->capture_default_str();
  bench->add_option("--threads", bc.threads, "Comma-separated thread counts (default: the solver's)");
  bench->add_option("--repeat", bc.repeat, "Runs per configuration")->capture_default_str();
  bench->add_option("--format", bc.format, "md | csv")->capture_default_str();
  bench->add_option("-o,--output", bc.output, "Write the table here instead of stdout");
  bench->add_flag("--replay", bc.replay,
                  "Replay each file through the incremental smoother (as tether replay) and tabulate update "
                  "latencies, chi2 and peak memory");
  bench->add_option("--outliers", bc.outliers,
                    "Outlier benchmark: comma-separated rates of false loop closures (0.1,0.3,0.5)");
  bench->add_option("--seeds", bc.seeds, "With --outliers: comma-separated seeds")->capture_default_str();
  bench
      ->add_option("--methods", bc.methods,
                   "With --outliers: none, huber, dcs, cdcs (DCS in chunks), gnc, gnc-ls (GNC from least squares), sc "
                   "(switchable constraints), sc:SIGMA (switch prior sigma)")
      ->capture_default_str();
  bench->add_flag("--grouped", bc.grouped, "With --outliers: false closures in consistent clusters of 5");
  bench->add_option("--plugin", bc.plugins, "Load a factor plugin (.so path or name) first; repeatable")
      ->allow_extra_args(false);

  tether::ReplayCommand rc;
  CLI::App* replay =
      app.add_subcommand("replay", "Feed a graph file into the incremental smoother pose by pose and time each update");
  replay->add_option("input", rc.input, "Graph file (.g2o, TORO .graph, or iSAM landmark text)")->required();
  replay->add_option("--every", rc.options.every, "Update the estimate every N-th pose")->capture_default_str();
  replay
      ->add_option("--check", rc.options.check,
                   "Every K-th update, solve the graph so far in batch (untimed) and compare")
      ->capture_default_str();
  replay->add_option("-o,--output", rc.options.output, "Write the final estimate (g2o)");
  replay->add_option("--plot", rc.plot, "Write an SVG of every update's latency (mean, p99 and max marked)");
  replay->add_flag("-q,--quiet", rc.quiet, "Only the summary lines");
  replay
      ->add_option("--relinearize-threshold", rc.options.smoother.relinearize_threshold,
                   "Re-linearise a variable whose step exceeds this (SmootherOptions::relinearize_threshold)")
      ->capture_default_str();
  replay
      ->add_option("--relinearize-sigmas", rc.options.smoother.relinearize_sigmas,
                   "Re-linearise a variable whose step exceeds this many standard deviations "
                   "(SmootherOptions::relinearize_sigmas)")
      ->capture_default_str();
  replay
      ->add_option(
          "--iterate-ratio", rc.options.smoother.iterate_ratio,
          "Solve again within an update while a step is this many times too large (SmootherOptions::iterate_ratio)")
      ->capture_default_str();
  replay
      ->add_option("--iterate-fraction", rc.options.smoother.iterate_fraction,
                   "When solving again, also re-linearise steps beyond this fraction of the thresholds "
                   "(SmootherOptions::iterate_fraction)")
      ->capture_default_str();
  replay
      ->add_option("--iterate-share", rc.options.smoother.iterate_share,
                   "Solve again within an update while more than this share of the variables have steps too large "
                   "(SmootherOptions::iterate_share)")
      ->capture_default_str();
  replay->add_flag_function(
      "--no-refine-new", [&rc](std::int64_t) { rc.options.smoother.refine_new_values = false; },
      "Start new variables at the given values, not at the optimum of their new factors "
      "(SmootherOptions::refine_new_values)");
  replay
      ->add_option("--rounds", rc.options.smoother.rounds_per_update,
                   "Factorise-solve rounds per update (SmootherOptions::rounds_per_update)")
      ->capture_default_str();
  const std::map<std::string, tether::SmootherFactorization> factorizations = {
      {"auto", tether::SmootherFactorization::kAuto},
      {"left-looking", tether::SmootherFactorization::kLeftLooking},
      {"multifrontal", tether::SmootherFactorization::kMultifrontal}};
  replay
      ->add_option("--factorization", rc.options.smoother.factorization,
                   "auto, left-looking or multifrontal (SmootherOptions::factorization)")
      ->transform(CLI::CheckedTransformer(factorizations, CLI::ignore_case))
      ->capture_default_str();
  replay
      ->add_option("--wildfire", rc.options.smoother.wildfire_threshold,
                   "Back-substitute below a variable only where its step changed by more than this "
                   "(SmootherOptions::wildfire_threshold)")
      ->capture_default_str();
  const std::map<std::string, tether::SmootherMode> modes = {{"factor", tether::SmootherMode::kFactor},
                                                             {"local", tether::SmootherMode::kLocal}};
  replay
      ->add_option("--mode", rc.options.smoother.mode,
                   "factor (keep a Cholesky factor of the whole system) or local (solve each update over a region "
                   "around it, with batch solves now and then) (SmootherOptions::mode)")
      ->transform(CLI::CheckedTransformer(modes, CLI::ignore_case))
      ->capture_default_str();
  replay
      ->add_option("--local-tolerance", rc.options.smoother.local_tolerance,
                   "local: grow the region while an edge variable alone could lower chi2 by more than this share of "
                   "chi2 per variable "
                   "(SmootherOptions::local_tolerance)")
      ->capture_default_str();
  replay
      ->add_option("--local-hops", rc.options.smoother.local_hops,
                   "local: the first region reaches this many factors from the update's variables "
                   "(SmootherOptions::local_hops)")
      ->capture_default_str();
  replay
      ->add_option("--local-max-region", rc.options.smoother.local_max_region,
                   "local: solve in batch where a region would grow beyond this many variables "
                   "(SmootherOptions::local_max_region)")
      ->capture_default_str();
  replay
      ->add_option("--local-batch-gap", rc.options.smoother.local_batch_gap,
                   "local: a batch solve once the edge gains since the last reach this share of chi2 "
                   "(SmootherOptions::local_batch_gap)")
      ->capture_default_str();
  replay
      ->add_option("--local-batch-correction", rc.options.smoother.local_batch_correction,
                   "local: solve in batch an update whose local solve lowers chi2 by more than this share of it "
                   "(SmootherOptions::local_batch_correction)")
      ->capture_default_str();
  replay
      ->add_option("--local-batch-share", rc.options.smoother.local_batch_share,
                   "local: a batch solve at the latest once the updates since the last reach this share of the "
                   "variables "
                   "(SmootherOptions::local_batch_share)")
      ->capture_default_str();

  tether::EkfDemoCommand ec;
  CLI::App* ekf_demo = app.add_subcommand(
      "ekf-demo", "Dead reckoning, EKF-SLAM, UKF-SLAM and the pose graph they seed, on simulated landmark worlds");
  ekf_demo->add_option("--seeds", ec.seeds, "Number of seeds (worlds) per experiment")->capture_default_str();
  ekf_demo->add_option("--first-seed", ec.first_seed, "The first seed")->capture_default_str();
  ekf_demo
      ->add_option("--experiments", ec.experiments, "1 (control noise std 0.1 m/s, pi/18 rad/s), 2 (doubled), or 1,2")
      ->capture_default_str();
  ekf_demo
      ->add_option("--association", ec.association, "known, nn (nearest neighbour with a Mahalanobis gate), or both")
      ->capture_default_str();
  ekf_demo->add_option("--steps", ec.setup.steps, "Time steps per run (dt = 1 s)")->capture_default_str();
  ekf_demo->add_option("--range-sigma", ec.setup.range_sigma, "Range noise std [m]")->capture_default_str();
  ekf_demo->add_option("--bearing-sigma", ec.setup.bearing_sigma, "Bearing noise std [rad]")->capture_default_str();
  ekf_demo
      ->add_option("--invariant-min-range", ec.setup.invariant_min_range,
                   "The invariant EKF uses no observation nearer than this [m] (negative: 1.5 range sigmas)")
      ->capture_default_str();
  ekf_demo->add_option("--min-range", ec.setup.min_range, "The EKF and UKF use no landmark nearer than this [m]")
      ->capture_default_str();
  ekf_demo
      ->add_option("--invariant-iterations", ec.setup.invariant_iterations,
                   "Gauss-Newton iterations of each invariant EKF correction (1: the plain update)")
      ->capture_default_str();
  ekf_demo->add_flag_function(
      "--no-graph", [&ec](std::int64_t) { ec.setup.graphs = false; },
      "The filters alone: no graph seeded by them (much faster)");
  ekf_demo->add_flag("--nees", ec.setup.consistency,
                     "Also the consistency of every pose estimate: the NEES per step averaged over the seeds, "
                     "against its 95% interval (the graphs: the smoother's online estimate and marginal)");
  ekf_demo->add_option("-o,--output", ec.output, "Also write the table (markdown) here");
  ekf_demo->add_option("--plot", ec.plot,
                       "Draw truth, dead reckoning, EKF, UKF and the optimised graph of the first seed (SVG)");
  ekf_demo->add_flag("-q,--quiet", ec.quiet, "Only the table");

  tether::LidarEvalCommand lc;
  tether::LidarCommand lsc;
  CLI::App* lidar = app.add_subcommand(
      "lidar", "2D LiDAR SLAM over a laser log (CARMEN or ROS 1 bag): trajectory, pose graph and occupancy map");
  lidar->add_option("log", lsc.log, "The log: CARMEN (.clf, .log, plain or gzip) or a ROS 1 bag")->required();
  lidar->add_option("-o,--output", lsc.output_dir, "Output folder (made if missing)")->required();
  tether::lidar::LocalSlamOptions& lo = lsc.options.local;
  tether::lidar::PoseGraphOptions& po = lsc.options.pose_graph;
  lidar->add_flag_function(
      "--no-loop-closure", [&po](std::int64_t) { po.loop_closure = false; },
      "Local SLAM and the pose graph without loop closures");
  // An option of `tether lidar` with its default shown in --help.
  const auto lidar_option = [lidar](const char* name, auto& value, const char* help) {
    lidar->add_option(name, value, help)->capture_default_str();
  };
  lidar_option("--threads", po.threads,
               "Background loop-closure search threads (default: the machine's cores; 0: "
               "inline; the result does not depend on it)");
  lidar_option("--max-scans", lsc.max_scans, "Only the first N scans (0: all)");
  lidar_option("--scans-per-submap", lo.submaps.scans_per_submap, "Scans in a finished submap");
  lidar_option("--resolution", lo.submaps.resolution, "Grid resolution [m]");
  lidar_option("--search-every", po.search_every_n_scans, "Loop-closure search for every N-th scan");
  lidar_option("--update-every", po.update_every_n_scans,
               "Scans per smoother update (in between, new scans follow local SLAM from the last estimate)");
  lidar_option("--min-score", po.min_score, "Branch and bound's score threshold");
  lidar_option("--local-sigma-t", po.local_translation_sigma, "Local constraints' translation sigma [m]");
  lidar_option("--local-sigma-r", po.local_rotation_sigma, "Local constraints' rotation sigma [rad]");
  lidar_option("--consecutive-sigma-t", po.consecutive_translation_sigma,
               "Consecutive scans' constraints (local SLAM's relative pose): translation sigma [m] (0: none)");
  lidar_option("--consecutive-sigma-r", po.consecutive_rotation_sigma,
               "Consecutive scans' constraints: rotation sigma [rad] (0: none)");
  lidar_option("--local-huber", po.local_huber_delta,
               "Huber loss on the local and consecutive constraints: delta on the whitened error (0: none)");
  lidar_option("--loop-sigma-t", po.loop_translation_sigma, "Loop closures' translation sigma [m]");
  lidar_option("--loop-sigma-r", po.loop_rotation_sigma, "Loop closures' rotation sigma [rad]");
  lidar_option("--rival-ratio", po.rival_ratio,
               "Drop a loop closure where a candidate 0.3 m or 2 degrees away scores above this share of its "
               "score (0: keep them)");
  lidar_option("--confirm-t", po.confirm_translation,
               "A match becomes a loop closure once a match of another scan to the same submap agrees with it "
               "through local SLAM's relative pose within this [m] and --confirm-r (0: every match is added)");
  lidar_option("--confirm-r", po.confirm_rotation, "See --confirm-t [rad]");
  lidar_option("--max-search-distance", po.max_search_distance,
               "Search a scan against the finished submaps whose origin lies this near it [m]");
  lidar_option("--search-voxel", po.search_voxel_size,
               "Loop closures: branch and bound scores the scan's points thinned by a voxel filter of this edge "
               "[m] (0: the matching points)");
  lidar_option("--search-window", po.search.linear_search_window,
               "Loop closures: branch and bound searches +- this far in x and y around the estimate [m]");
  lidar_option("--search-window-growth", po.search_window_growth,
               "Loop closures: the window's half side grows by this many metres per metre between the scan and "
               "the submap in the graph (0: fixed)");
  lidar_option("--max-search-window", po.max_search_window,
               "Loop closures: the window's half side grows up to this [m]");
  lidar_option("--search-angle-growth", po.search_angle_growth,
               "Loop closures: the window's rotations grow by this many radians per metre between the scan and "
               "the submap in the graph (0: fixed)");
  lidar_option("--max-search-angle", po.max_search_angle,
               "Loop closures: the window's rotations grow up to this [rad]");
  lidar_option("--search-angle", lsc.search_angle_deg,
               "Loop closures: branch and bound searches +- this many degrees around the estimate");
  lidar_option("--huber", po.huber_delta, "Loop closures' Huber delta (on the whitened error)");
  lidar_option("--match-translation-weight", lo.refiner.weights.translation,
               "Local matching: the scan-match factor's weight on the distance to the odometry's prediction "
               "[1/m]");
  lidar_option("--match-rotation-weight", lo.refiner.weights.rotation,
               "Local matching: the scan-match factor's weight on the turn from the odometry's prediction [1/rad]");
  lidar_option("--correlative-translation-weight", lo.correlative.translation_delta_cost_weight,
               "Local matching: the correlative search's preference for the prediction's translation [1/m]");
  lidar_option("--correlative-rotation-weight", lo.correlative.rotation_delta_cost_weight,
               "Local matching: the correlative search's preference for the prediction's heading [1/rad]");
  lidar_option("--correlative-angle", lsc.correlative_angle_deg,
               "Local matching: the correlative search's rotations, +- this many degrees around the prediction");
  lidar_option("--min-match-probability", lo.min_match_probability,
               "Local matching: a scan whose matched points read a lower mean probability in the submap takes "
               "the prediction (0: always trust the match)");
  lidar_option("--still-distance", lo.still_distance,
               "Local matching: where the odometry moved less than this [m] and turned less than --still-angle "
               "since the scan before, the scan keeps the pose before, unmatched (0: always match)");
  lidar_option("--still-angle", lo.still_angle, "Local matching: see --still-distance [rad]");
  lidar_option("--weak-window", lo.weak_prediction_linear_window,
               "Scan-only scans (no odometry): a weak first match is searched again +- this far [m]");
  lidar_option("--max-range", lsc.read.limits.max_range, "Drop ranges beyond this [m] (0: the log's)");
  lidar_option("--odometry", lsc.odometry,
               "Where the odometry comes from: auto, scan-line, interpolated, or none (scan-only: every scan "
               "predicted from the scans before)");
  lidar_option("--scan-topic", lsc.read.scan_topic, "Bags: the sensor_msgs/LaserScan topic");
  lidar_option("--odom-topic", lsc.read.odom_topic, "Bags: the nav_msgs/Odometry topic");
  lidar
      ->add_option("--laser-offset", lsc.laser_offset,
                   "The laser's pose on the robot, x,y,theta [m, m, rad], for every scan instead of the log's")
      ->delimiter(',')
      ->expected(3);
  lidar->add_option("--ground-truth", lsc.ground_truth,
                    "A true trajectory (TUM text, e.g. from tether simulate lidar --truth): print the absolute "
                    "trajectory error against it");
  lidar_option("--self-check-every", lsc.options.self_check.sample_every,
               "Self-check every N-th scan against the map made at other times (0: no check)");
  lidar_option("--progress-every", lsc.progress_every, "Scans between progress lines (0: none)");
  lidar->add_flag("-q,--quiet", lsc.quiet, "No progress lines");
  CLI::App* lidar_eval = app.add_subcommand(
      "lidar-eval",
      "Score a trajectory on the relations of Kuemmerle et al. (mean +- std of the relative-pose errors)");
  lidar_eval
      ->add_option("trajectory", lc.trajectory,
                   "TUM text (timestamp x y z qx qy qz qw), or a laser log (CARMEN .clf/.log, plain or .gz, or a ROS 1 "
                   "bag) whose scans' odometry poses are scored")
      ->required();
  lidar_eval->add_option("relations", lc.relations, "Relations file: t1 t2 x y z roll pitch yaw per line")->required();
  lidar_eval->add_option("--format", lc.format, "auto, tum or log")->capture_default_str();
  lidar_eval->add_option("--odometry", lc.odometry, "Logs: auto, scan-line, interpolated or none")
      ->capture_default_str();
  lidar_eval->add_option("--scan-topic", lc.scan_topic, "Bags: the sensor_msgs/LaserScan topic")->capture_default_str();
  lidar_eval->add_option("--odom-topic", lc.odom_topic, "Bags: the nav_msgs/Odometry topic")->capture_default_str();
  lidar_eval->add_option("--tolerance", lc.tolerance, "Seconds between a relation's stamp and the nearest pose")
      ->capture_default_str();
  lidar_eval->add_option("--time-reference", lc.time_reference,
                         "The raw log a corrected log was made from: its scans' stamps (found by ranges near the "
                         "logger time) replace the trajectory's");
  lidar_eval
      ->add_option("--time-reference-tolerance", lc.time_reference_tolerance,
                   "Seconds of logger time searched for the raw scan")
      ->capture_default_str();
  lidar_eval->add_option("--pose-offset", lc.pose_offset,
                         "x,y,theta: score every pose T as T * offset (e.g. laser poses on relations of the robot's)");
  lidar_eval->add_option("--trajectory-out", lc.trajectory_output, "Also write the scored trajectory (TUM text)");
  tether::LidarDegradeCommand ldc;
  CLI::App* lidar_degrade = app.add_subcommand(
      "lidar-degrade", "Write a laser log degraded as a cheaper scanner would record it (CARMEN; docs/lidar.md)");
  lidar_degrade->add_option("log", ldc.input, "The log: CARMEN (.clf, .log, plain or gzip) or a ROS 1 bag")->required();
  lidar_degrade->add_option("-o,--output", ldc.output, "The degraded log (CARMEN text)")->required();
  lidar_degrade->add_option("--preset", ldc.preset, "lds: 360 beams, 6 m, 0.02 m noise, 5% drops, every other scan");
  lidar_degrade->add_option("--beams", ldc.beams, "Resample each scan to N beams over its field of view");
  lidar_degrade->add_option("--max-range", ldc.max_range, "Maximum range [m]: beams beyond become no return");
  lidar_degrade->add_option("--noise", ldc.noise, "Gaussian range noise sigma [m]");
  lidar_degrade->add_option("--drop", ldc.drop, "Share of valid beams dropped, in [0, 1]");
  lidar_degrade->add_option("--error-share", ldc.error_share, "Share of the dropped beams made errors (NaN in memory)");
  lidar_degrade->add_option("--keep-every", ldc.keep_every, "Keep every K-th scan (2: every other one)");
  lidar_degrade->add_option("--first-scan", ldc.first_scan, "The first scan kept (index, from 0)");
  lidar_degrade->add_option("--max-scans", ldc.max_scans, "At most N scans (0: all)");
  lidar_degrade->add_option("--seed", ldc.seed, "Random seed of the noise and the drops (default 1)");
  lidar_degrade->add_flag("--no-odometry", ldc.no_odometry, "Drop the odometry (RAWLASER1 lines, no ODOM lines)");
  lidar_degrade->add_option("--odometry", ldc.odometry, "Reading: auto, scan-line, interpolated or none")
      ->capture_default_str();
  lidar_degrade->add_option("--scan-topic", ldc.scan_topic, "Bags: the sensor_msgs/LaserScan topic")
      ->capture_default_str();
  lidar_degrade->add_option("--odom-topic", ldc.odom_topic, "Bags: the nav_msgs/Odometry topic")->capture_default_str();

  tether::AddOptionChecks(&app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  // An output option given an empty path (`-o "$UNSET"`) is refused before anything runs.
  const std::pair<CLI::App*, std::vector<std::pair<const char*, const std::string*>>> paths[] = {
      {optimize,
       {{"-o", &opt.output},
        {"--plot", &opt.plot},
        {"--rejected-out", &opt.rejected_output},
        {"--covariance-out", &opt.covariance_output},
        {"--ground-truth", &opt.ground_truth}}},
      {simulate, {{"-o", &sim.output}, {"--ground-truth", &sim.ground_truth}}},
      {simulate, {{"--truth", &slc.truth}}},
      {bench, {{"-o", &bc.output}}},
      {replay, {{"-o", &rc.options.output}, {"--plot", &rc.plot}}},
      {ekf_demo, {{"-o", &ec.output}, {"--plot", &ec.plot}}},
      {lidar_eval, {{"--trajectory-out", &lc.trajectory_output}}},
      {lidar_degrade, {{"-o", &ldc.output}}},
      {lidar, {{"-o", &lsc.output_dir}}}};
  for (const auto& [sub, options] : paths) {
    if (!sub->parsed()) continue;
    for (const auto& [name, value] : options) {
      if (sub->count(name) > 0 && value->empty()) {
        std::cerr << "tether " << sub->get_name() << ": " << name
                  << " was given an empty path (an unset shell variable?); give a file name\n";
        return 2;
      }
    }
  }
  try {
    if (optimize->parsed()) return tether::RunOptimize(opt, std::cout, std::cerr);
    if (simulate->parsed() && (sim.world == "lidar" || slc.Given())) {
      return tether::RunSimulateLidar(sim, slc, std::cout, std::cerr);
    }
    if (simulate->parsed()) return tether::RunSimulate(sim, std::cout, std::cerr);
    if (list->parsed()) return tether::RunPluginsList(plist, std::cout, std::cerr);
    if (bench->parsed()) return tether::RunBench(bc, std::cout, std::cerr);
    if (replay->parsed()) return tether::RunReplay(rc, std::cout, std::cerr);
    if (ekf_demo->parsed()) return tether::RunEkfDemo(ec, std::cout, std::cerr);
    if (lidar_eval->parsed()) return tether::RunLidarEval(lc, std::cout, std::cerr);
    if (lidar_degrade->parsed()) return tether::RunLidarDegrade(ldc, std::cout, std::cerr);
    if (lidar->parsed()) return tether::RunLidar(lsc, std::cout, std::cerr);
  } catch (const std::exception& e) {
    // The commands report expected errors themselves; this is the last line of defence.
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
  return 2;
}
