#!/usr/bin/env bash
# The sweep engine from the command line, as a user runs it:
#  1. a 6-point sweep locally with -j 2 and under mpirun -n 3 gives the same bits in every
#     point file (wall times and creation dates aside); two different points do differ;
#  2. --collect writes one row per point, and `jamflow analyze` reads the table as it is;
#  3. a sweep interrupted with SIGINT (exit 130) and rerun completes with the same bits as an
#     uninterrupted one, resumes the interrupted point and does not recompute finished points;
#  4. a bad value in one point is one line naming the point and the key, exit 2, before any run;
#  5. --reuse copies finished replicas of the very same scene from another sweep, not rerun.
# usage: sweep_test.sh JAMFLOW_BINARY      (exit 77: skipped)
set -uo pipefail
jamflow="$(realpath "$1")"
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
py=/usr/bin/python3
compare="$py $here/compare_runs.py"
work="$(mktemp -d /tmp/jamflow-sweep-test.XXXXXX)"
trap '[ -n "${SWEEP_TEST_KEEP:-}" ] || rm -rf "$work"' EXIT
cd "$work"
passed=0
failed=0
ok() { echo "ok: $*"; passed=$((passed + 1)); }
bad() { echo "FAILED: $*"; failed=$((failed + 1)); }

cat > six.toml <<'TOML'
[sweep]
replicas = 1
[sweep.grid]
"shear.rate" = [1e-1, 3e-2, 1e-2]
[sweep.zip]
"system.phi" = [0.6, 0.66]
"integrator.dt" = [0.1, 0.08]
[scene.system]
N = 64
phi = 0.62
[scene.ensemble]
kind = "constant_volume"
[scene.shear]
rate = 1e-2
[scene.integrator]
kind = "euler"
dt = 0.1
[scene.run]
t_eq = 10.0
t_av = 40.0
sample_every = 0.4
TOML

# 1. Local -j 2, then the same sweep under MPI into the same folder name.
if "$jamflow" sweep six.toml -j 2 -q; then ok "local sweep of 6 points"; else bad "local sweep"; fi
files=(six.sweep/points/*/r0.h5)
[ "${#files[@]}" -eq 6 ] && ok "6 point files" || bad "expected 6 point files, found ${#files[@]}"
locks=$(find six.sweep -name '*.lock' | wc -l)
[ "$locks" -eq 0 ] && ok "no lock files after the sweep" || bad "$locks lock files left after the sweep"
mv six.sweep six.local
if command -v mpirun >/dev/null && "$jamflow" --help | grep -q mpirun; then
  export OMPI_MCA_rmaps_base_oversubscribe=1
  # Under a sanitizer build: Open MPI 4.1 leaves what MPI_Init allocates (hwloc, its dlopen'ed
  # components; about 120 kB in 3,360 blocks per rank) to the process's end, so LeakSanitizer
  # is off for the ranks. The same sweep ran leak-checked above, without MPI.
  mpi_env=()
  [ -n "${ASAN_OPTIONS:-}" ] && mpi_env=(-x "ASAN_OPTIONS=${ASAN_OPTIONS}:detect_leaks=0")
  if mpirun --allow-run-as-root --oversubscribe "${mpi_env[@]}" -n 3 "$jamflow" sweep six.toml -q; then
    ok "mpirun -n 3 sweep"
  else
    bad "mpirun -n 3 sweep"
  fi
  pairs=()
  for f in six.local/points/*/r0.h5; do pairs+=("$f" "six.sweep/${f#six.local/}"); done
  if $compare "${pairs[@]}"; then ok "MPI point files are bitwise the local ones"; else
    bad "MPI and local point files differ"; fi
  rm -rf six.sweep
else
  echo "skip: no mpirun, or jamflow built without MPI"
fi
# The comparison can fail: two different points differ.
if $compare six.local/points/rate-0.1_dt-0.1_phi-0.6/r0.h5 six.local/points/rate-0.03_dt-0.1_phi-0.6/r0.h5 >/dev/null; then
  bad "compare_runs.py finds no difference between two different points"
else
  ok "compare_runs.py tells different points apart"
fi

# 2. Collect, and analyze reads the table: an error about the table's form names the file and
# its header, a column or a line; tiny runs may still fail the collapse itself, which is not
# what is tested here.
mv six.local six.sweep
if "$jamflow" sweep six.toml --collect table.csv > collect.out; then ok "--collect"; else bad "--collect"; fi
rows=$(($(wc -l < table.csv) - 1))
[ "$rows" -eq 6 ] && ok "6 rows collected" || bad "expected 6 rows, found $rows"
head -1 table.csv | grep -q "^point,integrator.dt,system.phi,ensemble,N,shear_rate,phi,phi_err" &&
  ok "table header" || bad "table header: $(head -1 table.csv)"
# The cost columns: CPU seconds recorded by every run (not wall seconds standing in), and the
# force-pass equivalents (Euler: its force evaluations).
if $py -c 'import csv, math
rows = list(csv.DictReader(open("table.csv")))
assert rows
for r in rows:
    cpu = float(r["cpu_seconds"])
    assert math.isfinite(cpu) and cpu > 0, r
    assert r["cpu_from_wall"] == "0", r
    assert float(r["force_pass_equivalents"]) == float(r["force_evaluations"]) > 0, r'; then
  ok "table cost columns: cpu_seconds, force_pass_equivalents"
else
  bad "table cost columns: $(head -2 table.csv)"
fi
if "$jamflow" sweep six.toml --collect table.h5 > /dev/null &&
  $py -c 'import csv, sys, h5py, numpy as np
rows = list(csv.DictReader(open("table.csv")))
t = h5py.File("table.h5")["table"]
assert list(t.attrs["columns"]) == list(rows[0].keys()) == list(t)
assert np.array_equal(t["phi"][:], [float(r["phi"]) for r in rows])
assert list(t["point"].asstr()[()]) == [r["point"] for r in rows]'; then
  ok "--collect table.h5 holds the CSV table"
else
  bad "--collect table.h5"
fi
"$jamflow" analyze olsson-teitel table.csv --size 64 -o ot.json --no-plots > analyze.out 2> analyze.err
status=$?
# (tiny runs are mostly not decorrelated, and then left out with a note: that is a reading.)
if [ "$status" -eq 0 ] || ! grep -qE "table.csv(:[0-9]+)?: (header|column|expected|empty|no data)" analyze.err; then
  ok "analyze olsson-teitel reads the table (exit $status: $(head -c 120 analyze.err))"
else
  bad "analyze refused the collected table: $(cat analyze.err)"
fi

# 3. Interrupt and rerun. Points of decreasing length; -j 1 runs them longest first.
cat > three.toml <<'TOML'
[sweep]
[sweep.zip]
"system.N" = [400, 200, 50]
[scene.system]
N = 64
phi = 0.62
[scene.ensemble]
kind = "constant_volume"
[scene.shear]
rate = 1e-2
[scene.integrator]
kind = "euler"
dt = 0.1
[scene.run]
t_eq = 100.0
t_av = 1000.0
sample_every = 1.0
[scene.output]
checkpoint_every = 0.2
TOML
"$jamflow" sweep three.toml --out ref -j 2 -q || bad "reference sweep"
"$jamflow" sweep three.toml --out run -j 1 -q &
pid=$!
for _ in $(seq 600); do
  [ -f run/points/N-400/r0.h5 ] && [ -f run/points/N-200/r0.h5.part ] && break
  sleep 0.05
done
kill -INT "$pid"
wait "$pid"
status=$?
[ "$status" -eq 130 ] && ok "SIGINT: exit 130" || bad "SIGINT: exit $status, expected 130"
if [ -f run/points/N-400/r0.h5 ] && [ -f run/points/N-200/r0.h5.part ] && [ ! -f run/points/N-200/r0.h5 ]; then
  ok "interrupted with one point finished and one checkpointed"
  stamp=$(stat -c %Y.%i run/points/N-400/r0.h5)
  "$jamflow" sweep three.toml --out run -j 1 2> rerun.err
  status=$?
  [ "$status" -eq 0 ] && ok "rerun completes" || bad "rerun: exit $status"
  grep -q "from before" rerun.err && ok "rerun reports the finished point" || bad "rerun: $(cat rerun.err)"
  [ "$(stat -c %Y.%i run/points/N-400/r0.h5)" = "$stamp" ] && ok "finished point not recomputed" ||
    bad "finished point was rewritten"
  resumes=$($py -c 'import h5py,sys; print(int(h5py.File(sys.argv[1])["/"].attrs["resumes"]))' run/points/N-200/r0.h5)
  [ "$resumes" -ge 1 ] && ok "interrupted point resumed ($resumes)" || bad "interrupted point not resumed"
  left=$(find run -name '*.lock' -o -name '*.last.xyz' | wc -l)
  [ "$left" -eq 0 ] && ok "no lock or .last.xyz files after the resumed sweep" ||
    bad "left after the resumed sweep: $(find run -name '*.lock' -o -name '*.last.xyz')"
  pairs=()
  for n in N-400 N-200 N-50; do pairs+=("ref/points/$n/r0.h5" "run/points/$n/r0.h5"); done
  if $compare --ignore resumes "${pairs[@]}"; then ok "interrupted sweep gives the same bits"; else
    bad "interrupted sweep differs from the uninterrupted one"; fi
else
  bad "the interruption did not fall between two points (machine too slow?): $(ls run/points/*/)"
fi

# 4. Bad input in one point: one line, exit 2, nothing run.
cat > badpoint.toml <<'TOML'
[sweep]
scene = "base.toml"
[sweep.grid]
"system.phi" = [0.6, 1.5]
TOML
"$jamflow" scene > base.toml
"$jamflow" sweep badpoint.toml 2> bad.err
status=$?
[ "$status" -eq 2 ] && ok "bad point: exit 2" || bad "bad point: exit $status"
[ "$(wc -l < bad.err)" -eq 1 ] && grep -q "sweep point phi-1.5: .*phi" bad.err &&
  ok "bad point: one line naming the point and the key" || bad "bad point message: $(cat bad.err)"
[ ! -d badpoint.sweep ] && ok "bad point: nothing created" || bad "bad point: output folder created"

# 5. --reuse: a second sweep sharing two of six.sweep's points copies them (the same bits, a
#    log that says so) and runs only its new point.
cat > overlap.toml <<'TOML'
[sweep]
replicas = 1
[sweep.grid]
"shear.rate" = [1e-1, 3e-2, 3e-3]
[sweep.zip]
"system.phi" = [0.6]
"integrator.dt" = [0.1]
[scene.system]
N = 64
phi = 0.62
[scene.ensemble]
kind = "constant_volume"
[scene.shear]
rate = 1e-2
[scene.integrator]
kind = "euler"
dt = 0.1
[scene.run]
t_eq = 10.0
t_av = 40.0
sample_every = 0.4
TOML
if "$jamflow" sweep overlap.toml --reuse six.sweep -j 1 -q 2> overlap.err; then
  ok "sweep with --reuse"
else
  bad "sweep with --reuse: $(cat overlap.err)"
fi
reused=$(grep -l "^reused: " overlap.sweep/points/*/r0.log 2>/dev/null | wc -l)
[ "$reused" -eq 2 ] && ok "--reuse copied the 2 shared points" || bad "--reuse copied $reused points"
same=0
for f in overlap.sweep/points/*/r0.h5; do
  other="six.sweep/points/$(basename "$(dirname "$f")")/r0.h5"
  [ -f "$other" ] && cmp -s "$f" "$other" && same=$((same + 1))
done
[ "$same" -eq 2 ] && ok "--reuse: the shared points are the same bytes" ||
  bad "--reuse: $same of 2 shared points identical"
new_run=$(ls -d overlap.sweep/points/*rate-0.003*/r0.h5 2>/dev/null | wc -l)
[ "$new_run" -eq 1 ] && ! grep -q "^reused: " overlap.sweep/points/*rate-0.003*/r0.log &&
  ok "--reuse: the new point ran" || bad "--reuse: the new point did not run"

echo "sweep_test: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
