#!/usr/bin/env bash
# `mpirun -np K tether optimize ... --linear petsc` as a user runs it: the result is written once,
# by the first process, and equals the single-process solve; a bad input (on every process, or
# on one only) or a bad PETSc option ends the whole job with a clear message, no hang, and the
# old output untouched.
#   cli_test.sh TETHER MPIEXEC DATASETS_DIR
set -uo pipefail
tether=$1
mpiexec=$2
datasets=$3
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
failures=0
fail() {
  echo "FAIL: $*"
  failures=$((failures + 1))
}
# The run's output, and its exit code in $rc; a job that hangs is killed after 120 s.
run() {
  timeout 120 "$@" >"$work/stdout" 2>"$work/stderr"
  rc=$?
}

"$tether" simulate manhattan --poses 400 --seed 7 -o "$work/world.g2o" -q || fail "simulate"

# 1. Two processes write the result once, at the single-process optimum, and print one summary.
run "$tether" optimize "$work/world.g2o" -o "$work/one.g2o" --linear cholmod
[ "$rc" = 0 ] || fail "single-process solve exited $rc: $(cat "$work/stderr")"
one_chi2=$(grep "final chi2" "$work/stdout" | awk '{print $3}')
one_iterations=$(grep "^  iterations" "$work/stdout" | awk '{print $2}')
run "$mpiexec" -np 2 --oversubscribe "$tether" optimize "$work/world.g2o" -o "$work/two.g2o" --linear petsc
[ "$rc" = 0 ] || fail "two processes exited $rc: $(cat "$work/stderr")"
[ -s "$work/two.g2o" ] || fail "two processes wrote no result"
[ "$(grep -c "final chi2" "$work/stdout")" = 1 ] || fail "the summary is printed $(grep -c "final chi2" "$work/stdout") times, not once"
two_chi2=$(grep "final chi2" "$work/stdout" | awk '{print $3}')
two_iterations=$(grep "^  iterations" "$work/stdout" | awk '{print $2}')
awk -v a="$one_chi2" -v b="$two_chi2" 'BEGIN { d = a - b; if (d < 0) d = -d; exit !(d <= 1e-9 * a) }' ||
  fail "final chi2 $two_chi2 on two processes, $one_chi2 in one"
[ "$one_iterations" = "$two_iterations" ] || fail "iterations $two_iterations on two processes, $one_iterations in one"
grep -q "mumps) on 2 processes" "$work/stdout" || fail "the summary does not name MUMPS on 2 processes"
[ "$(wc -l <"$work/one.g2o")" = "$(wc -l <"$work/two.g2o")" ] || fail "the two results differ in length"

# 2. PETSc's options pass through: an iterative solve on request.
run "$mpiexec" -np 2 --oversubscribe "$tether" optimize "$work/world.g2o" --linear petsc \
  --petsc-options "-ksp_type cg -pc_type bjacobi -ksp_rtol 1e-12" -q
[ "$rc" = 0 ] || fail "--petsc-options cg + bjacobi exited $rc: $(cat "$work/stderr")"
grep -q "PETSc cg + bjacobi" "$work/stdout" || fail "--petsc-options did not reach PETSc: $(grep petsc "$work/stdout")"

# 3. A bad input on every process: the file and line named, exit 1, the old output untouched.
printf 'VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 nan 1 0 0 1 0 1\n' >"$work/bad.g2o"
echo "old result" >"$work/out.g2o"
run "$mpiexec" -np 2 --oversubscribe "$tether" optimize "$work/bad.g2o" -o "$work/out.g2o" --linear petsc
[ "$rc" = 1 ] || fail "a bad input on every process exited $rc, not 1"
grep -q "bad.g2o:3" "$work/stderr" || fail "the error does not name bad.g2o:3: $(cat "$work/stderr")"
[ "$(cat "$work/out.g2o")" = "old result" ] || fail "the old output was changed"

# 4. A bad input on the second process only (MPMD): the job ends, that process names it.
run "$mpiexec" --oversubscribe -np 1 "$tether" optimize "$work/world.g2o" -o "$work/out.g2o" --linear petsc : \
  -np 1 "$tether" optimize "$work/bad.g2o" -o "$work/out.g2o" --linear petsc
[ "$rc" != 0 ] || fail "a bad input on one process exited 0"
grep -q "\[process 1\] .*bad.g2o:3" "$work/stderr" || fail "process 1 does not name bad.g2o:3: $(cat "$work/stderr")"
[ "$(cat "$work/out.g2o")" = "old result" ] || fail "the old output was changed by a job that failed"

# 5. A PETSc option PETSc refuses: a clear error, no hang, nothing written.
run "$mpiexec" -np 2 --oversubscribe "$tether" optimize "$work/world.g2o" -o "$work/out.g2o" --linear petsc \
  --petsc-options "-ksp_type no_such_method"
[ "$rc" != 0 ] || fail "an unknown KSP type exited 0"
grep -q "no_such_method" "$work/stderr" || fail "the error does not name the option's value: $(cat "$work/stderr")"
[ "$(cat "$work/out.g2o")" = "old result" ] || fail "the old output was changed by a refused option"

# 6. Covariances and GNC's rejected closures: computed and written once, by the first process;
#    the others write nothing anywhere (run in a folder of its own to see it).
mkdir -p "$work/cwd"
(cd "$work/cwd" && run "$mpiexec" -np 2 --oversubscribe "$tether" optimize "$work/world.g2o" --linear petsc \
  --covariance 5 --gnc -o "$work/cov.g2o" -q && echo "$rc" >"$work/rc")
[ "$(cat "$work/rc")" = 0 ] || fail "covariance + gnc on two processes exited $(cat "$work/rc"): $(cat "$work/stderr")"
[ -s "$work/cov.g2o.cov" ] || fail "the covariances were not written"
[ -f "$work/cov.g2o.rejected.g2o" ] || fail "GNC's rejected closures (none here) were not written"
[ -z "$(ls -A "$work/cwd")" ] || fail "a process wrote into the working folder: $(ls -A "$work/cwd")"

# 7. Several processes with a solver of one process: refused (each would solve alone and
#    write the same outputs), naming the way out.
run "$mpiexec" -np 2 --oversubscribe "$tether" optimize "$work/world.g2o" -o "$work/out.g2o" --linear cholmod
[ "$rc" = 2 ] || fail "two processes with --linear cholmod exited $rc, not 2"
grep -q "add --linear petsc" "$work/stderr" || fail "the refusal does not say what to do: $(cat "$work/stderr")"
[ "$(cat "$work/out.g2o")" = "old result" ] || fail "the old output was changed by a refused run"

# 8. A public file on three processes (skipped where the datasets are absent).
if [ -f "$datasets/g2o/intel.g2o" ]; then
  run "$mpiexec" -np 3 --oversubscribe "$tether" optimize "$datasets/g2o/intel.g2o" --linear petsc -q
  [ "$rc" = 0 ] || fail "intel on three processes exited $rc: $(cat "$work/stderr")"
  grep -q "final chi2 *45.004695" "$work/stdout" || fail "intel on three processes: $(grep 'final chi2' "$work/stdout")"
else
  echo "intel.g2o absent ($datasets/g2o): its three-process run skipped"
fi

if [ "$failures" -gt 0 ]; then
  echo "$failures check(s) failed"
  exit 1
fi
echo "every distributed command-line check passed"
