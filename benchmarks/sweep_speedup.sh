#!/usr/bin/env bash
# The sweep engine's speed-up and overhead: a 2 x 2 sweep of small points (N = 2000, Euler,
# about 10 s each) with `jamflow sweep -j 2`, against the same four points run one after another
# with `jamflow run`, and against `jamflow sweep -j 1` (the engine's own overhead: its wall time
# over the sum of the runs' own wall times). The cases take turns, ROUNDS times.
#
# usage: bash benchmarks/sweep_speedup.sh [BUILD_DIR] [ROUNDS]
set -euo pipefail
build="${1:-build}"
rounds="${2:-3}"
jamflow="$(realpath "$build/jamflow")"
[ -x "$jamflow" ] || { echo "sweep_speedup: no $jamflow (build first)" >&2; exit 2; }
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
cd "$work"
cat > bench.toml <<'TOML'
[sweep]
[sweep.grid]
"shear.rate" = [1e-3, 3e-4]
"system.phi" = [0.6, 0.62]
[scene.system]
N = 2000
phi = 0.6
[scene.ensemble]
kind = "constant_volume"
[scene.shear]
rate = 1e-3
[scene.integrator]
kind = "euler"
dt = 0.1
[scene.run]
t_eq = 100.0
t_av = 19900.0
sample_every = 100.0
TOML
now() { date +%s.%N; }
sum_walls() {  # total of the runs' own wall_seconds in a sweep folder
  /usr/bin/python3 -c 'import glob, sys, h5py
print(sum(float(h5py.File(f)["summary"].attrs["wall_seconds"]) for f in glob.glob(sys.argv[1] + "/points/*/r0.h5")))' "$1"
}
printf "%-6s %10s %10s %10s %16s %18s\n" round "serial" "sweep -j1" "sweep -j2" \
  "serial / -j2" "-j1 over its runs"
for r in $(seq "$rounds"); do
  rm -rf s1 s2 serial && mkdir serial
  t0=$(now)
  "$jamflow" sweep bench.toml --out s1 -j 1 -q
  t1=$(now)
  # The same four scenes (each point's scene.toml), one after another.
  for scene in s1/points/*/scene.toml; do
    "$jamflow" run "$scene" -q --threads 1 -o "serial/$(basename "$(dirname "$scene")").h5" &> /dev/null
  done
  t2=$(now)
  "$jamflow" sweep bench.toml --out s2 -j 2 -q
  t3=$(now)
  runs=$(sum_walls s1)
  /usr/bin/python3 -c 'import sys
r, t0, t1, t2, t3, runs = sys.argv[1:]
t0, t1, t2, t3, runs = map(float, (t0, t1, t2, t3, runs))
j1, serial, j2 = t1 - t0, t2 - t1, t3 - t2
print("%-6s %9.2fs %9.2fs %9.2fs %15.2fx %17.2f%%" % (r, serial, j1, j2, serial / j2, 100 * (j1 - runs) / runs))' \
    "$r" "$t0" "$t1" "$t2" "$t3" "$runs"
done
