#!/usr/bin/env python3
"""Optimise a pose graph and draw its trajectory before and after.

    PYTHONPATH=build/python python3 examples/python/optimize_and_plot.py [graph.g2o] [-o out.png|out.svg]

Without a file it builds a graph itself: a robot driving laps around a block, with noisy
odometry and loop closures wherever it passes an earlier pose (nothing outside the repository
is needed). With a file (g2o, TORO or iSAM) it reads it and starts from the chordal
initialisation, as `tether optimize` does. The picture is drawn with matplotlib where it is
installed (python3-matplotlib), else written as an SVG by this script.
"""
import argparse
import math
import sys

import numpy as np

import tether


def build_laps(laps=4, side=10, seed=1):
    """(graph, initial values): laps around a side x side square, one pose per metre."""
    rng = np.random.default_rng(seed)
    per_lap = 4 * side
    n = laps * per_lap + 1
    truth = []
    x = tether.SE2(0, 0, 0)
    for k in range(n):
        truth.append(x)
        turn = math.pi / 2 if (k + 1) % side == 0 else 0.0
        x = x * tether.SE2(1.0, 0.0, turn)
    sigmas = np.array([0.05, 0.05, 0.02])
    info = np.diag(1 / sigmas**2)
    # Odometry: the true relative motion plus noise; initial values compose it.
    i = np.arange(n - 1, dtype=np.uint64)
    z = np.array([(truth[k].inverse() * truth[k + 1]).retract(rng.normal(0, sigmas)).params() for k in range(n - 1)])
    # Loop closures: each pose to the same corner of the block one lap earlier.
    ci = np.arange(per_lap, n, dtype=np.uint64)
    cj = ci - per_lap
    cz = np.array([(truth[int(a)].inverse() * truth[int(b)]).retract(rng.normal(0, sigmas)).params()
                   for a, b in zip(ci, cj)])
    graph = tether.FactorGraph()
    graph.add_between_se2_batch(np.concatenate([i, ci]), np.concatenate([i + 1, cj]), np.concatenate([z, cz]), info)
    graph.add(tether.PriorSE2(0, truth[0], tether.SqrtInformation.isotropic(3, 1e-3)))
    values = tether.Values()
    pose = truth[0]
    values.insert(0, pose)
    for k in range(n - 1):
        pose = pose * tether.SE2.from_params(z[k])
        values.insert(k + 1, pose)
    return graph, values


def xy(values):
    """(N, 2) positions of the poses (SE2, or SE3 seen from above) in insertion order."""
    for t in ("SE2", "SE3"):
        _, p = values.array(t)
        if len(p):
            return p[:, :2]
    return np.zeros((0, 2))


def plot_matplotlib(before, after, title, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 7))
    ax.plot(before[:, 0], before[:, 1], color="#bbbbbb", lw=1, label="before")
    ax.plot(after[:, 0], after[:, 1], color="#1f77b4", lw=1.2, label="after")
    ax.set_aspect("equal")
    ax.set_title(title)
    ax.legend()
    fig.savefig(path, dpi=120, bbox_inches="tight")


def plot_svg(before, after, title, path, size=700, margin=30):
    both = np.vstack([before, after])
    lo, hi = both.min(axis=0), both.max(axis=0)
    scale = (size - 2 * margin) / max(float(np.max(hi - lo)), 1e-9)

    def points(p):
        q = (p - lo) * scale + margin
        return " ".join(f"{a:.2f},{size - b:.2f}" for a, b in q)

    with open(path, "w") as f:
        f.write(f'<svg xmlns="http://www.w3.org/2000/svg" width="{size}" height="{size + 30}">\n')
        f.write('<rect width="100%" height="100%" fill="white"/>\n')
        f.write(f'<text x="{margin}" y="20" font-family="sans-serif" font-size="14">{title}</text>\n')
        f.write(f'<g transform="translate(0,30)"><polyline fill="none" stroke="#bbbbbb" stroke-width="1" '
                f'points="{points(before)}"/>\n')
        f.write(f'<polyline fill="none" stroke="#1f77b4" stroke-width="1.2" points="{points(after)}"/></g>\n')
        f.write(f'<text x="{size - 200}" y="20" font-family="sans-serif" font-size="12" fill="#888">'
                'grey: before, blue: after</text>\n</svg>\n')


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("graph", nargs="?", help="a g2o / TORO / iSAM file (default: a graph built here)")
    ap.add_argument("-o", "--output", help="the picture (.png or .svg; default optimize_and_plot.png, or .svg "
                    "without matplotlib)")
    ap.add_argument("--svg", action="store_true", help="write the SVG without matplotlib even where it is installed")
    args = ap.parse_args()

    if args.graph:
        graph, values = tether.read_graph(args.graph)
        print(tether.initialize(graph, values, "chordal").message)
        name = args.graph
    else:
        graph, values = build_laps()
        name = "4 laps around a block (built by the example)"
    before = xy(values)
    print(f"{name}: {len(values)} variables, {len(graph)} factors, chi2 {graph.chi2(values):.6g}")
    print("iter              chi2    rel.decr")
    summary = tether.optimize(graph, values,
                              callback=lambda it: print(f"{it.iteration:5d}  {it.chi2:16.9g}  {it.relative_decrease:10.3e}"))
    print(summary.full_report())
    after = xy(values)

    title = f"{name}: chi2 {summary.initial_chi2:.4g} -> {summary.final_chi2:.4g}"
    try:
        if args.svg or (args.output or "").endswith(".svg"):
            raise ImportError("SVG asked for")
        import matplotlib  # noqa: F401

        out = args.output or "optimize_and_plot.png"
        plot_matplotlib(before, after, title, out)
    except ImportError:
        out = args.output or "optimize_and_plot.svg"
        plot_svg(before, after, title, out)
    print(f"wrote {out}")
    return 0 if summary.is_solution_usable() else 1


if __name__ == "__main__":
    sys.exit(main())
