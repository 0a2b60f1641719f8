#!/usr/bin/env bash
# Two runs side by side on a shared machine: the total wall time of two simultaneous
# `jamflow run`s (N = 4000, phi = 0.64, Euler dt = 0.1, 15000 steps) with the default thread
# count, against the same two runs on one thread each, and with explicit thread counts and
# OpenMP wait policies for comparison. Each case is run ROUNDS times, the cases taking turns.
#
# usage: bash benchmarks/side_by_side.sh [BUILD_DIR] [ROUNDS]
set -euo pipefail
build="${1:-build}"
rounds="${2:-3}"
jamflow="$build/jamflow"
[ -x "$jamflow" ] || { echo "side_by_side: no $jamflow (build first)" >&2; exit 2; }
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
cat > "$work/scene.toml" <<'TOML'
[system]
N = 4000
phi = 0.64
[ensemble]
kind = "constant_volume"
[shear]
rate = 1e-4
[integrator]
kind = "euler"
dt = 0.1
[run]
t_eq = 0
t_av = 1500
sample_every = 10
blocks = 10
TOML

# One case: two runs at once with the given extra arguments and environment; prints seconds.
pair() {
  local env_args="$1"
  shift
  local t0 t1
  t0=$(date +%s.%N)
  env $env_args timeout 300 "$jamflow" run "$work/scene.toml" -o "$work/a.h5" "$@" \
    >/dev/null 2>&1 &
  local a=$!
  env $env_args timeout 300 "$jamflow" run "$work/scene.toml" -o "$work/b.h5" "$@" \
    >/dev/null 2>&1 &
  local b=$!
  wait $a || true
  wait $b || true
  t1=$(date +%s.%N)
  echo "$t1 - $t0" | bc -l
}

cases=("default||" "1 thread each||--threads 1"
       "2 threads each (libgomp's waits)||--threads 2"
       "2 threads each (OMP_WAIT_POLICY=active)|OMP_WAIT_POLICY=active|--threads 2"
       "2 threads each (OMP_WAIT_POLICY=passive)|OMP_WAIT_POLICY=passive|--threads 2")
declare -A total
for ((r = 1; r <= rounds; ++r)); do
  for c in "${cases[@]}"; do
    IFS='|' read -r name env_args extra <<<"$c"
    # shellcheck disable=SC2086
    s=$(pair "${env_args:-JAMFLOW_SIDE_BY_SIDE=1}" $extra)
    printf "round %d  %-42s %8.2f s\n" "$r" "$name" "$s"
    total[$name]="${total[$name]:-} $s"
  done
done
median() { tr ' ' '\n' | grep -v '^$' | sort -g | awk '{v[NR]=$1} END {print (NR%2) ? v[(NR+1)/2] : (v[NR/2]+v[NR/2+1])/2}'; }
base=$(echo "${total[1 thread each]}" | median)
echo "median over $rounds rounds (two runs at once, total wall time):"
for c in "${cases[@]}"; do
  IFS='|' read -r name _ _ <<<"$c"
  m=$(echo "${total[$name]}" | median)
  printf "  %-42s %8.2f s  %5.2f x the one-thread pair\n" "$name" "$m" "$(echo "$m / $base" | bc -l)"
done
