#!/usr/bin/env bash
# The installed package as others build on it:
#  1. `cmake --install BUILD --prefix SCRATCH` installs libraries, headers, binaries and
#     jamflowConfig.cmake;
#  2. examples/consumer configures with find_package(jamflow), builds and runs;
#  3. the installed jamflow binary runs; the installed Python module imports from the prefix
#     and finds the installed binary for sweeps;
#  4. the installed tree is relocatable: moved elsewhere, its jamflow runs the plot scripts of
#     its own share/jamflow (a marker appended to the moved copy shows which copy ran), and so
#     does its Python module.
# examples/consumer's project enables CXX alone (find_package(jamflow) must not need C).
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
         include/jamflow/driver/run.hpp include/jamflow/lib/config.hpp \
         share/jamflow/analysis/plots/hard_sphere.py share/jamflow/analysis/plots/common.py \
         share/jamflow/studies/hard-sphere/plot.py; do
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
grep -q "project(jamflow_consumer LANGUAGES CXX)" "$src/examples/consumer/CMakeLists.txt" ||
  { echo "FAILED: the consumer's project is not CXX-only"; exit 1; }
echo "ok: consumer (a CXX-only project) built against the installed package and ran"

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

# 4. Relocated: the tree moved away from where it was installed (the old prefix is gone).
moved="$work/moved/tree"
mkdir -p "$work/moved"
mv "$prefix" "$moved"
marker="$work/moved-script-ran"
printf '\nopen(%s, "w").write("ran")\n' "'$marker'" >> "$moved/share/jamflow/analysis/plots/hard_sphere.py"
# Pure hard-sphere data at two pressures (phi = phi_J - C J^b, mu = mu_J + C J^b), as the
# Python tests make it.
/usr/bin/python3 - "$work/granular.csv" <<'PY'
import sys
import numpy as np
rows = ["N,imposed_pressure,shear_rate,phi,phi_err,mu,mu_err"]
for p in (1e-4, 1e-5):
    for j in np.logspace(-5, -1, 9):
        phi, mu = 0.645 - 0.4 * j**0.38, 0.1 + 1.1 * j**0.36
        rows.append(f"1000,{p!r},{j * p!r},{phi!r},{1e-4!r},{mu!r},{1e-3!r}")
open(sys.argv[1], "w").write("\n".join(rows) + "\n")
PY
mkdir -p "$work/plots"
( cd "$work/plots" && "$moved/bin/jamflow" analyze hard-sphere "$work/granular.csv" -o hs.json \
    > analyze.out 2> analyze.err ) || { cat "$work/plots/analyze.err"; exit 1; }
grep -q "plots failed\|plots skipped" "$work/plots/analyze.err" &&
  { echo "FAILED: $(cat "$work/plots/analyze.err")"; exit 1; }
[ -f "$marker" ] || { echo "FAILED: the moved tree's plot script did not run"; exit 1; }
ls "$work/plots"/*.png > /dev/null 2>&1 || { echo "FAILED: no plots: $(ls "$work/plots")"; exit 1; }
echo "ok: the moved tree's jamflow analyze ran its own plot scripts"

if [ "$have_python" = ON ]; then
  rm -f "$marker"
  PYTHONPATH="$moved/$pydir" JAMFLOW_EXE= LD_PRELOAD="${JAMFLOW_PYTHON_PRELOAD:-}" \
    ASAN_OPTIONS="${JAMFLOW_PYTHON_PRELOAD:+detect_leaks=0}" /usr/bin/python3 - "$work" <<'PY'
import os, sys
import jamflow
work = sys.argv[1]
os.chdir(os.path.join(work, "plots"))
jamflow.analyze("hard-sphere", os.path.join(work, "granular.csv"), "py.json", plots=True)
assert os.path.exists(os.path.join(work, "moved-script-ran")), "the module ran another plot script"
print("ok: the moved tree's Python module ran its own plot scripts")
PY
fi
