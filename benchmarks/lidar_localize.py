#!/usr/bin/env python3
"""Localisation in a saved map (`tether localize`) on the benchmark logs.

    python3 benchmarks/lidar_localize.py TETHER OUT [LOG...]     (default logs: intel aces fr079)

Per log, `tether lidar --save-state` maps the whole log (the reference: its trajectory.tum) and
its first half (the map to localise in); fr079 without odometry (--odometry none: with it, the
mapping run folds the corridor at the door at 309 s, 3.7 m off, and that run is the reference;
benchmarks/mcl_logs.sh does the same). Localisation reads every log with its odometry. Then:
- starts: 20 start scans drawn with a fixed seed across the logs (7 intel, 7 aces, 6 fr079 with
  all three), each localising STARTS_SECONDS (default 60) seconds of log from an unknown start in
  the whole-log map (every start is then in the mapped area, and the reference is the run that
  made the map). Per start: the seconds of log to the first fix, the fix's error against the
  whole-log mapping run's pose at that scan (a false fix: more than 1 m or 5 degrees), the mean
  error of every localised pose after it;
- memory: intel's second half replayed 1 and 5 times in a row (--repeat), the largest resident
  set of each (GNU time);
- whole: each whole log localised in its half map: scans localised, mean error, real-time factor
  (slow where the log leaves the half map for long: every 5th scan is then searched globally,
  about 4 s a search on aces' map).
Needs ../shared/datasets (or TETHER_DATASETS_DIR). Extra `tether localize` options: $LOCALIZE_ARGS.
"""
import bisect
import csv
import math
import os
import random
import re
import subprocess
import sys


def run(cmd, **kw):
    return subprocess.run(cmd, check=True, capture_output=True, text=True, **kw).stdout


def read_tum(path):
    poses = []
    with open(path) as f:
        for line in f:
            if line.startswith("#") or not line.strip():
                continue
            v = [float(x) for x in line.split()]
            poses.append((v[0], v[1], v[2], 2 * math.atan2(v[6], v[7])))
    return poses


def scan_count(log):
    out = subprocess.run(f"zcat -f {log} | grep -cE '^(FLASER|ROBOTLASER1|RAWLASER1)'", shell=True,
                         capture_output=True, text=True).stdout
    return int(out.strip())


def nearest(ref, stamps, t):
    i = bisect.bisect_left(stamps, t)
    best = None
    for j in (i - 1, i):
        if 0 <= j < len(ref) and (best is None or abs(ref[j][0] - t) < abs(ref[best][0] - t)):
            best = j
    return ref[best] if best is not None and abs(ref[best][0] - t) < 1e-3 else None


def errors(rows, ref, stamps):
    """Per localised row: (stamp, position error, heading error in degrees) against the reference."""
    out = []
    for r in rows:
        if r["localized"] != "1":
            continue
        t = float(r["stamp"])
        p = nearest(ref, stamps, t)
        if p is None:
            continue
        d = math.hypot(float(r["x"]) - p[1], float(r["y"]) - p[2])
        a = abs(math.remainder(float(r["theta"]) - p[3], 2 * math.pi)) * 180 / math.pi
        out.append((t, d, a))
    return out


def localize(tether, log, state, out, extra, *args):
    cmd = [tether, "localize", log, "--state", state, "-o", out, "-q"] + list(args) + extra
    text = run(cmd)
    with open(os.path.join(out, "localization.csv")) as f:
        rows = list(csv.DictReader(f))
    return text, rows


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    tether, outdir = sys.argv[1], sys.argv[2]
    logs = sys.argv[3:] or ["intel", "aces", "fr079"]
    data = os.environ.get("TETHER_DATASETS_DIR", os.path.join(os.path.dirname(__file__), "../../shared/datasets"))
    extra = os.environ.get("LOCALIZE_ARGS", "").split()
    seconds = float(os.environ.get("STARTS_SECONDS", "60"))
    os.makedirs(outdir, exist_ok=True)
    info = {}
    for name in logs:
        log = os.path.join(data, "lidar/raw", name + ".clf.gz")
        n = scan_count(log)
        full, half = os.path.join(outdir, "map-" + name), os.path.join(outdir, "half-" + name)
        mapping = ["--odometry", "none"] if name == "fr079" else []
        if not os.path.exists(os.path.join(full, "state.tether")):
            run([tether, "lidar", log, "-o", full, "-q", "--save-state"] + mapping)
        if not os.path.exists(os.path.join(half, "state.tether")):
            run([tether, "lidar", log, "-o", half, "-q", "--save-state", "--max-scans", str(n // 2)] + mapping)
        ref = read_tum(os.path.join(full, "trajectory.tum"))
        info[name] = (log, n, ref, [p[0] for p in ref], os.path.join(half, "state.tether"),
                      os.path.join(full, "state.tether"))

    # 20 starts across the logs, in the whole-log maps.
    share = {"intel": 7, "aces": 7, "fr079": 6}
    rng = random.Random(34)
    print(f"starts: {seconds:.0f} s of log each from an unknown start, in the whole-log map")
    print("| log | start scan | first fix [s of log] | fix error [m, deg] | mean error after it [m] | localised |")
    print("|---|---|---|---|---|---|")
    fixed_in_10 = total = false_fixes = 0
    means = []
    for name in logs:
        log, n, ref, stamps, _, state = info[name]
        rate = len(ref) / (ref[-1][0] - ref[0][0])
        for _ in range(share.get(name, 7) if len(logs) == 3 else 20 // len(logs)):
            start = rng.randrange(0, n - int(seconds * rate) - 1)
            _, rows = localize(tether, log, state, os.path.join(outdir, "start"), extra, "--start-scan", str(start),
                               "--max-scans", str(int(seconds * rate)))
            total += 1
            t0 = float(rows[0]["stamp"])
            fix = next((r for r in rows if r["fix"] == "1"), None)
            e = errors(rows, ref, stamps)
            if fix is None:
                print(f"| {name} | {start} | no fix | - | - | 0 |")
                continue
            t_fix = float(fix["stamp"]) - t0
            fe = next((x for x in e if x[0] == float(fix["stamp"])), None)
            false_fix = fe is not None and (fe[1] > 1 or fe[2] > 5)
            false_fixes += false_fix
            fixed_in_10 += t_fix <= 10 and not false_fix
            mean = sum(x[1] for x in e) / len(e) if e else float("nan")
            means.append(mean)
            loc = sum(r["localized"] == "1" for r in rows)
            fes = f"{fe[1]:.3f}, {fe[2]:.2f}" if fe else "-"
            print(f"| {name} | {start} | {t_fix:.1f} | {fes} | {mean:.4f} | {loc} of {len(rows)} |")
    print(f"\nfirst fix within 10 s of log: {fixed_in_10} of {total}; false fixes: {false_fixes}; "
          f"mean error over the starts: {sum(means) / max(len(means), 1):.4f} m\n")

    if "intel" in info:
        log, n, ref, stamps, state, _ = info["intel"]
        print("\nmemory, intel's second half replayed (largest resident set):")
        for repeat in (1, 5):
            t = subprocess.run(["/usr/bin/time", "-v", tether, "localize", log, "--state", state, "-o",
                                os.path.join(outdir, "memory"), "-q", "--start-scan", str(n // 2), "--repeat",
                                str(repeat)] + extra, capture_output=True, text=True, check=True)
            rss = re.search(r"Maximum resident set size \(kbytes\): (\d+)", t.stderr)
            print(f"  --repeat {repeat}: {int(rss.group(1)) / 1024:.0f} MB")

    print("whole logs in their half maps:")
    print("| log | scans localised | first fix [s] | mean error [m] | max error [m] | real time once localised |")
    print("|---|---|---|---|---|---|")
    for name in logs:
        log, n, ref, stamps, state, _ = info[name]
        text, rows = localize(tether, log, state, os.path.join(outdir, "whole-" + name), extra)
        e = errors(rows, ref, stamps)
        loc = sum(r["localized"] == "1" for r in rows)
        fix = next((r for r in rows if r["fix"] == "1"), None)
        t_fix = float(fix["stamp"]) - float(rows[0]["stamp"]) if fix else float("nan")
        rt = re.search(r"once localised ([0-9.]+)x", text)
        mean = sum(x[1] for x in e) / len(e) if e else float("nan")
        worst = max((x[1] for x in e), default=float("nan"))
        print(f"| {name} | {loc} of {len(rows)} ({100 * loc / len(rows):.1f}%) | {t_fix:.1f} | {mean:.4f} | "
              f"{worst:.3f} | {rt.group(1) if rt else '-'}x |")


if __name__ == "__main__":
    main()
