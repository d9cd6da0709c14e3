"""Solving: the public intel dataset against the CLI, the iteration callback, errors from
files, marginals, the incremental smoother, the pipeline and plugins."""
import math
import re
import subprocess

import numpy as np
import pytest

import tether


def test_intel_reaches_the_final_chi2_of_the_cli(datasets_dir, cli):
    path = datasets_dir / "g2o" / "intel.g2o"
    if not path.exists():
        pytest.skip(f"{path} is absent")
    out = subprocess.run([cli, "optimize", str(path), "--quiet"], capture_output=True, text=True, check=True).stdout
    cli_final = float(re.search(r"final chi2\s+(\S+)", out).group(1))
    graph, values = tether.read_graph(str(path))
    init = tether.initialize(graph, values, "chordal")  # the CLI's default start
    assert init.method == "chordal"
    summary = tether.optimize(graph, values)
    assert summary.status == "converged"
    assert summary.final_chi2 == pytest.approx(cli_final, rel=1e-8)
    # The report is C++'s own text: the CLI prints the same line.
    line = re.search(r"final chi2.*", summary.full_report()).group(0)
    assert line in out
    assert str(summary) == summary.brief_report()
    result = tether.run_pipeline(str(path))
    assert result.ok() and result.status == "ok"
    assert result.summary.final_chi2 == pytest.approx(cli_final, rel=1e-8)


def test_parse_error_names_file_and_line(tmp_path):
    bad = tmp_path / "bad.g2o"
    bad.write_text("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 zero 1 0 0 1 0 1\n")
    with pytest.raises(tether.ParseError, match=r"bad\.g2o:3:") as e:
        tether.read_graph(str(bad))
    assert isinstance(e.value, tether.Error) and isinstance(e.value, ValueError)
    with pytest.raises(tether.IoError):
        tether.read_graph(str(tmp_path / "missing.g2o"))
    result = tether.run_pipeline(str(bad))
    assert not result.ok() and result.status == "bad-input" and "bad.g2o:3" in result.message


def test_pipeline_writes_every_output_together(tmp_path):
    graph, initial, truth = tether.simulate("manhattan", poses=80, seed=7)
    tether.write_g2o(str(tmp_path / "in.g2o"), graph, initial)
    tether.write_g2o(str(tmp_path / "truth.g2o"), graph, truth)
    out, plot = tmp_path / "out.g2o", tmp_path / "plot.svg"
    result = tether.run_pipeline(str(tmp_path / "in.g2o"), output=str(out), covariance=[4, 9], plot=str(plot),
                                 ground_truth=str(tmp_path / "truth.g2o"))
    assert result.ok(), result.message
    assert result.written_paths == [str(out), str(out) + ".cov", str(plot)]
    assert sorted(result.covariances) == [4, 9] and result.covariances[9].shape == (3, 3)
    marginals = tether.Marginals(result.graph, result.values)
    np.testing.assert_allclose(result.covariances[9], marginals.marginal(9), rtol=1e-9)
    assert result.result_error.poses == 80 and result.result_error.rmse < 0.5 * result.start_error.rmse
    assert plot.read_text().startswith("<svg") and "ground truth" in plot.read_text()
    # A stage after the solve that fails replaces none of the files.
    out.write_text("old\n")
    failed = tether.run_pipeline(str(tmp_path / "in.g2o"), output=str(out), covariance=[4, 99999], plot=str(plot))
    assert failed.status == "bad-input" and "99999" in failed.message and not failed.written
    assert out.read_text() == "old\n" and plot.read_text().startswith("<svg")
    with pytest.raises(tether.InvalidArgument, match="covariance is None, 'all' or a sequence of keys"):
        tether.run_pipeline(str(tmp_path / "in.g2o"), output=str(out), covariance="some")
    assert tether.run_pipeline(str(tmp_path / "in.g2o"), covariance="all").status == "invalid-options"


def test_write_and_read_back(tmp_path):
    graph, initial, _ = tether.simulate("manhattan", poses=50, seed=7)
    out = tmp_path / "m.g2o"
    tether.write_g2o(str(out), graph, initial)
    g2, v2 = tether.read_graph(str(out))
    assert len(g2) == len(graph) and len(v2) == len(initial)
    assert g2.chi2(v2) == pytest.approx(graph.chi2(initial), rel=1e-12)


def test_callback_sees_the_table_and_stops_the_solve():
    graph, initial, _ = tether.simulate("manhattan", poses=300, seed=5)
    full = initial.copy()
    rows = []
    s_full = tether.optimize(graph, full, callback=lambda it: rows.append(it))
    assert [r.iteration for r in rows] == [r.iteration for r in s_full.log]
    assert rows[0].iteration == 0 and rows[-1].chi2 == pytest.approx(s_full.final_chi2)
    assert all(hasattr(r, f) for r in rows for f in ("chi2", "relative_decrease", "lambda_", "step_norm", "seconds"))
    assert s_full.iterations >= 2

    stopped = initial.copy()
    s = tether.optimize(graph, stopped, callback=lambda it: it.iteration < 1)
    assert "stopped by keep_going after iteration 1" in s.message
    assert s.status == "stopped" and s.iterations == 1
    assert s.final_chi2 == pytest.approx(graph.chi2(stopped))
    assert s.final_chi2 == pytest.approx(rows[1].chi2)  # the state the callback saw at iteration 1
    assert s.final_chi2 < s.initial_chi2 and s.final_chi2 > s_full.final_chi2

    def raises(it):
        raise KeyError("callback")

    with pytest.raises(KeyError, match="callback"):
        tether.optimize(graph, initial.copy(), callback=raises)


def test_solver_options_and_their_errors():
    o = tether.SolverOptions()
    assert o.algorithm == "lm" and o.linear_solver == "auto" and o.max_iterations == 100
    o.algorithm = "dogleg"
    o.linear_solver = "qr"
    with pytest.raises(tether.InvalidArgument, match="unknown algorithm 'newton'"):
        o.algorithm = "newton"
    o.max_iterations = -1
    ok, why = o.is_valid()
    assert not ok and "max_iterations" in why
    graph, initial, _ = tether.simulate("manhattan", poses=30)
    s = tether.optimize(graph, initial, o)
    assert s.status == "invalid-input" and "max_iterations" in s.message


def test_marginals_are_numpy_arrays():
    graph, initial, _ = tether.simulate("manhattan", poses=40, seed=3)
    graph.add(tether.PriorSE2(0, initial.at(0), tether.SqrtInformation.isotropic(3, 0.01)))
    tether.optimize(graph, initial)
    m = tether.Marginals(graph, initial)
    c0, c39 = m.marginal(0), m.marginal(39)
    assert c0.shape == (3, 3) and c0.dtype == np.float64
    assert np.all(np.linalg.eigvalsh(c39) > 0)
    assert np.trace(c39) > np.trace(c0)  # uncertainty grows away from the prior
    j = m.joint_marginal([0, 39])
    assert j.shape == (6, 6)
    np.testing.assert_allclose(j[3:, 3:], c39, rtol=1e-9)


def _feed_pose_by_pose(smoother, graph, initial, poses):
    """Adds pose i with the factors it completes, one update per pose."""
    by_step = [[] for _ in range(poses)]
    for k in range(len(graph)):
        by_step[max(graph[k].keys)].append(graph[k])
    updates = []
    for i in range(poses):
        step = tether.FactorGraph()
        for f in by_step[i]:
            if not any(smoother.was_marginalized(key) for key in f.keys):
                step.add(f)
        new = tether.Values()
        new.insert(i, initial.at(i))
        updates.append(smoother.update(step, new))
        yield updates[-1]


def test_fixed_lag_smoother_keeps_a_window_and_hands_out_what_leaves():
    graph, initial, _ = tether.simulate("manhattan", poses=120, seed=4)
    # A lag longer than the run: nothing leaves, the window is the whole graph's optimum.
    whole = tether.FixedLagSmoother(tether.FixedLagOptions())
    for u in _feed_pose_by_pose(whole, graph, initial, 120):
        assert u.marginalized == 0
    assert whole.marginalized == 0
    final = whole.finish()
    batch = initial.copy()
    tether.optimize(graph, batch)
    assert graph.chi2(final) == pytest.approx(graph.chi2(batch), rel=1e-6)
    # A lag of 20: a bounded window, the poses that left handed out once, and a factor that
    # reaches a marginalised pose refused.
    o = tether.FixedLagOptions()
    o.lag = 20
    o.batch = 0.25
    smoother = tether.FixedLagSmoother(o)
    left = {}
    for u in _feed_pose_by_pose(smoother, graph, initial, 120):
        assert len(smoother.estimate()) <= 26
        out = smoother.take_marginalized()
        for key in out.keys():
            assert key not in left
            left[key] = out.at(key)
    assert smoother.marginalized == len(left) and len(left) + len(smoother.estimate()) == 120
    assert smoother.was_marginalized(0) and not smoother.was_marginalized(119)
    assert smoother.marginal(119).shape == (3, 3)
    late = tether.FactorGraph()
    late.add(graph[0])  # the odometry 0 -> 1
    with pytest.raises(tether.InvalidArgument, match="marginalised"):
        smoother.update(late)
    bad = tether.FixedLagOptions()
    bad.lag = -1
    with pytest.raises(tether.InvalidArgument, match="lag"):
        tether.FixedLagSmoother(bad)


def test_incremental_smoother_matches_the_batch_solve():
    graph, initial, _ = tether.simulate("manhattan", poses=80, seed=9)
    smoother = tether.IncrementalSmoother()
    added = set()
    for k in range(len(graph)):
        f = graph[k]
        step = tether.FactorGraph()
        step.add(f)
        new = tether.Values()
        for key in f.keys:
            if key not in added:
                new.insert(key, initial.at(key))
                added.add(key)
        if k == 0:
            step.add(tether.PriorSE2(0, initial.at(0), tether.SqrtInformation.isotropic(3, 1e-4)))
        u = smoother.update(step, new)
        assert u.factors_added == len(step)
    est = smoother.estimate()
    assert len(est) == len(initial)
    cov = smoother.marginal(79)
    assert cov.shape == (3, 3)
    final = smoother.finish()
    assert smoother.finish_summary.status == "converged"
    batch = initial.copy()
    g = graph.copy()
    g.add(tether.PriorSE2(0, initial.at(0), tether.SqrtInformation.isotropic(3, 1e-4)))
    tether.optimize(g, batch)
    assert g.chi2(final) == pytest.approx(g.chi2(batch), rel=1e-6)
    # removal by handle
    h = smoother.graph().handles()[-1]
    u = smoother.update(remove=[h])
    assert u.factors_removed == 1 and len(smoother.graph()) == len(g) - 1


def test_plugin_types_from_files_and_from_python(plugin_dir, tmp_path):
    so = plugin_dir / "odometry_scale.so"
    if not so.exists():
        pytest.skip(f"{so} is not built")
    p = tether.load_plugin(str(so))
    assert "Scale" in p.variable_names and "ScaledOdometrySE2" in p.type_names
    assert "Scale" in tether.variable_types()
    # Poses 2 m apart, odometry that says 1 m: the scale comes out as 2.
    lines = ["VERTEX_SE2 %d %g 0 0" % (i, i * 1.0) for i in range(5)] + ["VERTEX_SCALE 100 1"]
    lines += ["EDGE_SE2_SCALED %d %d 100 1 0 0 100 0 0 100 0 100" % (i, i + 1) for i in range(4)]
    path = tmp_path / "scaled.g2o"
    path.write_text("\n".join(lines) + "\n")
    graph, values = tether.read_graph(str(path))
    assert values.type_of(100) == "Scale" and values.at(100).shape == (1,)
    n = tether.SqrtInformation.isotropic(3, 1e-3)
    graph.add(tether.PriorSE2(0, tether.SE2(0, 0, 0), n))
    graph.add(tether.make_factor("PriorSE2", [4], [8.0, 0.0, 0.0], n))
    s = tether.optimize(graph, values)
    assert s.status == "converged", s.full_report()
    assert values.at(100)[0] == pytest.approx(2.0, abs=1e-6)
    # The plugin's factor made from Python, and its variable inserted by type name.
    f = tether.make_factor("ScaledOdometrySE2", [0, 1, 100], [1.0, 0.0, 0.0], tether.SqrtInformation.identity(3))
    v = tether.Values()
    v.insert(0, tether.SE2())
    v.insert(1, tether.SE2(2, 0, 0))
    v.insert(100, np.array([2.0]), type="Scale")
    assert f.chi2(v) == pytest.approx(0.0, abs=1e-20)
    with pytest.raises(tether.PluginError):
        tether.load_plugin(str(tmp_path / "nothing.so"))
