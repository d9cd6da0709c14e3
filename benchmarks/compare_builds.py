#!/usr/bin/env python3
"""Whole-process wall times of two tether builds on the public g2o files, runs interleaved.

Usage: benchmarks/compare_builds.py BEFORE_TETHER AFTER_TETHER [REPEATS] [FILES]
  BEFORE_TETHER, AFTER_TETHER: paths of two `tether` programs
  REPEATS: runs per build, file and solver (default 9); the builds alternate, the order
           flipping every run, so that a noisy neighbour hits both alike
  FILES: comma-separated names in ../shared/datasets/g2o (default: all eleven)
Prints a Markdown table: median (min) per build and the ratio of the medians.
"""
import os
import statistics
import subprocess
import sys
import tempfile
import time

ALL = "intel,MIT,CSAIL,manhattan,ais2klinik,kitti_00,input_M3500_g2o,sphere2500,parking-garage,smallGrid3D,tinyGrid3D"


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    bins = {"before": sys.argv[1], "after": sys.argv[2]}
    reps = int(sys.argv[3]) if len(sys.argv) > 3 else 9
    files = (sys.argv[4] if len(sys.argv) > 4 else ALL).split(",")
    data = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "shared", "datasets", "g2o")
    out = os.path.join(tempfile.mkdtemp(), "out.g2o")
    print("| file | solver | before: median (min) [s] | after: median (min) [s] | median after / before |")
    print("|---|---|---|---|---|")
    for f in files:
        for solver in ("gn", "lm"):
            times = {"before": [], "after": []}
            for r in range(reps):
                for name in ("before", "after") if r % 2 == 0 else ("after", "before"):
                    t0 = time.perf_counter()
                    subprocess.run([bins[name], "optimize", os.path.join(data, f + ".g2o"), "--solver", solver,
                                    "--linear", "cholmod", "-q", "-o", out],
                                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=False)
                    times[name].append(time.perf_counter() - t0)
            mb, ma = statistics.median(times["before"]), statistics.median(times["after"])
            print(f"| {f} | {solver} | {mb:.3f} ({min(times['before']):.3f}) | {ma:.3f} ({min(times['after']):.3f}) "
                  f"| {ma / mb:.2f} |", flush=True)


if __name__ == "__main__":
    main()
