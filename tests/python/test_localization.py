"""tether.localization: the map from a NumPy image, Monte Carlo localisation step by step
(predict, update, resample; the particles as an (N, 4) array), and a whole log by
MclLocalization2D, the same files as `tether mcl`."""
import math
import subprocess
import threading

import numpy as np
import pytest

import tether

lo = tether.localization

RES = 0.05
W, H = 160, 120  # an 8 m x 6 m room
# The scans: 180 beams over the front half circle, as CARMEN's FLASER lines have them.
ANGLE_MIN = -math.pi / 2
ANGLE_STEP = math.pi / 179
ANGLES = ANGLE_MIN + ANGLE_STEP * np.arange(180)
RANGE_MAX = 10.0


def set_cells(image, i0, i1, j0, j1, value=0):
    """Cells i in [i0, i1), j in [j0, j1) (j from the bottom) of an image whose first row is the top."""
    image[H - j1:H - j0, i0:i1] = value


def room_image():
    """The room's walls one cell thick, a 1 m x 0.6 m box, a post and a stub of wall: no symmetry."""
    image = np.full((H, W), 254, np.uint8)
    set_cells(image, 0, W, 0, 1)
    set_cells(image, 0, W, H - 1, H)
    set_cells(image, 0, 1, 0, H)
    set_cells(image, W - 1, W, 0, H)
    set_cells(image, 100, 120, 30, 42)  # x in [5, 6), y in [1.5, 2.1)
    set_cells(image, 120, 124, 80, 84)  # x in [6, 6.2), y in [4, 4.2)
    set_cells(image, 0, 16, 60, 62)     # x in [0, 0.8), y in [3, 3.1)
    return image


@pytest.fixture(scope="module")
def room():
    return lo.OccupancyMap2D(room_image(), RES, (0.0, 0.0))


def compose(a, b):
    """a * b of poses (x, y, theta)."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return (a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], math.atan2(math.sin(a[2] + b[2]),
                                                                                 math.cos(a[2] + b[2])))


def tour():
    """Poses round the box and the post: straight steps of 0.15 m, turns in steps of 0.3 rad."""
    corners = [(1.2, 0.8), (7.0, 0.8), (7.0, 5.2), (1.2, 5.2), (1.2, 0.8)]
    poses = []
    heading = 0.0
    for (x0, y0), (x1, y1) in zip(corners, corners[1:]):
        target = math.atan2(y1 - y0, x1 - x0)
        turn = math.atan2(math.sin(target - heading), math.cos(target - heading))
        steps = max(1, int(abs(turn) / 0.3))
        for k in range(1, steps + 1):
            poses.append((x0, y0, heading + turn * k / steps))
        heading = target
        n = int(math.hypot(x1 - x0, y1 - y0) / 0.15)
        for k in range(1, n + 1):
            poses.append((x0 + (x1 - x0) * k / n, y0 + (y1 - y0) * k / n, heading))
    return np.array(poses)


# The odometry's frame: the robot's start at its origin, turned.
ODOM_FROM_MAP = (-3.0, 2.0, 0.7)


def scans_of(room, poses, seed=1):
    """Ranges the laser measures at the poses (the C++ ray caster, 1 cm noise), and the odometry."""
    caster = lo.BeamModel(room)
    rng = np.random.default_rng(seed)
    scans, odometry = [], []
    for p in poses:
        r = caster.cast_rays(p, ANGLES, RANGE_MAX)
        hit = r < RANGE_MAX
        r[hit] += rng.normal(0, 0.01, hit.sum())
        r[~hit] = np.inf
        scans.append(r)
        odometry.append(compose(ODOM_FROM_MAP, p))
    return scans, odometry


def scan_args(ranges, **more):
    return dict(angle_min=ANGLE_MIN, angle_increment=ANGLE_STEP, range_max=RANGE_MAX, **more)


def heading_error(a, b):
    return abs(math.atan2(math.sin(a - b), math.cos(a - b)))


def test_map_from_numpy(room, tmp_path):
    assert (room.width, room.height, room.resolution, room.origin) == (W, H, RES, (0.0, 0.0))
    # Rows from the bottom: the box's cells at x in [5, 6), y in [1.5, 2.1).
    assert room.cell_of(5.5, 1.8) == (110, 36)
    assert room.state(110, 36) == "occupied"
    assert room.state(110, 90) == "free"
    assert room.cell_of(-0.1, 1.0) is None and room.cell_of(1.0, 6.0) is None
    d = room.distances
    assert d.shape == (H, W) and d.dtype == np.float64
    assert d[36, 110] == 0 == room.distance(110, 36)
    assert d[20, 10] == room.distance(10, 20) == pytest.approx(10 * RES)  # 10 cells from the wall at x = 0
    states = room.states
    assert states[36, 110] == 1 and states[90, 110] == 0
    assert room.cell_centre(0, 0) == pytest.approx((0.025, 0.025))
    with pytest.raises(tether.InvalidArgument, match="outside the 160 x 120 map"):
        room.state(160, 0)
    with pytest.raises(tether.InvalidArgument, match="uint8"):
        lo.OccupancyMap2D(room_image().astype(float), RES)
    with pytest.raises(tether.InvalidArgument, match="resolution"):
        lo.OccupancyMap2D(room_image(), 0.0)
    with pytest.raises(tether.InvalidArgument, match="thresholds"):
        lo.OccupancyMap2D(room_image(), RES, occupied_thresh=0.1, free_thresh=0.2)
    # The same map through a map_server YAML and PGM.
    image = room_image()
    (tmp_path / "room.pgm").write_bytes(f"P5\n{W} {H}\n255\n".encode() + image.tobytes())
    (tmp_path / "room.yaml").write_text("image: room.pgm\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\nnegate: 0\n"
                                        "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    read = lo.OccupancyMap2D.read(tmp_path / "room.yaml")
    assert np.array_equal(read.distances, room.distances) and np.array_equal(read.states, room.states)
    with pytest.raises(tether.IoError):
        lo.OccupancyMap2D.read(tmp_path / "absent.yaml")


def test_global_localisation_step_by_step(room):
    truth = tour()
    scans, odometry = scans_of(room, truth)
    options = lo.MclOptions()
    options.particles = 10000
    options.threads = 2
    # The default method (auto: the costmap's re-draws until localised) and its tempered
    # updates; KLD sampling sheds most of the particles once the pose is found.
    options.kld.enabled = True
    options.kld.min_particles = 500
    options.kld.max_particles = 10000
    mcl = lo.MonteCarloLocalizer2D(room, options)
    mcl.initialize_global()
    assert mcl.particles.shape == (10000, 4)
    errors = []
    for k, ranges in enumerate(scans):
        if k > 0:
            mcl.predict(odometry[k - 1], odometry[k])
        mcl.update(ranges, **scan_args(ranges))
        pose, covariance = mcl.estimate()
        errors.append((np.hypot(*(pose[:2] - truth[k, :2])), heading_error(pose[2], truth[k, 2])))
        mcl.resample()
    errors = np.array(errors)
    # Lost at first, found within the first half of the tour, and kept from there on.
    assert errors[0, 0] > 0.3
    half = len(truth) // 2
    assert np.all(errors[half:, 0] < 0.2) and np.all(errors[half:, 1] < 0.1)
    assert errors[-1, 0] < 0.15
    assert covariance.shape == (3, 3) and np.all(np.diag(covariance) < 0.02)
    n = len(mcl.particles)
    assert 500 <= n < 10000
    assert np.isfinite(mcl.log_w_slow) and np.isfinite(mcl.log_w_fast)
    assert 0 <= mcl.injection_probability < 1
    assert mcl.redrawn.dtype == bool and mcl.redrawn.shape == (n,) and not mcl.redrawn.any()


def test_add_scan_and_the_costmap_method(room):
    truth = tour()
    scans, odometry = scans_of(room, truth, seed=2)
    options = lo.MclOptions()
    options.method = "acmcl"
    options.particles = 3000
    options.robot_radius = 0.15
    mcl = lo.MonteCarloLocalizer2D(room, options)
    assert mcl.costmap.robot_radius == 0.15 and not mcl.costmap.valid(5.5, 1.8) and mcl.costmap.valid(3.0, 3.0)
    with pytest.raises(tether.InvalidArgument, match="no odometry"):
        mcl.add_scan(scans[0], **scan_args(scans[0]))
    steps = [mcl.add_scan(r, **scan_args(r, stamp=0.1 * k, odometry=o)) for k, (r, o) in enumerate(zip(scans, odometry))]
    assert steps[0].updated and steps[0].particles == 3000
    assert sum(s.updated for s in steps) > len(steps) // 2
    last = steps[-1].as_dict()
    assert set(last) == {"updated", "redrawn", "injected", "particles", "w_avg", "w_slow", "w_fast", "pose",
                         "covariance", "cluster_weight", "clusters"}
    assert np.hypot(*(steps[-1].pose[:2] - truth[-1, :2])) < 0.15
    assert heading_error(steps[-1].pose[2], truth[-1, 2]) < 0.1
    assert steps[-1].covariance.shape == (3, 3) and 0 < steps[-1].cluster_weight <= 1
    assert "MclStep(updated=" in repr(steps[-1])


def test_particles_round_trip(room):
    mcl = lo.MonteCarloLocalizer2D(room, lo.MclOptions())
    with pytest.raises(tether.InvalidArgument, match="no particles yet"):
        mcl.resample()
    rng = np.random.default_rng(3)
    p = np.column_stack([rng.uniform(1, 7, 50), rng.uniform(1, 5, 50), rng.uniform(-3, 3, 50), rng.uniform(0, 2, 50)])
    mcl.set_particles(p)
    back = mcl.particles
    assert back.shape == (50, 4)
    assert np.allclose(back[:, :3], p[:, :3], rtol=0, atol=1e-12)
    assert np.allclose(back[:, 3], p[:, 3] / p[:, 3].sum())
    mcl.set_particles(p[:, :3])
    assert np.allclose(mcl.particles[:, 3], 1 / 50)
    assert not mcl.injected.any() and mcl.injected.shape == (50,)
    # Headings are wrapped into (-pi, pi].
    mcl.set_particles(np.array([[2.0, 2.0, 2 * math.pi + 0.5]]))
    assert mcl.particles[0, 2] == pytest.approx(0.5)
    with pytest.raises(tether.InvalidArgument, match=r"\(N, 4\)"):
        mcl.set_particles(np.zeros((5, 2)))
    with pytest.raises(tether.InvalidArgument, match="weight"):
        mcl.set_particles(np.array([[1.0, 1.0, 0.0, -1.0]]))
    with pytest.raises(tether.InvalidArgument, match="particle 1"):
        mcl.set_particles(np.array([[1.0, 1.0, 0.0], [np.nan, 1.0, 0.0]]))


def test_resampling_a_single_heavy_particle_copies_it(room):
    options = lo.MclOptions()
    options.method = "mcl"
    options.particles = 200
    mcl = lo.MonteCarloLocalizer2D(room, options)
    p = np.column_stack([np.linspace(1, 7, 100), np.full(100, 3.0), np.zeros(100), np.zeros(100)])
    p[37] = (4.25, 3.5, 1.0, 1.0)
    mcl.set_particles(p)
    mcl.resample()
    after = mcl.particles
    assert after.shape == (200, 4)  # resampled to the option's count
    assert np.all(after[:, :3] == (4.25, 3.5, 1.0)) and np.allclose(after[:, 3], 1 / 200)
    pose, covariance = mcl.estimate()
    assert np.allclose(pose, (4.25, 3.5, 1.0)) and np.allclose(covariance, 0)
    # Systematic resampling: each particle gets floor or ceil of count x weight copies.
    w = np.array([0.5, 0.125, 0.25, 0.125])
    for u in (0.1, 0.5, 0.9):
        counts = np.bincount(lo.low_variance_resample(w, 8, u), minlength=4)
        assert np.array_equal(counts, [4, 1, 2, 1])
    counts = np.bincount(lo.low_variance_resample(np.array([0.3, 0.7]), 10, 0.5), minlength=2)
    assert np.array_equal(counts, [3, 7])


def test_invalid_options_raise_with_the_message(room):
    options = lo.MclOptions()
    assert options.is_valid() == (True, "")
    options.alpha_slow = 0.5
    options.alpha_fast = 0.1
    valid, why = options.is_valid()
    assert not valid and "alpha_slow" in why
    with pytest.raises(tether.InvalidArgument, match="alpha_slow"):
        lo.MonteCarloLocalizer2D(room, options)
    with pytest.raises(ValueError, match="unknown method 'monte'; use mcl, amcl, cmcl, acmcl or auto"):
        options.method = "monte"
    assert lo.methods() == ["mcl", "amcl", "cmcl", "acmcl", "auto"]
    options = lo.MclOptions()
    options.particles = 0
    assert "particles" in options.is_valid()[1]
    options = lo.MclOptions()
    options.motion_alphas = (0.1, 0.1, -0.1, 0.1)
    assert options.motion.alpha3 == -0.1 and not options.is_valid()[0]
    options = lo.MclOptions()
    options.likelihood_field.sigma_hit = 0
    assert not options.is_valid()[0]
    with pytest.raises(tether.InvalidArgument):
        options.likelihood_field.combination = "max"
    run = lo.MclRunOptions()
    run.filter.kld.enabled = True
    run.filter.kld.min_particles = 10
    run.filter.kld.max_particles = 5
    assert not run.is_valid()[0]
    with pytest.raises(tether.InvalidArgument):
        lo.MclLocalization2D(room, run)
    # A map without a free cell.
    with pytest.raises(tether.InvalidArgument, match="no free cell"):
        lo.MonteCarloLocalizer2D(lo.OccupancyMap2D(np.zeros((4, 4), np.uint8), 0.1), lo.MclOptions())
    # Bad scans and poses.
    mcl = lo.MonteCarloLocalizer2D(room, lo.MclOptions())
    mcl.initialize_global()
    with pytest.raises(tether.InvalidArgument, match="ranges"):
        mcl.update(np.ones(1), angle_min=0, angle_increment=0.1, range_max=10)
    with pytest.raises(tether.InvalidArgument, match="range_max"):
        mcl.update(np.ones(10), angle_min=0, angle_increment=0.1, range_max=math.inf)
    with pytest.raises(tether.InvalidArgument, match="odom_to"):
        mcl.predict((0, 0, 0), (1, 2))
    with pytest.raises(tether.InvalidArgument, match="positive definite"):
        mcl.initialize_gaussian((1, 1, 0), np.zeros((3, 3)))


def run_filter(room, scans, odometry, seed, threads):
    options = lo.MclOptions()
    options.particles = 1000
    options.seed = seed
    options.threads = threads
    mcl = lo.MonteCarloLocalizer2D(room, options)
    mcl.initialize_gaussian(compose(ODOM_FROM_MAP, (0, 0, 0)), np.diag([0.5, 0.5, 0.2]) ** 2)
    for k in range(len(scans)):
        if k:
            mcl.predict(odometry[k - 1], odometry[k])
        mcl.update(scans[k], **scan_args(scans[k]))
        mcl.resample()
    return mcl.particles


def test_a_seed_gives_the_same_particles_whatever_the_threads(room):
    scans, odometry = scans_of(room, tour()[:12])
    a = run_filter(room, scans, odometry, seed=5, threads=1)
    b = run_filter(room, scans, odometry, seed=5, threads=2)
    c = run_filter(room, scans, odometry, seed=6, threads=1)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)


def test_a_second_update_from_another_thread_is_refused(room):
    options = lo.MclOptions()
    options.particles = 300000
    options.max_beams = 0
    options.threads = 1
    mcl = lo.MonteCarloLocalizer2D(room, options)
    mcl.initialize_global()
    scans, _ = scans_of(room, tour()[:1])
    done = threading.Event()
    failures = []

    def work():
        try:
            mcl.update(scans[0], **scan_args(scans[0]))
        except Exception as e:  # pragma: no cover - reported below
            failures.append(e)
        done.set()

    worker = threading.Thread(target=work)
    worker.start()
    refused = []
    while not done.is_set():
        for call in (lambda: mcl.update(scans[0], **scan_args(scans[0])), lambda: mcl.particles,
                     mcl.resample, lambda: mcl.log_w_fast):
            try:
                call()
            except tether.InUseError as e:
                refused.append(str(e))
    worker.join()
    assert not failures
    assert refused and "in use by a running MonteCarloLocalizer2D.update" in refused[0]
    # Free again once the update has returned.
    mcl.resample()
    assert mcl.particles.shape == (300000, 4)


def carmen_log(path, truth, scans, odometry):
    lines = []
    for k, (ranges, odom) in enumerate(zip(scans, odometry)):
        p = " ".join(f"{v:.10g}" for v in odom)
        r = " ".join(f"{x:.6g}" if np.isfinite(x) else "81.9" for x in ranges)
        lines.append(f"FLASER 180 {r} {p} {p} {100 + 0.2 * k:.10g} sim {0.2 * k:.6g}")
    path.write_text("\n".join(lines) + "\n")
    return np.column_stack([100 + 0.2 * np.arange(len(truth)), truth])


def test_a_log_localised_as_the_command_does(room, tmp_path, cli):
    truth = tour()
    scans, odometry = scans_of(room, truth, seed=4)
    reference = carmen_log(tmp_path / "room.log", truth, scans, odometry)
    image = room_image()
    (tmp_path / "room.pgm").write_bytes(f"P5\n{W} {H}\n255\n".encode() + image.tobytes())
    (tmp_path / "room.yaml").write_text("image: room.pgm\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\nnegate: 0\n"
                                        "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    options = lo.MclRunOptions()
    options.initial_pose = tuple(truth[0])
    options.filter.particles = 1000
    options.filter.threads = 2
    run = lo.MclLocalization2D(lo.OccupancyMap2D.read(tmp_path / "room.yaml"), options)
    run.run(tmp_path / "room.log")
    trajectory = run.trajectory()
    assert trajectory.shape == (len(truth), 4)
    assert np.allclose(trajectory[:, 0], reference[:, 0])
    error = lo.compare_with_reference(trajectory, reference)
    assert error["matched"] == len(truth)
    assert error["converged_index"] == 0 and error["max_error"] < 0.15
    assert run.report["scans"] == len(truth) and run.report["final_particles"] == 1000
    assert "scans" in run.summary()
    outputs = run.outputs()
    assert set(outputs) == {"trajectory.tum", "mcl_steps.csv", "mcl.png"}
    assert np.allclose(lo.read_tum(_write(tmp_path / "t.tum", outputs["trajectory.tum"])), trajectory, atol=1e-6)
    # The command's files, byte for byte.
    subprocess.run([cli, "mcl", str(tmp_path / "room.log"), "--map", str(tmp_path / "room.yaml"), "-o",
                    str(tmp_path / "cli"), "--particles", "1000", "--threads", "1", "-q", "--initial-pose",
                    ",".join(f"{v:.17g}" for v in truth[0])], check=True,
                   capture_output=True)
    run.write(tmp_path / "py")
    for name in outputs:
        assert (tmp_path / "cli" / name).read_bytes() == (tmp_path / "py" / name).read_bytes() == outputs[name], name
    # A scan without odometry is refused.
    with pytest.raises(tether.InvalidArgument, match="no odometry"):
        run.add_scan(scans[0], **scan_args(scans[0]))


def _write(path, data):
    path.write_bytes(data)
    return path
