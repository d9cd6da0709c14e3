#!/usr/bin/env python3
"""Speed of building graphs from Python, and of factors written in Python.

    PYTHONPATH=build-py/python python3 python_bindings/benchmarks/build_speed.py \
        [--graph /tmp/m.g2o] [--poses 100000] [--cli build-py/tools/tether]

1. Builds the graph of a g2o file (simulated by `tether simulate manhattan` where absent) three
   ways and times each: the C++ reader (tether.read_graph), the batch calls from NumPy arrays
   (Values.insert_batch + FactorGraph.add_between_se2_batch), and a per-factor Python loop.
   The arrays are parsed from the file beforehand (not timed).
2. Solves a smaller Manhattan graph with its BetweenSE2 factors in C++ and as PythonFactor
   twins (analytic Jacobians in Python, and central differences), and reports the cost per
   factor evaluation.
Best of --repeat runs for each timing.
"""
import argparse
import math
import os
import subprocess
import time

import numpy as np

import tether


def best_of(n, fn):
    best = math.inf
    for _ in range(n):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def parse_g2o(path):
    """The VERTEX_SE2 and EDGE_SE2 lines of a file as arrays (keys, poses; i, j, z, information)."""
    vk, vp, ei, ej, ez, einfo = [], [], [], [], [], []
    with open(path) as f:
        for line in f:
            t = line.split()
            if not t:
                continue
            if t[0] == "VERTEX_SE2":
                vk.append(int(t[1]))
                vp.append([float(x) for x in t[2:5]])
            elif t[0] == "EDGE_SE2":
                ei.append(int(t[1]))
                ej.append(int(t[2]))
                ez.append([float(x) for x in t[3:6]])
                a, b, c, d, e, g = (float(x) for x in t[6:12])
                einfo.append([[a, b, c], [b, d, e], [c, e, g]])
    return (np.array(vk, dtype=np.uint64), np.array(vp), np.array(ei, dtype=np.uint64),
            np.array(ej, dtype=np.uint64), np.array(ez), np.array(einfo))


def build_batch(vk, vp, ei, ej, ez, einfo):
    values = tether.Values()
    values.insert_batch("SE2", vk, vp)
    graph = tether.FactorGraph()
    graph.add_between_se2_batch(ei, ej, ez, einfo)
    return graph, values


def build_loop(vk, vp, ei, ej, ez, einfo):
    values = tether.Values()
    for k, p in zip(vk.tolist(), vp.tolist()):
        values.insert(k, tether.SE2(*p))
    graph = tether.FactorGraph()
    for a, b, z, info in zip(ei.tolist(), ej.tolist(), ez.tolist(), einfo):
        graph.add(tether.BetweenSE2(a, b, tether.SE2(*z), tether.SqrtInformation.from_information(info)))
    return graph, values


def between_twin(f):
    z = f.measured
    cz, sz = math.cos(z.theta), math.sin(z.theta)

    def error(x):
        d = x[0].inverse() * x[1]
        ex, ey = d.x - z.x, d.y - z.y
        return np.array([cz * ex + sz * ey, -sz * ex + cz * ey, tether.wrap_angle(d.theta - z.theta)])

    def jacobians(x):
        d = x[0].inverse() * x[1]
        c, s = math.cos(d.theta - z.theta), math.sin(d.theta - z.theta)
        return [np.array([[-cz, -sz, cz * d.y - sz * d.x], [sz, -cz, -sz * d.y - cz * d.x], [0, 0, -1.0]]),
                np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])]

    return error, jacobians


def python_factor_cost(poses, repeat):
    graph, initial, _ = tether.simulate("manhattan", poses=poses, seed=1)
    twins = {}
    for name, analytic in (("python, analytic Jacobians", True), ("python, numeric Jacobians", False)):
        g = tether.FactorGraph()
        for k in range(len(graph)):
            f = graph[k]
            e, j = between_twin(f)
            g.add(tether.PythonFactor(f.keys, ["SE2", "SE2"], 3, e, f.noise, jacobians=j if analytic else None))
        twins[name] = g
    rows = []
    for name, g in [("C++ BetweenSE2", graph)] + list(twins.items()):
        t, s = best_of(repeat, lambda: tether.optimize(g, initial.copy()))
        # One linearisation per iteration that was tried, plus the start.
        evals = (s.iterations + 1) * len(g)
        rows.append((name, t, s.linearize_seconds, s.iterations, s.final_chi2,
                     s.linearize_seconds / evals * 1e6))
    return len(graph), rows


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--graph", default="/tmp/m.g2o")
    ap.add_argument("--poses", type=int, default=100000)
    ap.add_argument("--cli", default=os.path.join(os.path.dirname(__file__), "../../build-py/tools/tether"))
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--factor-poses", type=int, default=2000)
    args = ap.parse_args()
    if not os.path.exists(args.graph):
        subprocess.run([args.cli, "simulate", "manhattan", "--poses", str(args.poses), "-o", args.graph], check=True)
    arrays = parse_g2o(args.graph)
    print(f"{args.graph}: {len(arrays[0])} poses, {len(arrays[2])} BetweenSE2 factors")
    t_read, (g, v) = best_of(args.repeat, lambda: tether.read_graph(args.graph))
    t_batch, (gb, vb) = best_of(args.repeat, lambda: build_batch(*arrays))
    t_loop, (gl, vl) = best_of(1, lambda: build_loop(*arrays))
    chi2 = g.chi2(v)
    assert abs(gb.chi2(vb) - chi2) <= 1e-9 * chi2 and abs(gl.chi2(vl) - chi2) <= 1e-9 * chi2
    print(f"  C++ reader (read_graph)          {t_read:8.3f} s")
    print(f"  batch from NumPy arrays          {t_batch:8.3f} s  ({t_batch / t_read:.2f}x the reader)")
    print(f"  per-factor Python loop           {t_loop:8.3f} s  ({t_loop / t_read:.2f}x the reader)")
    n, rows = python_factor_cost(args.factor_poses, args.repeat)
    print(f"manhattan {args.factor_poses} poses, {n} factors, optimize() with default options:")
    print(f"  {'factors':28s} {'solve [s]':>9s} {'linearise [s]':>13s} {'iter':>4s} {'final chi2':>14s} {'us/factor eval':>14s}")
    for name, t, lin, it, c, per in rows:
        print(f"  {name:28s} {t:9.3f} {lin:13.3f} {it:4d} {c:14.6f} {per:14.2f}")


if __name__ == "__main__":
    main()
