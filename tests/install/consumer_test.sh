#!/usr/bin/env bash
# The installed package as others build on it:
#  1. `cmake --install BUILD --prefix SCRATCH` installs libraries, headers, binaries and
#     jamflowConfig.cmake;
#  2. examples/consumer configures with find_package(jamflow), builds and runs;
#  3. the installed jamflow binary runs; the installed Python module imports from the prefix
#     and finds the installed binary for sweeps.
# usage: consumer_test.sh BUILD_DIR SOURCE_DIR HAVE_PYTHON PYTHON_INSTALL_DIR
set -euo pipefail
build="$(realpath "$1")"
src="$(realpath "$2")"
have_python="$3"
pydir="$4"
work="$(mktemp -d /tmp/jamflow-install-test.XXXXXX)"
trap 'rm -rf "$work"' EXIT
prefix="$work/prefix"

cmake --install "$build" --prefix "$prefix" >"$work/install.log"
for f in bin/jamflow lib/cmake/jamflow/jamflowConfig.cmake lib/cmake/jamflow/jamflowTargets.cmake \
         include/jamflow/driver/run.hpp include/jamflow/lib/config.hpp; do
  [ -e "$prefix/$f" ] || { echo "FAILED: $f not installed"; exit 1; }
done
echo "ok: installed"

# No build type: no optimisation, the quickest compile (the program runs for a second).
# A sanitizer build (scripts/sanitize.sh) passes the flags its libraries need at link time.
flags="${JAMFLOW_CONSUMER_FLAGS:-}"
cmake -S "$src/examples/consumer" -B "$work/consumer" \
  -DCMAKE_PREFIX_PATH="$prefix" -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_EXE_LINKER_FLAGS="$flags" \
  >"$work/configure.log" || { cat "$work/configure.log"; exit 1; }
cmake --build "$work/consumer" -j 2 >"$work/build.log" || { cat "$work/build.log"; exit 1; }
out="$("$work/consumer/shear_ramp")"
echo "$out"
[ "$(echo "$out" | grep -c '^gdot')" = 3 ] || { echo "FAILED: consumer output"; exit 1; }
echo "ok: consumer built against the installed package and ran"

"$prefix/bin/jamflow" scene >"$work/default.toml"
grep -q '^\[system\]' "$work/default.toml" || { echo "FAILED: installed jamflow"; exit 1; }
echo "ok: installed jamflow runs"

if [ "$have_python" = ON ]; then
  cd "$work"
  # (The sanitizer build preloads the sanitizers' runtimes into the interpreter.)
  PYTHONPATH="$prefix/$pydir" JAMFLOW_EXE= LD_PRELOAD="${JAMFLOW_PYTHON_PRELOAD:-}" \
    ASAN_OPTIONS="${JAMFLOW_PYTHON_PRELOAD:+detect_leaks=0}" /usr/bin/python3 - "$prefix" <<'PY'
import os, sys
import jamflow
prefix = sys.argv[1]
assert jamflow.__file__.startswith(prefix), jamflow.__file__
open("s.toml", "w").write("""
[sweep]
[sweep.grid]
"shear.rate" = [1e-2]
[scene.system]
N = 64
phi = 0.6
[scene.ensemble]
kind = "constant_volume"
[scene.shear]
rate = 1e-2
[scene.integrator]
kind = "euler"
dt = 0.1
[scene.run]
t_eq = 0.0
t_av = 8.0
sample_every = 1.0
blocks = 4
""")
table = jamflow.sweep("s.toml", jobs=1)
assert len(table["point"]) == 1, table
print("ok: installed module", jamflow.__file__)
PY
fi
