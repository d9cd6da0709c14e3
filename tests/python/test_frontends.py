"""The front-ends through Python: the motion model, the odometry front-end, EKF/UKF-SLAM."""
import math
import subprocess

import numpy as np
import pytest

import tether
from tether import ekf, odometry


def test_motion_model():
    u = odometry.from_wheel_speeds(0.9, 1.1, 0.5)
    assert u.v == pytest.approx(1.0) and u.w == pytest.approx(0.4)
    p, dp, du = odometry.move(tether.SE2(), u, 2.0, jacobians=True)
    assert dp.shape == (3, 3) and du.shape == (3, 2)
    r = 1.0 / 0.4  # an arc of radius v / w
    assert p.x == pytest.approx(r * math.sin(0.8)) and p.theta == pytest.approx(0.8)
    np.testing.assert_allclose(odometry.relative_motion(u, 2.0), p.params(), atol=1e-12)


def test_odometry_front_end_feeds_the_smoother():
    fe = odometry.OdometryFrontEnd()
    smoother = tether.IncrementalSmoother()
    for _ in range(10):
        assert fe.add(odometry.Control(1.0, 0.1), 1.0)
        factors, values = fe.take_new()
        smoother.update(factors, values)
    est = smoother.estimate()
    assert len(fe.trajectory) == 11
    last = est.at(fe.pose_key(10))
    np.testing.assert_allclose(last.params(), fe.trajectory[10].params(), atol=1e-6)


@pytest.mark.parametrize("filter_class", [ekf.EkfSlam, ekf.UkfSlam, ekf.InvariantEkfSlam])
def test_filters_track_the_simulated_world(filter_class):
    opts = ekf.LandmarkWorldOptions()
    opts.steps = 60
    world = ekf.simulate_landmark_world(opts)
    truth = world.truth_array()
    assert truth.shape == (61, 3) and world.landmarks().shape == (opts.landmarks, 2)
    f = filter_class(world.truth[0], np.eye(3) * 1e-6)
    for k in range(opts.steps):
        f.predict(world.odometry[k], world.dt)
        f.update(world.observations[k])
    dead = ekf.dead_reckoning(world)
    err = np.linalg.norm(f.pose.translation() - truth[-1, :2])
    dead_err = np.linalg.norm(dead[-1].translation() - truth[-1, :2])
    assert f.landmark_count > 0 and f.landmarks().shape == (f.landmark_count, 2)
    assert f.cov.shape == (3 + 2 * f.landmark_count,) * 2
    assert err < max(dead_err, 1.0)
    with pytest.raises(tether.InvalidArgument, match="use known, nearest or nn"):
        ekf.FilterOptions().association = "best"


@pytest.mark.parametrize("version", ["1.0", "2.0"])
def test_fast_slam_step_by_step(version):
    world_opts = ekf.LandmarkWorldOptions()
    world_opts.steps = 60
    world_opts.control_sigma = world_opts.control_sigma * 0.1
    world_opts.measurement_sigma = world_opts.measurement_sigma * 0.1
    world = ekf.simulate_landmark_world(world_opts)
    opts = ekf.FastSlamOptions()
    opts.version = version
    opts.particles = 40
    opts.filter.control_cov = np.diag(world_opts.control_sigma ** 2)
    opts.filter.measurement_cov = np.diag(world_opts.measurement_sigma ** 2)
    f = ekf.FastSlam(world.truth[0], np.zeros((3, 3)), opts)
    for k in range(world_opts.steps):
        f.predict(world.odometry[k], world.dt)
        taken = f.update(world.observations[k])
        assert len(taken) == len(world.observations[k])
        particles, weights = f.particles, f.weights
        assert particles.shape == (40, 3) and weights.shape == (40,)
        assert weights.sum() == pytest.approx(1.0)
        # The estimate is the weighted mean of the particles (the positions).
        if version == "1.0":
            np.testing.assert_allclose(weights @ particles[:, :2], f.pose.translation(), atol=1e-9)
    truth = world.truth_array()
    assert np.linalg.norm(f.pose.translation() - truth[-1, :2]) < 0.5
    lm = f.landmarks()
    assert lm.shape[1] == 2 and lm.shape[0] > 0 and len(f.landmark_covs()) == lm.shape[0]
    assert f.best_path.shape == (61, 3)
    assert f.wrong_associations == 0
    with pytest.raises(tether.InvalidArgument, match="use 1.0, 2.0"):
        ekf.FastSlamOptions().version = "3"
    bad = ekf.FastSlamOptions()
    bad.particles = 0
    with pytest.raises(tether.InvalidArgument, match="particles"):
        ekf.FastSlam(tether.SE2(), np.zeros((3, 3)), bad)


def test_min_range_skips_near_observations():
    opts = ekf.FilterOptions()
    opts.min_range = 3.0
    opts.update_iterations = 3
    f = ekf.InvariantEkfSlam(tether.SE2(), np.zeros((3, 3)), opts)
    assert f.update([ekf.Observation(2.0, 0.1, 0), ekf.Observation(5.0, 0.2, 1)]) == [-1, 0]
    assert f.near_observations == 1 and f.landmark_count == 1
    track = ekf.run_filter(ekf.InvariantEkfSlam(tether.SE2(), np.zeros((3, 3)), opts),
                           ekf.simulate_landmark_world(ekf.LandmarkWorldOptions()))
    assert len(track.poses) == 201


def test_filter_seeds_the_graph_and_the_smoother_solves_it():
    opts = ekf.LandmarkWorldOptions()
    opts.steps = 60
    opts.seed = 3
    world = ekf.simulate_landmark_world(opts)
    f = ekf.EkfSlam(world.truth[0], np.zeros((3, 3)))
    track = ekf.run_filter(f, world)
    assert track.poses_array().shape == (61, 3)
    assert len(track.association) == 60 and track.wrong_associations == 0
    solved = ekf.smooth_landmark_run(world, track)
    assert solved.updates == 61
    # The same optimum from the truth (batch) and from the filter (online, then finished).
    truth = ekf.truth_track(world)
    graph = ekf.build_landmark_graph(world, truth.association)
    values = ekf.seed_values(truth)
    tether.optimize(graph, values)
    assert graph.chi2(values) == pytest.approx(solved.chi2, rel=1e-6)
    gt = world.truth
    assert ekf.trajectory_rmse(solved.track.poses, gt) < ekf.trajectory_rmse(ekf.dead_reckoning(world), gt)
    assert ekf.landmark_rmse(solved.track, world.landmarks()) < 5.0
    assert values.at(ekf.pose_key(60)).params().shape == (3,)


def test_the_ekf_demo_experiment_from_python(cli):
    setup = ekf.ExperimentSetup()
    setup.steps = 60
    setup.graphs = False
    result = ekf.run_experiment(experiment=1, seeds=2, first_seed=1, setup=setup)
    methods = [r.method for r in result.rows]
    assert methods == ["dead reckoning", "EKF", "UKF", "invariant EKF", "FastSLAM 1.0 (100 particles)",
                       "FastSLAM 2.0 (100 particles)"]
    for r in result.rows:
        assert len(r.trajectory_rmse) == 2 and all(x > 0 for x in r.trajectory_rmse)
    # The filters beat dead reckoning on the mean, as the command's table says.
    dr = sum(result.rows[0].trajectory_rmse)
    assert sum(result.rows[1].trajectory_rmse) < dr
    # The command runs the same library loop: the same table rows (times aside).
    out = subprocess.run([cli, "ekf-demo", "--seeds", "2", "--steps", "60", "--no-graph", "--experiments", "1",
                          "--association", "known", "-q"], capture_output=True, text=True, check=True).stdout
    # Every column but the time (the last but one) is the same, FastSLAM's (seeded) too.
    cells = lambda line: [c.strip() for c in line.strip("|").split("|")]
    for method in ["| EKF |", "| FastSLAM 2.0 (100 particles) |"]:
        lib_row = [line for line in result.table().splitlines() if method in line][0]
        cli_row = [line for line in out.splitlines() if method in line][0]
        assert cells(lib_row)[:-2] == cells(cli_row)[:-2] and cells(lib_row)[-1] == cells(cli_row)[-1]
    # The particle counts and versions are the caller's.
    setup.fastslam_particles = [5, 20]
    setup.fastslam_one = False
    methods = [r.method for r in ekf.run_experiment(experiment=1, seeds=1, setup=setup).rows]
    assert methods[4:] == ["FastSLAM 2.0 (5 particles)", "FastSLAM 2.0 (20 particles)"]
    svg = ekf.experiment_svg(1, False, 1, setup)
    assert svg.startswith("<svg") and "EKF" in svg


def test_odometry_track_becomes_a_pose_graph():
    # A track driven by arcs: run_track gives the graph of every second pose, at chi2 0, and
    # control_between recovers each arc's control.
    pose, stamps, poses = tether.SE2(1, 2, 0.3), [], []
    for k in range(41):
        stamps.append(5.0 + 0.2 * k)
        poses.append(pose)
        pose = tether.odometry.move(pose, tether.odometry.Control(0.6, 0.4 * math.cos(0.3 * k)), 0.2)
    u = tether.odometry.control_between(poses[3], poses[4], 0.2)
    assert u.v == pytest.approx(0.6) and u.w == pytest.approx(0.4 * math.cos(0.9))
    options = tether.odometry.OdometryFrontEndOptions()
    options.controls_per_pose = 2
    graph, values, graph_stamps, report = tether.odometry.run_track(stamps, poses, options)
    assert report.poses == 21 and report.steps == 40 and report.merged == 0
    assert len(values) == 21 and len(graph) == 21 and graph_stamps[-1] == pytest.approx(stamps[-1])
    assert graph.chi2(values) == pytest.approx(0, abs=1e-9)
    assert report.distance == pytest.approx(0.6 * 0.2 * 40)
    assert "21 poses in the graph" in str(report)
    with pytest.raises(tether.InvalidArgument, match="at least two"):
        tether.odometry.run_track([1.0], [tether.SE2()])
