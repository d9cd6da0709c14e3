"""Measuring and drawing results from Python: the absolute trajectory error and the SVG plot,
the same code `tether optimize --ground-truth --plot` runs; the smoother's mode and the option
names that come from the library's one table of enum names."""
import math
import re
import subprocess
import sys

import pytest

import tether


def _solved_world(seed=3):
    graph, initial, truth = tether.simulate("manhattan", poses=200, seed=seed)
    result = initial.copy()
    tether.initialize(graph, result, "chordal")
    summary = tether.optimize(graph, result)
    assert summary.status == "converged"
    return graph, initial, result, truth


def test_the_solve_lowers_the_trajectory_error():
    graph, initial, result, truth = _solved_world()
    start = tether.absolute_trajectory_error(initial, truth)
    end = tether.absolute_trajectory_error(result, truth)
    assert start.poses == end.poses == 200
    assert end.rmse < 0.5 * start.rmse
    assert end.mean <= end.rmse <= end.max
    # A trajectory against itself has no error; an unaligned shift is all error.
    assert tether.absolute_trajectory_error(truth, truth).rmse == pytest.approx(0, abs=1e-9)
    shifted = truth.copy()
    for k in shifted.keys():
        p = shifted.at(k)
        shifted.update(k, tether.SE2(p.x + 1.0, p.y, p.theta))
    assert tether.absolute_trajectory_error(shifted, truth).rmse == pytest.approx(0, abs=1e-9)
    assert tether.absolute_trajectory_error(shifted, truth, alignment="none").rmse == pytest.approx(1.0)
    with pytest.raises(tether.InvalidArgument, match="rigid or none"):
        tether.absolute_trajectory_error(shifted, truth, alignment="scaled")
    nothing = tether.absolute_trajectory_error(tether.Values(), truth)
    assert nothing.poses == 0 and math.isnan(nothing.rmse)


def test_the_plot_is_the_commands_plot(tmp_path, cli):
    graph, initial, result, truth = _solved_world()
    options = tether.PlotOptions()
    options.title = "world"
    options.before_label = "file's start"
    options.after_label = "result"
    svg = tether.plot_svg(graph, before=initial, after=result, truth=truth, options=options)
    assert svg.startswith("<svg") and svg.endswith("</svg>\n")
    assert "s start" in svg and "result" in svg and "ground truth" in svg
    # The legend gives the trajectory error the function above gives.
    ate = tether.absolute_trajectory_error(result, truth).rmse
    assert re.search(r"result \(ATE [0-9.e-]+ m\)", svg)
    path = tmp_path / "p.svg"
    tether.write_svg(str(path), graph, before=initial, after=result, options=options)
    assert path.read_text().startswith("<svg")
    # The command draws the same picture from the same inputs (written and read back as g2o).
    g2o = tmp_path / "w.g2o"
    tether.write_g2o(str(g2o), graph, initial)
    out_svg = tmp_path / "cli.svg"
    subprocess.run([cli, "optimize", str(g2o), "-q", "--plot", str(out_svg)], check=True, capture_output=True)
    text = out_svg.read_text()
    assert "s start" in text and "result" in text
    assert ate > 0
    with pytest.raises(tether.InvalidArgument):
        bad = tether.PlotOptions()
        bad.width_px = 10
        tether.plot_svg(graph, after=result, options=bad)


def test_plot_helper_draws_with_matplotlib_where_installed(tmp_path):
    mpl = pytest.importorskip("matplotlib", reason="python3-matplotlib is not installed")
    mpl.use("Agg")
    graph, initial, result, truth = _solved_world()
    options = tether.PlotOptions()
    options.title = "world"
    options.before_label = "file's start"
    options.after_label = "result"
    path = tmp_path / "p.png"
    ax = tether.plot(graph, before=initial, after=result, truth=truth, options=options, path=str(path))
    assert ax.get_title() == "world"
    labels = [line.get_label() for line in ax.get_lines()]
    ate = tether.absolute_trajectory_error(result, truth).rmse
    assert labels[0] == "ground truth" and labels[1].startswith("file's start (ATE ")
    assert labels[2].startswith("result (ATE ") and ate > 0
    assert "loop closures" in labels and labels[-1] == "start"
    # The result's line is its poses in key order (one run: odometry joins them all).
    after = ax.get_lines()[2]
    xs = after.get_xdata()
    assert len(xs) == 200
    assert xs[17] == pytest.approx(result.at(17).x) and after.get_ydata()[17] == pytest.approx(result.at(17).y)
    assert path.read_bytes().startswith(b"\x89PNG")
    # On an Axes the caller made, nothing else is made.
    import matplotlib.pyplot as plt

    fig, mine = plt.subplots()
    assert tether.plot(graph, after=result, ax=mine) is mine
    plt.close("all")


def test_plot_helper_falls_back_to_svg(tmp_path, monkeypatch):
    graph, initial, result, truth = _solved_world()
    svg = tether.plot(graph, before=initial, after=result, truth=truth, backend="svg", path=str(tmp_path / "p.svg"))
    assert svg == tether.plot_svg(graph, before=initial, after=result, truth=truth)
    assert (tmp_path / "p.svg").read_text() == svg
    # Without matplotlib, 'auto' draws the SVG; asking for matplotlib says how to get it.
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    monkeypatch.setitem(sys.modules, "matplotlib.pyplot", None)
    assert tether.plot(graph, after=result) == tether.plot_svg(graph, after=result)
    with pytest.raises(tether.InvalidArgument, match="python3-matplotlib"):
        tether.plot(graph, after=result, backend="matplotlib")
    with pytest.raises(tether.InvalidArgument, match="auto, matplotlib or svg"):
        tether.plot(graph, after=result, backend="png")


def test_enum_options_take_the_tables_names():
    o = tether.SmootherOptions()
    assert o.mode == "factor" and o.factorization == "auto"
    o.mode = "local"
    o.factorization = "multifrontal"
    o.local_hops = 3
    assert (o.mode, o.factorization, o.local_hops) == ("local", "multifrontal", 3)
    with pytest.raises(tether.InvalidArgument, match="use factor or local"):
        o.mode = "global"
    with pytest.raises(tether.InvalidArgument, match="use auto, left-looking or multifrontal"):
        o.factorization = "supernodal"
    with pytest.raises(tether.InvalidArgument, match="use manhattan, sphere or landmarks"):
        tether.simulate("city")


def test_check_factor_types_finds_a_wrong_jacobian(test_plugin_dir):
    loaded = tether.load_plugin(str(test_plugin_dir / "test_wrong_jacobian.so"))
    checks = {c.type: c for c in tether.check_factor_types(loaded.type_names, trials=30)}
    assert set(checks) == {"TestRightRange", "TestWrongRange"}
    assert checks["TestRightRange"].ok and checks["TestRightRange"].largest < 1e-6
    wrong = checks["TestWrongRange"]
    assert not wrong.ok and wrong.failed > 0
    assert "d e[0] / d delta_0[1]" in wrong.first_failure
    # The built-in types pass the same check.
    assert all(c.ok for c in tether.check_factor_types(["BetweenSE2", "BetweenSE3"], trials=20))
    with pytest.raises(tether.InvalidArgument, match="no factor type named"):
        tether.check_factor_types(["NoSuchType"])


def test_a_failed_solve_prints_its_reason():
    graph, values = tether.FactorGraph(), tether.Values()
    values.insert(0, tether.SE2(0, 0, 0))
    values.insert(1, tether.SE2(float("nan"), 0, 0))
    graph.add(tether.BetweenSE2(0, 1, tether.SE2(1, 0, 0), tether.SqrtInformation.identity(3)))
    graph.fix(0)
    summary = tether.optimize(graph, values)
    assert summary.status == "invalid-input"
    # The printed line names the factor, as the message does; a usable result prints no message.
    assert str(summary).startswith("invalid-input: ")
    assert "factor 0 (BetweenSE2, keys 0, 1) has a non-finite error" in str(summary)
    assert summary.message in str(summary)
