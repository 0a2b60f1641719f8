#!/usr/bin/env bash
# The whole test suite under AddressSanitizer and UndefinedBehaviorSanitizer: a separate build
# (RelWithDebInfo, -DJAMFLOW_SANITIZE=ON) in build-sanitize/, then every ctest test. Heavy tests
# run shorter there, not excluded (tests/short_tests.hpp: JAMFLOW_SHORT_TESTS). Any sanitizer
# report fails its test (UBSan does not recover, ASan aborts). Prints the figures: tests run,
# shortened, failed, and the wall and CPU time of the test run.
# usage: scripts/sanitize.sh [-j JOBS] [ctest arguments...]   (e.g. -R Sweep to run some)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${JAMFLOW_SANITIZE_BUILD:-$root/build-sanitize}"
jobs=2
if [ "${1:-}" = "-j" ]; then
  jobs="$2"
  shift 2
fi
mkdir -p "$build"
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DJAMFLOW_SANITIZE=ON \
  "${launcher[@]}" >"$build/sanitize-configure.log" 2>&1 || { cat "$build/sanitize-configure.log"; exit 1; }
# GCC 12's std::regex gives -Wmaybe-uninitialized false positives in its own headers under
# -fsanitize=address; they are not ours, and the Release build is warning-free.
cmake --build "$build" -j "$jobs" >"$build/sanitize-build.log" 2>&1 || { tail -50 "$build/sanitize-build.log"; exit 1; }

export JAMFLOW_SHORT_TESTS=1
# As in `scripts/setup.sh test`: OpenMP threads that wait by sleeping. Spinning threads on a
# loaded two-core machine made a threaded force test 37 times slower (47 s against 1.3 s).
export OMP_WAIT_POLICY="${OMP_WAIT_POLICY:-passive}"
# Leaks are reported (the default on Linux); a report ends the process with a failure.
export ASAN_OPTIONS="${ASAN_OPTIONS:-abort_on_error=1:detect_leaks=1:strict_string_checks=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
log="$build/sanitize-ctest.log"
start=$(date +%s.%N)
# CPU time of the children this shell has waited for (fields cutime and cstime), before and
# after: the difference is ctest's and every test's under it.
ticks=$(getconf CLK_TCK)
children_cpu() { awk -v t="$ticks" '{print ($16 + $17) / t}' "/proc/$$/stat"; }
cpu0=$(children_cpu)
set +e
ctest --test-dir "$build" -j "$jobs" --output-on-failure "$@" >"$log" 2>&1
status=$?
set -e
wall=$(echo "$(date +%s.%N) - $start" | bc)
cpu=$(echo "$(children_cpu) - $cpu0" | bc)
run=$(sed -n 's/.*tests passed, [0-9]* tests failed out of \([0-9]*\).*/\1/p' "$log" | tail -1)
failed=$(sed -n 's/.*tests passed, \([0-9]*\) tests failed out of.*/\1/p' "$log" | tail -1)
[ -z "$failed" ] && failed=0
# Tests that said they ran shorter ("[shortened] NAME", tests/short_tests.hpp), counted once.
# (grep finds none when no test ran shorter: not a failure of the script.)
shortened=$({ grep -ho '\[shortened\] [A-Za-z0-9_.]*' "$build/Testing/Temporary/LastTest.log" \
  2>/dev/null || true; } | sort -u | wc -l)
tail -25 "$log"
printf 'sanitize: %s tests run, %s shortened, %s failed; wall %.0f s, CPU %.0f s\n' \
  "${run:-0}" "$shortened" "$failed" "$wall" "$cpu"
exit "$status"
