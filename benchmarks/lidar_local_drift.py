#!/usr/bin/env python3
"""Local SLAM's drift, measured against an optimised run of the same log (benchmarks/RESULTS.md).

    python3 benchmarks/lidar_local_drift.py LOCAL.tum OPTIMISED.tum NAME

LOCAL.tum: `tether lidar LOG --no-loop-closure` (local SLAM's chain); OPTIMISED.tum: `tether
lidar LOG` (the defaults). From every 25th scan, the motion to the first scan at least L metres
further along (L = 20, 50, 100, 150) is compared between the two: the translation error per
metre driven and the rotation error (rad). Prints the median, 95th percentile and largest of
each. These bound how far apart two views of the map may place a trajectory that is not yet
joined (ConstraintBuilderOptions::join_drift, join_drift_angle).
"""
import math
import sys


def load(path):
    poses = {}
    with open(path) as f:
        for line in f:
            if line.startswith("#") or not line.strip():
                continue
            v = line.split()
            poses[round(float(v[0]), 4)] = (float(v[1]), float(v[2]), 2 * math.atan2(float(v[6]), float(v[7])))
    return poses


def wrap(a):
    return math.atan2(math.sin(a), math.cos(a))


def relative(a, b):
    dx, dy = b[0] - a[0], b[1] - a[1]
    c, s = math.cos(a[2]), math.sin(a[2])
    return (c * dx + s * dy, -s * dx + c * dy, wrap(b[2] - a[2]))


def main():
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    local, optimised = load(sys.argv[1]), load(sys.argv[2])
    stamps = sorted(t for t in local if t in optimised)
    if len(stamps) < 2:
        sys.exit("%s and %s share fewer than two stamps" % (sys.argv[1], sys.argv[2]))
    p = [local[t] for t in stamps]
    q = [optimised[t] for t in stamps]
    driven = [0.0]
    for i in range(1, len(p)):
        driven.append(driven[-1] + math.hypot(p[i][0] - p[i - 1][0], p[i][1] - p[i - 1][1]))
    for length in (20, 50, 100, 150):
        rates, angles = [], []
        j = 0
        for i in range(0, len(p), 25):
            while j < len(p) and driven[j] - driven[i] < length:
                j += 1
            if j >= len(p):
                break
            a, b = relative(p[i], p[j]), relative(q[i], q[j])
            rates.append(math.hypot(a[0] - b[0], a[1] - b[1]) / length)
            angles.append(abs(wrap(a[2] - b[2])))
        if not rates:
            continue
        rates.sort()
        angles.sort()

        def at(v, f):
            return v[min(len(v) - 1, int(f * len(v)))]

        print("%s L=%d m, %d stretches: drift median %.3f p95 %.3f max %.3f m/m | rotation median %.3f p95 %.3f "
              "max %.3f rad" % (sys.argv[3], length, len(rates), at(rates, 0.5), at(rates, 0.95), rates[-1],
                                at(angles, 0.5), at(angles, 0.95), angles[-1]))


if __name__ == "__main__":
    main()
