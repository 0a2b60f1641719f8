#!/usr/bin/env bash
# `pip install .` as a user runs it: into a virtual environment of Debian's python3 that sees the
# system's packages (numpy, setuptools, wheel), with no build isolation and no network. The
# module imports from the environment, the `jamflow` command is in its bin/, the module's sweeps
# run that binary, and its analyses find their plot scripts in the environment's share/jamflow.
# To keep the test cheap, setup.py reuses this build folder (JAMFLOW_CMAKE_BUILD_DIR) instead of
# configuring and compiling jamflow again, and installs it as ctest found it
# (JAMFLOW_CMAKE_INSTALL_AS_BUILT): a build step there would relink build/jamflow, which other
# tests run at the same time, whenever the commit changed since the build (the binary names its
# commit). The source is a copy, so that pip's in-tree build writes nothing into the checkout.
# usage: pip_install_test.sh SOURCE_DIR BUILD_DIR
set -euo pipefail
src="$(realpath "$1")"
build="$(realpath "$2")"
work="$(mktemp -d /tmp/jamflow-pip-test.XXXXXX)"
trap 'rm -rf "$work"' EXIT

mkdir "$work/src"
tar -C "$src" --exclude='./build*' --exclude='./.git' -cf - . | tar -C "$work/src" -xf -
/usr/bin/python3 -m venv --system-site-packages "$work/venv"
( cd "$work/src" && JAMFLOW_CMAKE_BUILD_DIR="$build" JAMFLOW_CMAKE_INSTALL_AS_BUILT=1 \
    "$work/venv/bin/pip" install --no-build-isolation --no-index . > "$work/pip.log" 2>&1 ) ||
  { tail -40 "$work/pip.log"; echo "FAILED: pip install"; exit 1; }
echo "ok: pip install . into a venv"

"$work/venv/bin/jamflow" --version | grep -q '^jamflow ' || { echo "FAILED: venv/bin/jamflow"; exit 1; }
[ -f "$work/venv/share/jamflow/analysis/plots/hard_sphere.py" ] ||
  { echo "FAILED: no plot scripts in venv/share/jamflow"; exit 1; }
echo "ok: the jamflow command and the plot scripts are in the venv"

cd "$work"
env -u PYTHONPATH -u JAMFLOW_EXE "$work/venv/bin/python" - "$work" <<'PY'
import os, sys
import numpy as np
import jamflow
work = sys.argv[1]
venv = os.path.join(work, "venv")
assert jamflow.__file__.startswith(venv), jamflow.__file__
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
rows = ["N,imposed_pressure,shear_rate,phi,phi_err,mu,mu_err"]
for p in (1e-4, 1e-5):
    for j in np.logspace(-5, -1, 9):
        phi, mu = 0.645 - 0.4 * j**0.38, 0.1 + 1.1 * j**0.36
        rows.append(f"1000,{p!r},{j * p!r},{phi!r},{1e-4!r},{mu!r},{1e-3!r}")
open("granular.csv", "w").write("\n".join(rows) + "\n")
jamflow.analyze("hard-sphere", "granular.csv", "hs.json", plots=True)
pngs = [f for f in os.listdir(".") if f.startswith("hs") and f.endswith(".png")]
assert pngs, os.listdir(".")
print("ok: the installed module runs sweeps with venv/bin/jamflow and plots from venv/share")
PY
