#!/usr/bin/env python3
"""Whole-process wall time of `tether optimize FILE -o OUT -q` for one or more tether builds,
interleaved run by run (so that a machine's drift hits every build alike), median of N runs
per file and build, as a Markdown table. OPENBLAS_NUM_THREADS=1 and OMP_NUM_THREADS=1, as the
issue's SLAM++ comparison ran.

  usage: benchmarks/whole_process.py [--runs N] [--files a,b,...] LABEL=TETHER [LABEL=TETHER ...]
"""
import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time

DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "shared", "datasets", "g2o")
FILES = ["intel", "MIT", "CSAIL", "manhattan", "input_M3500_g2o", "ais2klinik", "kitti_00", "parking-garage",
         "sphere2500", "smallGrid3D", "tinyGrid3D"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--files", default=",".join(FILES))
    ap.add_argument("builds", nargs="+")
    a = ap.parse_args()
    builds = [b.split("=", 1) for b in a.builds]
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    out = os.path.join(tempfile.mkdtemp(), "o.g2o")
    print("| file | " + " | ".join(f"{label} [s]" for label, _ in builds) +
          (" | " + " / ".join(l for l, _ in builds[1:]) + " ÷ " + builds[0][0] if len(builds) > 1 else "") + " |")
    print("|---|" + "---|" * len(builds) + ("---|" if len(builds) > 1 else ""))
    for f in a.files.split(","):
        path = os.path.join(DATA, f + ".g2o")
        if not os.path.exists(path):
            print(f"skipped {f}: {path} not found", file=sys.stderr)
            continue
        times = {label: [] for label, _ in builds}
        for _ in range(a.runs):
            for label, exe in builds:
                t0 = time.perf_counter()
                subprocess.run([exe, "optimize", path, "-q", "-o", out], env=env, check=True,
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                times[label].append(time.perf_counter() - t0)
        med = [statistics.median(times[label]) for label, _ in builds]
        ratio = " / ".join(f"{m / med[0]:.2f}" for m in med[1:])
        print(f"| {f} | " + " | ".join(f"{m:.4f}" for m in med) + (f" | {ratio}" if len(builds) > 1 else "") + " |")


if __name__ == "__main__":
    main()
