#!/usr/bin/env bash
# One entry point for a fresh Debian machine:
#   bash scripts/setup.sh run    install what is missing, build (Release), run the default scene
#   bash scripts/setup.sh test   install what is missing, build, run the test suite (ctest)
# Extra arguments after `run` are passed to `jamflow run`.
set -euo pipefail
mode="${1:-}"
[ $# -gt 0 ] && shift
case "$mode" in run|test|install|build) ;; *)
  echo "usage: bash scripts/setup.sh {run|test|install|build} [jamflow run args...]" >&2; exit 2;;
esac
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$here"

packages=(build-essential cmake pkg-config libeigen3-dev libsundials-dev libgsl-dev libhdf5-dev
          libgtest-dev libtomlplusplus-dev libcli11-dev libhwy-dev libopenmpi-dev openmpi-bin
          python3-matplotlib python3-h5py python3-numpy python3-dev pybind11-dev python3-pytest
          python3-ase python3-mdanalysis python3-tqdm python3-venv python3-pip python3-setuptools
          python3-wheel python3-sphinx python3-myst-parser furo chromium)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}" >&2
  sudo_cmd=""
  [ "$(id -u)" -ne 0 ] && sudo_cmd="sudo"
  $sudo_cmd apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
[ "$mode" = install ] && exit 0

jobs="$(nproc)"
build_dir="${JAMFLOW_BUILD_DIR:-build}"
cmake -S . -B "$build_dir" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build_dir" -j "$jobs"
case "$mode" in
  run) mkdir -p out && exec "$build_dir/jamflow" run -o out/default.h5 "$@" ;;
  # ctest runs $jobs test processes at once, and some tests use 2-3 threads each: with libgomp's
  # spinning waits they would starve each other (docs/guide/running.md, "Threads").
  test) cd "$build_dir" && OMP_WAIT_POLICY="${OMP_WAIT_POLICY:-passive}" \
          exec ctest --output-on-failure -j "$jobs" ;;
esac
