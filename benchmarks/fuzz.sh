#!/usr/bin/env bash
# Fuzzes every graph reader, the CARMEN laser-log reader (with the log writer and degrader
# behind it), the TUM and relations readers, the bag record check and the map image (PGM)
# reader with the localisation map behind it, with libFuzzer under
# AddressSanitizer and UndefinedBehaviorSanitizer, and the saved LiDAR state reader (whole files,
# and payloads packed with a correct CRC so that their contents are fuzzed).
#
#   bash benchmarks/fuzz.sh [SECONDS]     (default 60 seconds per target)
#
# Seeds: the first 40 lines of every public dataset in ../shared/datasets (g2o files for fuzz_g2o,
# TORO .graph files, BR lines included, for fuzz_toro, iSAM landmark files for fuzz_isam, the first
# 40 lines of the CARMEN logs in lidar/ for fuzz_carmen), files written by `tether simulate` where that
# folder is absent, and the regression inputs in tests/fuzz/regressions (regressions/carmen for fuzz_carmen). Prints per target: executions,
# coverage (cov, ft), corpus size and findings; exits non-zero where a target found something
# (the input is left in build-fuzz/findings/TARGET/, with a minimised copy min-*; the findings of
# an earlier run are moved to build-fuzz/findings/TARGET.DATE/ first). The corpus in
# build-fuzz/corpus/ is kept from run to run (delete it to start from the seeds alone).
#
# TETHER_FUZZ_ROUNDTRIP=0 fuzzes the readers alone (no write and read back of what was read).
# TETHER_FUZZ_TARGETS="carmen g2o" runs only those targets (default: all six, one after another).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
root="$PWD"
work="$root/build-fuzz"

need=()
command -v clang++ > /dev/null || need+=(clang)
ls /usr/lib/llvm-*/lib/clang/*/lib/linux/libclang_rt.fuzzer-x86_64.a > /dev/null 2>&1 || need+=(libclang-rt-14-dev)
if [ ${#need[@]} -gt 0 ]; then
  apt-get update
  DEBIAN_FRONTEND=noninteractive apt-get install -y "${need[@]}"
fi
bash scripts/install_deps.sh > /dev/null

CC=clang CXX=clang++ cmake -S . -B "$work/build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DTETHER_BUILD_FUZZERS=ON \
  -DTETHER_BUILD_TESTS=OFF -DTETHER_BUILD_TOOLS=OFF -DTETHER_BUILD_BENCHMARKS=OFF -DBUILD_SHARED_LIBS=OFF > /dev/null
cmake --build "$work/build" -j"$(nproc)" --target fuzz_g2o fuzz_toro fuzz_isam fuzz_carmen fuzz_lidar_text fuzz_lidar_state > /dev/null

# Seed corpora.
datasets="$root/../shared/datasets"
stamp=$(date +%Y%m%d-%H%M%S)
for t in g2o toro isam carmen lidar_text lidar_state; do
  mkdir -p "$work/corpus/$t" "$work/findings/$t"
  if [ -n "$(ls -A "$work/findings/$t")" ]; then
    mkdir -p "$work/findings/$t.$stamp"
    mv "$work/findings/$t"/* "$work/findings/$t.$stamp/"
  fi
done
if [ -d "$datasets" ]; then
  while IFS= read -r f; do
    case "$f" in *.graph) t=toro ;; *.txt) t=isam ;; *) t=g2o ;; esac
    { printf '\000'; head -n 40 "$f"; } > "$work/corpus/$t/seed_$(basename "$f")"
  done < <(find "$datasets" -type f \( -name '*.g2o' -o -name '*.graph' -o -path '*/landmarks/*.txt' \))
  # CARMEN logs (plain or gzip): their first lines, and a stretch after the header.
  while IFS= read -r f; do
    # (the reader stops early: zcat's SIGPIPE is expected, not a failure)
    { printf '\000'; zcat -f "$f" | head -n 40 || true; } > "$work/corpus/carmen/seed_$(basename "$f")"
    { printf '\010'; zcat -f "$f" | grep -m 12 -E '^(ODOM|FLASER|ROBOTLASER1)' || true; } > "$work/corpus/carmen/seed_gz_$(basename "$f")"
    # Raw gzip bytes (two members, then trailing data) for the reader's own inflate to meet damaged.
    { printf '\000'; zcat -f "$f" | grep -m 6 -E '^(ODOM|FLASER|ROBOTLASER1)' | gzip -c || true
      zcat -f "$f" | grep -m 3 -E '^(ODOM|FLASER)' | gzip -c || true; printf 'junk'; } \
      > "$work/corpus/carmen/seed_rawgz_$(basename "$f")"
  done < <(find "$datasets/lidar" -type f \( -name '*.clf*' -o -name '*.log*' \) 2> /dev/null)
  # BR lines start after the poses in example.graph: seed them from the middle too.
  if [ -f "$datasets/landmarks/example.graph" ]; then
    { printf '\000'; grep -m 20 -E '^(VERTEX2|EDGE2)' "$datasets/landmarks/example.graph";
      grep -m 20 '^BR' "$datasets/landmarks/example.graph"; } > "$work/corpus/toro/seed_example_br"
  fi
else
  echo "fuzz: $datasets is absent; seeding from small written graphs only"
fi
printf '\000VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 0 500 0 0 500 0 500\n' > "$work/corpus/g2o/seed_se2"
printf '\000VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nVERTEX_XY 5 1 2\nEDGE_SE3:QUAT 0 1 1 0 0 0 0 0 1 1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 1 0 0 1 0 1\nFIX 0\n' > "$work/corpus/g2o/seed_se3"
printf '\004VERTEX_SWITCH 7 1\nEDGE_SWITCH_PRIOR 7 1 1\nEDGE_SE2_SWITCHABLE 0 1 7 1 0 0 1 0 0 1 0 1\n' > "$work/corpus/g2o/seed_switch"
printf '\000VERTEX2 0 0 0 0\nVERTEX2 1 1 0 0\nEDGE2 0 1 1 0 0 1 0 1 1 0 0\nEQUIV 0 1\n' > "$work/corpus/toro/seed_toro"
printf '\000VERTEX2 0 0 0 0\nBR 0 4 0.5 2 0.05 0.1\nBR 0 5 -2 3 0.05 0.1\n' > "$work/corpus/toro/seed_br"
printf '\000ODOMETRY 0 1 1 0 0 10 0 0 10 0 20\nLANDMARK 1 0 2 3 2 1 3\nEDGE2 1 2 1 0 0 1 0 0 1 0 1\n' > "$work/corpus/isam/seed_isam"
printf '\100ODOMETRY 0 1 1 0 0 0.0001 0 0 4e-06 0 4e-06\nLANDMARK 1 5 2 3 0.4 0.1 0.4\n' > "$work/corpus/isam/seed_isam_cov"
printf '\000PARAMS_SE3OFFSET 1 0.1 0 0.2 0 0 0.3 0.95\nVERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nEDGE_SE3_TRACKXYZ 0 7 1 1 2 3 1 0 0 1 0 1\nEDGE_SE3_PRIOR 0 1 0 0 0 0 0 0 1 1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 1 0 0 1 0 1\nEDGE_RANGE_BEARING_SE2_XY 3 4 2 0.5 1 0 1\n' > "$work/corpus/g2o/seed_landmarks"
printf '\000ODOM 0 0 0 0 0 0 9.5 h 0\nRAWLASER1 0 -1.5 1.5 0.75 40 0.01 0 3 1 2 3 2 7 8 10 h 1\nODOM 1 0 0.5 0 0 0 10.5 h 1\n' > "$work/corpus/carmen/seed_raw"
printf '\003FLASER 3 1 2 81.9 0.1 0 0 0 0 0 10 h 1\nROBOTLASER1 0 -1.5 1.5 0.75 40 0.01 0 3 1 2 3 0 1 0 0 1 0 0 0 0 0 0 0 11 h 2\n' > "$work/corpus/carmen/seed_none"
# TUM (first byte 0), relations (1), bag records (2): the public trajectories' and relations'
# first lines, a tiny bag and the head of a real one.
printf '\000# timestamp x y z qx qy qz qw\n1.5 1 2 0 0 0 0.1 0.995\n2.5 1.2 2 0 0 0 0.2 0.98\n' > "$work/corpus/lidar_text/seed_tum"
printf '\x011.5 2.5 0.2 0 0 0 0 0.1\n' > "$work/corpus/lidar_text/seed_relations"
printf '\003P5\n4 3\n255\n\000\376\376\315\376\376\376\376\000\000\376\376' > "$work/corpus/lidar_text/seed_pgm"
printf '\003P2\n# a map\n3 2\n15\n0 15 7\n15 15 0\n' > "$work/corpus/lidar_text/seed_pgm_plain"
if [ -d "$datasets/lidar" ]; then
  while IFS= read -r f; do
    { printf '\001'; head -n 30 "$f"; } > "$work/corpus/lidar_text/seed_$(basename "$f")"
  done < <(find "$datasets/lidar" -type f -name '*.relations' 2> /dev/null)
  while IFS= read -r f; do
    { printf '\002'; head -c 3000 "$f"; } > "$work/corpus/lidar_text/seed_$(basename "$f")"
  done < <(find "$datasets/lidar" -type f -name '*.bag' 2> /dev/null)
fi
for f in "$root"/tests/fuzz/regressions/carmen/*; do
  case "$f" in *.md) continue ;; esac
  [ -f "$f" ] && cp "$f" "$work/corpus/carmen/"
done
# Saved LiDAR states: the kept small states (whole files, first byte 0) and their payloads
# (first byte 1: packed with a correct CRC by the target, so that the contents are fuzzed).
for f in "$root"/tests/fuzz/regressions/lidar_state/*; do
  case "$f" in *.md) continue ;; esac
  [ -f "$f" ] && cp "$f" "$work/corpus/lidar_state/"
done
for f in "$root"/tests/fuzz/regressions/*; do
  [ -f "$f" ] || continue
  case "$f" in *toro*) cp "$f" "$work/corpus/toro/" ;; *isam*) cp "$f" "$work/corpus/isam/" ;; *) cp "$f" "$work/corpus/g2o/" ;; esac
done
cat > "$work/tags.dict" << 'DICT'
"VERTEX_SE2"
"VERTEX_SE3:QUAT"
"VERTEX_XY"
"VERTEX_TRACKXYZ"
"VERTEX_SWITCH"
"EDGE_SE2"
"EDGE_SE3:QUAT"
"EDGE_SE2_XY"
"EDGE_PRIOR_SE2"
"EDGE_SWITCH_PRIOR"
"EDGE_SE2_SWITCHABLE"
"EDGE_SE3_SWITCHABLE"
"FIX"
"VERTEX2"
"EDGE2"
"EQUIV"
"BR"
"ODOMETRY"
"LANDMARK"
"PARAMS_SE3OFFSET"
"EDGE_SE3_TRACKXYZ"
"EDGE_SE3_PRIOR"
"EDGE_RANGE_BEARING_SE2_XY"
"nan"
"inf"
"1e308"
"-0"
"18446744073709551615"
"18446744073709551616"
"1e-320"
"+"
"#"
DICT
cat > "$work/carmen.dict" << 'DICT'
"ODOM"
"FLASER"
"ROBOTLASER1"
"RAWLASER1"
"PARAM"
"SYNC"
"NMEA-GGA"
"#"
" "
"\x0a"
"\x0d\x0a"
"nan"
"inf"
"1e308"
"-1e308"
"1e-320"
"-0"
"1048576"
"1048577"
"81.9"
"0.0175"
"3.1416"
DICT

status=0
echo "round trip (write and read back): $([ "${TETHER_FUZZ_ROUNDTRIP:-1}" = 0 ] && echo off || echo on)"
printf '%-10s %8s %12s %9s %6s %6s %7s %9s\n' target seconds executions exec/s cov ft corpus findings
for t in ${TETHER_FUZZ_TARGETS:-g2o toro isam carmen lidar_text lidar_state}; do
  log="$work/fuzz_$t.log"
  dict="$work/tags.dict"
  [ "$t" = carmen ] && dict="$work/carmen.dict"
  ( cd "$work/findings/$t" && ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
      "$work/build/tests/fuzz/fuzz_$t" "$work/corpus/$t" -dict="$dict" -max_total_time="$seconds" \
      -timeout=10 -rss_limit_mb=2048 -max_len=4096 -print_final_stats=1 > "$log" 2>&1 ) || true
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo 0)
  rate=$(grep -o 'stat::average_exec_per_sec: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo 0)
  last=$(grep -E '^#[0-9]+' "$log" | tail -1)
  cov=$(echo "$last" | grep -o 'cov: [0-9]*' | grep -o '[0-9]*' || echo 0)
  ft=$(echo "$last" | grep -o 'ft: [0-9]*' | grep -o '[0-9]*' || echo 0)
  corpus=$(ls "$work/corpus/$t" | wc -l)
  found=$(ls "$work/findings/$t" | grep -cE '^(crash|leak|timeout|oom|slow-unit)-' || true)
  printf '%-10s %8s %12s %9s %6s %6s %7s %9s\n' "fuzz_$t" "$seconds" "$execs" "$rate" "$cov" "$ft" "$corpus" "$found"
  if [ "$found" -gt 0 ]; then
    status=1
    echo "fuzz_$t: findings in $work/findings/$t (log: $log):"
    grep -E 'ERROR|finding:|runtime error' "$log" | head -5
    for f in "$work/findings/$t"/*; do
      case "$(basename "$f")" in crash-* | leak-* | timeout-* | oom-*) ;; *) continue ;; esac
      ( cd "$work/findings/$t" && "$work/build/tests/fuzz/fuzz_$t" -minimize_crash=1 -max_total_time=60 -timeout=10 \
          -rss_limit_mb=2048 -exact_artifact_path="$work/findings/$t/min-$(basename "$f")" "$f" \
          > "$work/findings/$t/min-$(basename "$f").log" 2>&1 ) || true
      echo "  $(basename "$f") minimised: $work/findings/$t/min-$(basename "$f")"
    done
  fi
done
exit "$status"
