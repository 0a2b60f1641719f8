#!/usr/bin/env bash
# libFuzzer targets (fuzz/), built with clang apart from the main GCC build:
#   bash scripts/fuzz.sh TARGET SECONDS     TARGET: scene, xyz, csv, hdf5
#   bash scripts/fuzz.sh all SECONDS        each target in turn, SECONDS each
#   bash scripts/fuzz.sh build              only build them
# Findings (crash-*, leak-*, timeout-*, oom-*) land in fuzz/findings/TARGET/; replay one with
#   build-fuzz/fuzz_TARGET fuzz/findings/TARGET/crash-...
# New inputs go to build-fuzz/corpus/TARGET/ (the committed seeds in fuzz/corpus/ stay as they
# are). Runs at nice 19.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$here"
targets=(scene xyz csv hdf5)
target="${1:-}"
seconds="${2:-60}"
case "$target" in scene|xyz|csv|hdf5|all|build) ;; *)
  echo "usage: bash scripts/fuzz.sh {scene|xyz|csv|hdf5|all|build} [SECONDS]" >&2; exit 2;;
esac
command -v clang++ >/dev/null || { echo "fuzz.sh: clang++ not found (apt-get install clang)" >&2; exit 2; }
build_dir="${JAMFLOW_FUZZ_BUILD_DIR:-build-fuzz}"
# The targets write each input to a scratch file: keep it in memory when possible.
[ -z "${TMPDIR:-}" ] && [ -d /dev/shm ] && export TMPDIR=/dev/shm

nice -n 5 cmake -S fuzz -B "$build_dir" -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ >/dev/null
if [ "$target" = all ] || [ "$target" = build ]; then
  nice -n 5 cmake --build "$build_dir" -j "$(nproc)" --target "${targets[@]/#/fuzz_}"
else
  nice -n 5 cmake --build "$build_dir" -j "$(nproc)" --target "fuzz_$target"
fi
[ "$target" = build ] && exit 0

run_one() {
  local t="$1"
  local corpus="$build_dir/corpus/$t" findings="fuzz/findings/$t"
  mkdir -p "$corpus" "$findings"
  local dict=()
  [ -f "fuzz/$t.dict" ] && dict=("-dict=fuzz/$t.dict")
  echo "fuzz.sh: $t for ${seconds}s" >&2
  # -rss_limit_mb: an input that makes the reader allocate gigabytes is a finding (oom-*).
  # -timeout: one input taking more than 10 s is a finding (timeout-*).
  # -fork=1 with -ignore_*: a finding is saved and fuzzing goes on for the whole time (set
  # FUZZ_FORK=0 to stop at the first one).
  local fork=(-fork=1 -ignore_crashes=1 -ignore_ooms=1 -ignore_timeouts=1)
  [ "${FUZZ_FORK:-1}" = 0 ] && fork=()
  # allocator_may_return_null: a request of exabytes (libhdf5 on a corrupt size field) fails as
  # in a normal build; in jamflow code the std::bad_alloc still escapes and is a finding.
  ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:allocator_may_return_null=1}" \
  LSAN_OPTIONS="${LSAN_OPTIONS:-suppressions=$here/fuzz/lsan.supp:print_suppressions=0}" \
  UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}" \
    nice -n 19 "$build_dir/fuzz_$t" "$corpus" "fuzz/corpus/$t" "${dict[@]}" \
      -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -max_len=65536 "${fork[@]}" \
      -artifact_prefix="$findings/" -print_final_stats=1 || status=$?
  # Each fuzzing process has its scratch input file; a crashed one leaves it behind. (A target
  # running alongside simply writes its file again.)
  rm -f "${TMPDIR:-/tmp}"/jamflow-fuzz-*
  return "${status:-0}"
}

if [ "$target" = all ]; then
  for t in "${targets[@]}"; do run_one "$t"; done
else
  run_one "$target"
fi
