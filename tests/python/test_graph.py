"""Values, factors, graphs: built in Python, solved back to the truth; errors and shapes."""
import math

import numpy as np
import pytest

import tether


def square_world(n=24, landmarks=6, seed=3):
    """Ground truth: n SE2 poses on a circle and landmarks inside it."""
    rng = np.random.default_rng(seed)
    poses = [tether.SE2(5 * math.cos(2 * math.pi * i / n), 5 * math.sin(2 * math.pi * i / n),
                        2 * math.pi * i / n + math.pi / 2) for i in range(n)]
    points = [rng.uniform(-3, 3, size=2) for _ in range(landmarks)]
    return poses, points, rng


def test_synthetic_graph_is_solved_back_to_its_ground_truth():
    poses, points, rng = square_world()
    n = len(poses)
    x = lambda i: tether.Symbol("x", i)
    l = lambda j: tether.Symbol("l", j)
    noise3 = tether.SqrtInformation.from_sigmas(np.array([0.1, 0.1, 0.05]))
    noise2 = tether.SqrtInformation.isotropic(2, 0.1)
    graph = tether.FactorGraph()
    graph.add(tether.PriorSE2(x(0), poses[0], tether.SqrtInformation.isotropic(3, 1e-3)))
    for i in range(n):  # odometry around the loop, and the closure back to the start
        j = (i + 1) % n
        graph.add(tether.BetweenSE2(x(i), x(j), poses[i].inverse() * poses[j], noise3))
    for i in range(0, n, 2):
        for j, p in enumerate(points):
            rel = poses[i].inverse() * p
            if i % 4 == 0:
                graph.add(tether.PosePoint2(x(i), l(j), rel, noise2))
            else:
                graph.add(tether.RangeBearing2(x(i), l(j), float(np.linalg.norm(rel)),
                                               math.atan2(rel[1], rel[0]), noise2))
    values = tether.Values()
    for i, p in enumerate(poses):
        values.insert(x(i), p.retract(rng.normal(0, [0.3, 0.3, 0.1])))
    for j, p in enumerate(points):
        values.insert(l(j), p + rng.normal(0, 0.5, size=2))
    assert graph.chi2(values) > 100
    summary = tether.optimize(graph, values)
    assert summary.status == "converged", summary.full_report()
    assert summary.final_chi2 < 1e-12
    for i, p in enumerate(poses):
        np.testing.assert_allclose(values.at(x(i)).local(p), np.zeros(3), atol=1e-6)
    for j, p in enumerate(points):
        np.testing.assert_allclose(values.at(l(j)), p, atol=1e-6)


def test_values_arrays_shapes_and_types():
    v = tether.Values()
    v.insert(1, tether.SE2(1, 2, 0.3))
    v.insert(2, tether.SE3())
    v.insert(3, np.array([1.0, 2.0]))
    v.insert(4, [1, 2, 3], type="Point3")  # ints and lists are converted to float64
    # Three plain numbers are ambiguous (SE2 or Point3) without the type; nothing is stored.
    for ambiguous in ((1, 2, 0.5), [1.0, 2.0, 0.5]):
        with pytest.raises(tether.InvalidArgument, match="type='SE2' / type='Point3'"):
            v.insert(5, ambiguous)
    assert 5 not in v
    v.insert(5, (1, 2, 0.5), type="SE2")
    assert isinstance(v.at(5), tether.SE2) and v.at(5).theta == pytest.approx(0.5)
    assert v.erase(5)
    assert len(v) == 4 and 3 in v and 9 not in v
    assert v.keys() == [1, 2, 3, 4]
    assert [v.type_of(k) for k in v.keys()] == ["SE2", "SE3", "Point2", "Point3"]
    assert isinstance(v.at(1), tether.SE2) and isinstance(v[2], tether.SE3)
    p = v.at(4)
    assert p.shape == (3,) and p.dtype == np.float64
    assert v.params(2).shape == (7,)
    v.update(3, np.array([5.0, 6.0]))
    np.testing.assert_array_equal(v.at(3), [5.0, 6.0])
    keys, params = v.array("Point2")
    assert keys.dtype == np.uint64 and keys.tolist() == [3]
    assert params.shape == (1, 2)
    v.insert_batch("SE2", np.array([10, 11]), np.array([[0, 0, 0], [1, 0, 7.0]]))
    keys, params = v.array("SE2")
    assert keys.tolist() == [1, 10, 11] and params.shape == (3, 3)
    assert params[2, 2] == pytest.approx(7.0 - 2 * math.pi)  # wrapped
    assert v.erase(3) and not v.erase(3)


def test_values_errors_name_the_problem():
    v = tether.Values()
    v.insert(1, tether.SE2())
    with pytest.raises(tether.InvalidArgument, match="exists"):
        v.insert(1, tether.SE2())
    with pytest.raises(tether.InvalidArgument, match="no variable x3"):
        v.at(tether.Symbol("x", 3))
    with pytest.raises(KeyError):
        v[99]
    with pytest.raises(tether.InvalidArgument, match=r"shape \(3,\)"):
        v.update(1, np.zeros(2))
    with pytest.raises(tether.InvalidArgument, match=r"shape \(2,\) or \(3,\)"):
        v.insert(5, np.zeros(4))
    with pytest.raises(tether.InvalidArgument, match="unknown variable type 'Quux'"):
        v.insert(6, np.zeros(1), type="Quux")
    # tether's errors are also the matching Python built-in exceptions
    assert issubclass(tether.InvalidArgument, ValueError)
    assert issubclass(tether.ParseError, tether.Error)
    assert issubclass(tether.IoError, OSError)


def test_factor_evaluate_linearize_and_losses():
    v = tether.Values()
    v.insert(0, tether.SE2(0, 0, 0))
    v.insert(1, tether.SE2(1.5, 0, 0))
    f = tether.BetweenSE2(0, 1, tether.SE2(1, 0, 0), tether.SqrtInformation.from_information(np.diag([4.0, 4, 4])))
    e, jac = f.evaluate(v)
    assert e.shape == (3,) and len(jac) == 2 and jac[0].shape == (3, 3)
    np.testing.assert_allclose(e, [0.5, 0, 0])
    r, wjac = f.linearize(v)
    np.testing.assert_allclose(r, [1.0, 0, 0])
    np.testing.assert_allclose(wjac[1], 2 * jac[1])
    assert f.chi2(v) == pytest.approx(1.0)
    f.set_loss(tether.make_loss("huber:0.5"))
    assert f.loss.name.startswith("huber")
    assert f.cost(v) == pytest.approx(2 * 0.5 * 1.0 - 0.25)  # 2 d sqrt(s) - d^2 beyond d^2
    f.set_loss("cauchy:1")
    assert f.cost(v) == pytest.approx(math.log(2.0))
    with pytest.raises(tether.InvalidArgument, match="unknown|quux"):
        f.set_loss("quux:1")
    assert f.measurement() == [1.0, 0.0, 0.0]


def test_measured_composes_with_poses():
    # Read back from a graph, a factor is a plain Factor: its measurement is still a value that
    # composes with the poses (a relative pose an SE2, a pose prior an SE2, a point an array).
    graph, _, truth = tether.simulate("landmarks", poses=30, seed=3, landmarks=20)
    kinds = set()
    for i in range(len(graph)):
        f = graph[i]
        z = f.measured
        if f.type_name == "BetweenSE2":
            assert isinstance(z, tether.SE2)
            a, b = f.keys
            predicted = truth[a] * z
            assert abs(predicted.x - truth[b].x) < 0.2 and abs(predicted.y - truth[b].y) < 0.2
            assert [z.x, z.y, z.theta] == pytest.approx(f.measurement(), abs=1e-12)
        else:
            assert isinstance(z, np.ndarray) and z.shape == (len(f.measurement()),)
            np.testing.assert_allclose(z, f.measurement())
        kinds.add(f.type_name)
    assert "BetweenSE2" in kinds and len(kinds) >= 2
    prior = tether.make_factor("PriorSE2", [0], [1.0, 2.0, 0.5], tether.SqrtInformation.identity(3))
    assert isinstance(prior.measured, tether.SE2) and prior.measured.y == 2.0
    rb = tether.make_factor("RangeBearing2", [0, 1], [3.0, 0.25], tether.SqrtInformation.identity(2))
    assert isinstance(rb.measured, np.ndarray) and list(rb.measured) == [3.0, 0.25]


def test_graph_handles_remove_and_copies():
    g = tether.FactorGraph()
    n = tether.SqrtInformation.identity(3)
    h = [g.add(tether.PriorSE2(k, tether.SE2(), n)) for k in range(3)]
    assert h == [0, 1, 2] and len(g) == 3
    g.remove(1)
    with pytest.raises(tether.InvalidArgument, match="no factor with handle 1"):
        g.remove(1)
    assert g.handles() == [0, 2] and g.index_of(2) == 1 and g.index_of(1) is None
    assert g[1].keys == [2]
    g.set_loss(2, "huber:1")
    assert g.has_loss()
    g.fix(5)
    assert g.is_fixed(5) and g.fixed == {5}


def test_make_factor_by_registered_name_and_its_errors():
    n = tether.SqrtInformation.identity(3)
    f = tether.make_factor("BetweenSE2", [1, 2], [1.0, 0.0, 0.0], n)
    assert isinstance(f, tether.BetweenSE2) and f.keys == [1, 2]
    assert any(t["name"] == "BetweenSE2" and t["tag"] == "EDGE_SE2" for t in tether.factor_types())
    with pytest.raises(tether.InvalidArgument, match="no factor type is named 'Nope'"):
        tether.make_factor("Nope", [1], [], n)
    with pytest.raises(tether.InvalidArgument, match="measurement of 3 numbers"):
        tether.make_factor("BetweenSE2", [1, 2], [1.0], n)


def test_batch_construction_matches_one_by_one():
    rng = np.random.default_rng(1)
    m = 50
    i = np.arange(m, dtype=np.uint64)
    j = i + 1
    z = rng.normal(size=(m, 3))
    info = np.tile(np.diag([10.0, 20.0, 30.0]), (m, 1, 1))
    batch = tether.FactorGraph()
    handles = batch.add_between_se2_batch(i, j, z, info)
    assert handles.shape == (m,) and handles.dtype == np.uint64
    single = tether.FactorGraph()
    for r in range(m):
        single.add(tether.BetweenSE2(int(i[r]), int(j[r]), tether.SE2.from_params(z[r]),
                                     tether.SqrtInformation.from_information(info[r])))
    v = tether.Values()
    v.insert_batch("SE2", np.arange(m + 1), rng.normal(size=(m + 1, 3)))
    assert batch.chi2(v) == pytest.approx(single.chi2(v), rel=1e-14)
    shared = tether.FactorGraph()
    shared.add_between_se2_batch(i, j, z, np.diag([10.0, 20.0, 30.0]))
    assert shared.chi2(v) == pytest.approx(single.chi2(v), rel=1e-14)


def test_batch_errors_leave_the_graph_unchanged():
    g = tether.FactorGraph()
    with pytest.raises(tether.InvalidArgument, match=r"z must have shape \(2, 3\), got \(2, 2\)"):
        g.add_between_se2_batch(np.array([0, 1]), np.array([1, 2]), np.zeros((2, 2)), np.eye(3))
    info = np.stack([np.eye(3), -np.eye(3)])
    with pytest.raises(tether.InvalidArgument, match=r"information\[1\]"):
        g.add_between_se2_batch(np.array([0, 1]), np.array([1, 2]), np.zeros((2, 3)), info)
    assert len(g) == 0


def test_keys_that_would_alias_another_variable_are_refused():
    # An index of 2**56 would spill into the letter; a NUL letter would be a plain number.
    with pytest.raises(tether.InvalidArgument, match="below 2\\*\\*56"):
        tether.Symbol("x", 2**56)
    with pytest.raises(tether.InvalidArgument, match="printable"):
        tether.Symbol("\x00", 3)
    with pytest.raises(tether.InvalidArgument, match="printable"):
        tether.Symbol(" ", 3)
    assert tether.key_to_string(tether.Symbol("x", 2**56 - 1)) == f"x{2**56 - 1}"
    v = tether.Values()
    with pytest.raises(tether.InvalidArgument, match="integer keys.*float"):
        v.insert_batch("Point2", np.array([0.5, 1.7]), np.zeros((2, 2)))
    with pytest.raises(tether.InvalidArgument, match=r"keys\[1\] is -1"):
        v.insert_batch("Point2", np.array([0, -1], dtype=np.int64), np.zeros((2, 2)))
    with pytest.raises(tether.InvalidArgument, match="given twice"):
        v.insert_batch("Point2", [4, 4], np.zeros((2, 2)))
    assert len(v) == 0
    v.insert_batch("Point2", [0, 1], np.zeros((2, 2)))  # a list of ints is fine
    v.insert_batch("Point2", np.array([2, 3], dtype=np.uint32), np.zeros((2, 2)))
    assert v.keys() == [0, 1, 2, 3]
    g = tether.FactorGraph()
    info = np.eye(3)
    with pytest.raises(tether.InvalidArgument, match="integer keys"):
        g.add_between_se2_batch(np.array([0.0]), np.array([1.0]), np.zeros((1, 3)), info)
    with pytest.raises(tether.InvalidArgument, match=r"j\[0\] is -2"):
        g.add_between_se2_batch(np.array([0]), np.array([-2]), np.zeros((1, 3)), info)
    assert len(g) == 0


def test_factors_the_file_reader_would_refuse_are_refused_here_too():
    g = tether.FactorGraph()
    noise = tether.SqrtInformation.identity(3)
    with pytest.raises(tether.InvalidArgument, match="connects 4 to itself"):
        g.add(tether.BetweenSE2(4, 4, tether.SE2(1, 0, 0), noise))
    with pytest.raises(tether.InvalidArgument, match="row 1 connects 2 to itself"):
        g.add_between_se2_batch([0, 2], [1, 2], np.zeros((2, 3)), np.eye(3))
    z = np.zeros((2, 3))
    z[1, 2] = np.inf
    with pytest.raises(tether.InvalidArgument, match=r"z\[1\] is not finite"):
        g.add_between_se2_batch([0, 1], [1, 2], z, np.eye(3))
    assert len(g) == 0
    g.add(tether.BetweenSE2(0, 1, tether.SE2(1, 0, 0), noise))
    with pytest.raises(tether.InvalidArgument, match="no factor with handle 99"):
        g.remove(99)
    assert len(g) == 1


def test_a_python_factor_that_fails_part_way_is_named():
    # Residuals turn NaN after a few calls: the solve stops and names the factor, instead of
    # blaming the graph ("rank-deficient ... add a prior") or claiming convergence.
    for after in range(4, 14):
        g = tether.FactorGraph()
        v = tether.Values()
        v.insert(0, tether.SE2(0, 0, 0))
        v.insert(1, tether.SE2(1, 0, 0))
        g.add(tether.PriorSE2(0, tether.SE2(0, 0, 0), tether.SqrtInformation.identity(3)))
        g.add(tether.BetweenSE2(0, 1, tether.SE2(1, 0, 0), tether.SqrtInformation.identity(3)))
        calls = [0]

        def error(x, calls=calls, after=after):
            calls[0] += 1
            return np.array([np.nan]) if calls[0] > after else np.array([x[0].x - 2.0])

        g.add(tether.PythonFactor([1], ["SE2"], 1, error, tether.SqrtInformation.identity(1), name="Flaky"))
        s = tether.optimize(g, v)
        if s.status == "converged":
            # It converged before the factor started to fail.
            assert calls[0] <= after + 1 and v.at(1).x == pytest.approx(2.0, abs=1e-6)
        else:
            assert s.status == "invalid-input", (after, s.message)
            assert "factor 2 (Flaky, keys 1)" in s.message, (after, s.message)
