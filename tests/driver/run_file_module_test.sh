#!/usr/bin/env bash
# The run-file module is the only code that opens run files: outside driver/checkpoint.cpp,
# driver/run_file.cpp and driver/run_summary.cpp, no source file opens an HDF5 file for reading
# (H5Fopen, or an H5Reader) other than the HDF5 wrapper itself (lib/h5.cpp) and the H5MD
# trajectory writer (lib/h5md.cpp, which reopens its own trajectory to continue it). Tests are
# exempt: they inspect files on purpose. Fails naming each file and line.
# usage: run_file_module_test.sh SOURCE_DIR
set -euo pipefail
root="$1"
cd "$root"
allowed='^(driver/checkpoint\.cpp|driver/run_file\.cpp|driver/run_summary\.cpp|lib/h5\.cpp|lib/h5\.hpp|lib/h5md\.cpp):'
dirs=(lib ensembles integrators driver sweep analysis framework studies apps python fuzz benchmarks)
# H5Fopen anywhere; an H5Reader constructed (a variable, a temporary, emplace into an optional).
pattern='H5Fopen|H5Reader[[:space:]]+[A-Za-z_][A-Za-z0-9_]*[[:space:]]*[({]|H5Reader[({]|optional<[^>]*H5Reader'
hits=$(grep -rnE --include='*.cpp' --include='*.hpp' "$pattern" "${dirs[@]}" | grep -vE "$allowed" || true)
# The pattern must find the module's own readers, or it finds nothing anywhere.
grep -qE "$pattern" driver/checkpoint.cpp || { echo "pattern finds no reader in driver/checkpoint.cpp"; exit 1; }
grep -qE "$pattern" driver/run_summary.cpp || { echo "pattern finds no reader in driver/run_summary.cpp"; exit 1; }
if [ -n "$hits" ]; then
  echo "run files opened outside the run-file module (driver/checkpoint.cpp, run_file.cpp, run_summary.cpp):"
  echo "$hits"
  exit 1
fi
echo "only the run-file module opens run files"
