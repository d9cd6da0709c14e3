"""Robust losses by name from the loss registry: the built-ins, an unknown name's message, and a
plugin's loss (barron_loss) used by name from Python once the plugin is loaded."""
import math

import numpy as np
import pytest

import tether


def test_builtin_losses_are_listed_and_an_unknown_name_lists_them():
    assert tether.loss_names()[:5] == ["huber", "cauchy", "tukey", "gm", "dcs"]
    for name in ["huber", "cauchy", "tukey", "gm", "dcs"]:
        assert tether.make_loss(name + ":2").name == name + ":2"
    with pytest.raises(tether.InvalidArgument) as e:
        tether.make_loss("nope:1")
    message = str(e.value)
    assert "unknown kernel 'nope'" in message
    assert "registered: huber, cauchy, tukey, gm, dcs" in message
    assert isinstance(e.value, ValueError)
    with pytest.raises(tether.InvalidArgument, match="takes no parameter"):
        tether.make_loss("huber:1:2")


def two_laps(n=40, wrong=3, seed=5):
    """Two laps of a circle: noisy odometry, true closures between the laps, wrong closures."""
    rng = np.random.default_rng(seed)
    truth = [tether.SE2(10 * math.cos(2 * math.pi * i / n), 10 * math.sin(2 * math.pi * i / n),
                        2 * math.pi * i / n + math.pi / 2) for i in range(2 * n)]
    sigmas = np.array([0.05, 0.05, 0.01])
    noise = tether.SqrtInformation.from_sigmas(sigmas)
    graph = tether.FactorGraph()
    start = tether.Values()
    start.insert(0, truth[0])
    at = truth[0]
    for i in range(2 * n - 1):
        z = (truth[i].inverse() * truth[i + 1]).retract(rng.normal(0, sigmas))
        graph.add(tether.BetweenSE2(i, i + 1, z, noise))
        at = at * z
        start.insert(i + 1, at)
    closures = []
    for i in range(0, n, 2):
        z = (truth[i].inverse() * truth[i + n]).retract(rng.normal(0, sigmas))
        closures.append(tether.BetweenSE2(i, i + n, z, noise))
    bad = []
    for i, j in [(3, 50), (12, 70), (30, 44)][:wrong]:
        bad.append(tether.BetweenSE2(i, j, tether.SE2(*rng.uniform(-5, 5, 2), 1.0), noise))
    return truth, graph, start, closures, bad


def rms_error(values, truth):
    return math.sqrt(sum(float(np.sum((values.at(i).translation() - p.translation()) ** 2))
                         for i, p in enumerate(truth)) / len(truth))


def test_a_plugin_loss_is_used_by_name_once_the_plugin_is_loaded(plugin_dir, tmp_path):
    so = plugin_dir / "barron_loss.so"
    if not so.exists():
        pytest.skip(f"{so} is not built")
    p = tether.load_plugin(str(so))
    assert p.loss_names == ["barron"] and "1 robust loss" in p.summary()
    assert "barron" in tether.loss_names()
    # The text forms: barron:SCALE:ALPHA, alpha 1 by default; the closed forms at 0 and 1.
    assert tether.make_loss("barron:2").name == "barron:2:1"
    s, c = 3.0, 1.5
    rho, d1, _ = tether.make_loss("barron:1.5:0").evaluate(s)
    assert rho == pytest.approx(2 * c * c * math.log1p(s / (2 * c * c)), rel=1e-14)
    assert d1 == pytest.approx(1 / (1 + s / (2 * c * c)), rel=1e-14)
    rho, _, _ = tether.make_loss("barron:1.5:1").evaluate(s)
    assert rho == pytest.approx(2 * c * c * (math.sqrt(1 + s / (c * c)) - 1), rel=1e-14)
    with pytest.raises(tether.InvalidArgument, match="alpha must be below infinity"):
        tether.make_loss("barron:1:inf")

    # A solve from the chordal start, as `tether optimize` starts: least squares is bent by the
    # wrong closures, barron on the closures is not, and weighs them far less than the true ones.
    truth, graph, odometry, closures, bad = two_laps()
    clean = graph.copy()
    for f in closures:
        clean.add(f)
    plain = clean.copy()
    for f in bad:
        plain.add(f)
    start = odometry.copy()
    tether.initialize(plain, start, "chordal")
    clean_values = start.copy()
    assert tether.optimize(clean, clean_values).status == "converged"
    clean_error = rms_error(clean_values, truth)
    plain_values = start.copy()
    tether.optimize(plain, plain_values)
    assert rms_error(plain_values, truth) > 10 * clean_error
    for spec in ["barron:1", "barron:1:0", "barron:1:-2"]:
        robust = graph.copy()
        for f in closures + bad:
            g = f.copy()
            g.set_loss(spec)  # the text form, looked up in the registry
            robust.add(g)
        values = start.copy()
        summary = tether.optimize(robust, values)
        assert summary.status == "converged", summary.full_report()
        assert rms_error(values, truth) < 1.5 * clean_error + 0.02, spec
        loss = tether.make_loss(spec)
        wrong = max(loss.weight(f.chi2(values)) for f in bad)
        true = min(loss.weight(f.chi2(values)) for f in closures)
        assert wrong < 0.2 and wrong < 0.25 * true, spec

    # The same name in run_pipeline's robust rules (what `tether optimize --robust` does).
    path = tmp_path / "laps.g2o"
    tether.write_g2o(str(path), plain, odometry)
    result = tether.run_pipeline(str(path), robust=["loop=barron:1:0"])
    assert result.ok(), result.message
    assert rms_error(result.values, truth) < 1.5 * clean_error + 0.02
    with pytest.raises(tether.InvalidArgument, match="must be a number"):
        tether.run_pipeline(str(path), robust=["loop=barron:1:nan"])
    with pytest.raises(tether.InvalidArgument, match="unknown kernel 'barronn'"):
        tether.run_pipeline(str(path), robust=["loop=barronn:1"])
