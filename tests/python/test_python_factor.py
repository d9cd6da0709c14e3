"""Factors written in Python: the same solution as their C++ twins, with and without Jacobians."""
import math
import threading

import numpy as np
import pytest

import tether


def between_error(z):
    """BetweenSE2's error in Python: Rz^T (D.t - z.t), wrap(D.theta - z.theta), D = Xi^-1 Xj."""
    cz, sz = math.cos(z.theta), math.sin(z.theta)

    def error(x):
        d = x[0].inverse() * x[1]
        ex, ey = d.x - z.x, d.y - z.y
        return np.array([cz * ex + sz * ey, -sz * ex + cz * ey, tether.wrap_angle(d.theta - z.theta)])

    return error


def between_jacobians(z):
    cz, sz = math.cos(z.theta), math.sin(z.theta)

    def jacobians(x):
        d = x[0].inverse() * x[1]
        ji = np.array([[-cz, -sz, cz * d.y - sz * d.x], [sz, -cz, -sz * d.y - cz * d.x], [0, 0, -1.0]])
        c, s = math.cos(d.theta - z.theta), math.sin(d.theta - z.theta)
        jj = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])
        return [ji, jj]

    return jacobians


def simulated(poses=60):
    graph, initial, truth = tether.simulate("manhattan", poses=poses, seed=4)
    return graph, initial


def python_twin(graph, with_jacobians):
    """The graph with every BetweenSE2 replaced by a Python factor computing the same error."""
    twin = tether.FactorGraph()
    for k in range(len(graph)):
        f = graph[k]
        z = f.measured
        twin.add(tether.PythonFactor(f.keys, ["SE2", "SE2"], 3, between_error(z), f.noise,
                                     jacobians=between_jacobians(z) if with_jacobians else None,
                                     name="PyBetweenSE2"))
    return twin


@pytest.mark.parametrize("with_jacobians", [True, False])
def test_python_factor_gives_the_solution_of_its_cpp_twin(with_jacobians):
    graph, initial = simulated()
    twin = python_twin(graph, with_jacobians)
    assert twin.chi2(initial) == pytest.approx(graph.chi2(initial), rel=1e-12)
    a, b = initial.copy(), initial.copy()
    sa = tether.optimize(graph, a)
    sb = tether.optimize(twin, b)
    assert sa.status == sb.status == "converged"
    assert sb.final_chi2 == pytest.approx(sa.final_chi2, rel=1e-6)
    for k in a.keys():
        np.testing.assert_allclose(b.at(k).local(a.at(k)), np.zeros(3), atol=1e-6)


def test_numeric_jacobians_match_the_analytic_ones():
    v = tether.Values()
    v.insert(0, tether.SE2(0.3, -1.0, 2.9))
    v.insert(1, tether.SE2(1.2, 0.4, -2.8))
    z = tether.SE2(0.5, 0.2, 0.4)
    cpp = tether.BetweenSE2(0, 1, z, tether.SqrtInformation.identity(3))
    py = tether.PythonFactor([0, 1], ["SE2", "SE2"], 3, between_error(z), tether.SqrtInformation.identity(3))
    e1, j1 = cpp.evaluate(v)
    e2, j2 = py.evaluate(v)
    np.testing.assert_allclose(e2, e1, atol=1e-14)
    for a, b in zip(j1, j2):
        np.testing.assert_allclose(b, a, atol=1e-7)


def test_python_factor_next_to_cpp_factors_with_points():
    """A range factor on a point written in Python, in a graph of C++ factors."""
    g = tether.FactorGraph()
    g.add(tether.PriorSE2(0, tether.SE2(), tether.SqrtInformation.isotropic(3, 1e-3)))
    beacons = [np.array([3.0, 0.0]), np.array([0.0, 4.0]), np.array([-2.0, -2.0])]
    target = np.array([1.0, 1.0])
    for k, b in enumerate(beacons):
        g.add(tether.PosePoint2(0, 10 + k, b, tether.SqrtInformation.isotropic(2, 1e-3)))
        r = float(np.linalg.norm(target - b))
        g.add(tether.PythonFactor([10 + k, 20], ["Point2", "Point2"], 1,
                                  lambda x, r=r: np.array([np.linalg.norm(x[1] - x[0]) - r]),
                                  tether.SqrtInformation.isotropic(1, 0.01)))
    v = tether.Values()
    v.insert(0, tether.SE2(0.1, -0.1, 0.05))
    for k, b in enumerate(beacons):
        v.insert(10 + k, b + 0.1)
    v.insert(20, np.array([0.5, 0.2]))
    s = tether.optimize(g, v)
    assert s.status == "converged", s.full_report()
    np.testing.assert_allclose(v.at(20), target, atol=1e-6)


def test_exceptions_and_bad_results_from_python_factors():
    v = tether.Values()
    v.insert(0, tether.SE2())
    v.insert(1, tether.SE2(1, 0, 0))
    g = tether.FactorGraph()

    def boom(x):
        raise ZeroDivisionError("from the residual")

    g.add(tether.PythonFactor([0, 1], ["SE2", "SE2"], 3, boom, tether.SqrtInformation.identity(3)))
    with pytest.raises(ZeroDivisionError, match="from the residual"):
        tether.optimize(g, v)
    with pytest.raises(ZeroDivisionError):
        g.chi2(v)
    bad = tether.FactorGraph()
    bad.add(tether.PythonFactor([0, 1], ["SE2", "SE2"], 3, lambda x: np.zeros(2), tether.SqrtInformation.identity(3)))
    with pytest.raises(tether.InvalidArgument, match=r"must return 3 numbers"):
        tether.optimize(bad, v)
    with pytest.raises(tether.InvalidArgument, match="one variable type per key"):
        tether.PythonFactor([0, 1], ["SE2"], 3, boom, tether.SqrtInformation.identity(3))
    with pytest.raises(tether.InvalidArgument, match="noise model has dimension 2"):
        tether.PythonFactor([0], ["SE2"], 3, boom, tether.SqrtInformation.identity(2))


def test_optimize_releases_the_gil():
    graph, initial = tether.simulate("manhattan", poses=20000, seed=2)[:2]
    done = threading.Event()
    result = {}

    def solve():
        result["summary"] = tether.optimize(graph, initial)
        done.set()

    t = threading.Thread(target=solve)
    t.start()
    spins = 0
    while not done.is_set():
        spins += 1
    t.join()
    assert result["summary"].status == "converged"
    # With the GIL held for the whole solve this thread could not have run during it.
    assert spins > 1000, f"the main thread ran only {spins} loops during a {result['summary'].total_seconds:.2f} s solve"
