#!/usr/bin/env bash
# Regenerates the committed quick-preset numbers (tests/studies/data/quick/<study>/) that
# SweepStudies.QuickPresetsEndToEnd compares its runs with, exactly (tests/studies/quick_numbers.py).
# Run it only for a change meant to move the numbers, and say in the commit which change and why.
# The runs use the portable force kernel, as the test does: the same bits on every x86-64 machine.
#   bash scripts/quick-reference.sh [BUILD_DIR]      (default: build)
#   STUDIES="timestep ensemble" bash scripts/quick-reference.sh   only these studies
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
jamflow="$(realpath "${1:-$root/build}")/jamflow"
[ -x "$jamflow" ] || { echo "quick-reference: no $jamflow (build first)" >&2; exit 2; }
work="$(mktemp -d "${TMPDIR:-/tmp}/jamflow-quick-reference.XXXXXX")"
trap 'rm -rf "$work"' EXIT
export JAMFLOW_KERNEL=portable
declare -A files=(
  [hard-sphere]="table.csv analysis.json"
  [finite-size]="table.csv analysis.json"
  [soft-rheology]="constant-pressure/table.csv constant-volume/table.csv analysis.json"
  [olsson-teitel]="table.csv analysis.json"
)
want() { [ -z "${STUDIES:-}" ] || [[ " $STUDIES " == *" $1 "* ]]; }
for study in hard-sphere finite-size soft-rheology olsson-teitel; do
  want "$study" || continue
  echo "quick-reference: $study"
  "$jamflow" study "$study" --preset quick --out "$work/$study" -j 2 --no-plots \
    > "$work/$study.log" 2>&1 || true  # exit 1: a part could not be fitted (tiny systems)
  ref="$root/tests/studies/data/quick/$study"
  rm -rf "$ref"
  for f in ${files[$study]}; do
    [ -s "$work/$study/$f" ] || { echo "quick-reference: $study wrote no $f" >&2; exit 1; }
    mkdir -p "$(dirname "$ref/$f")"
    /usr/bin/python3 "$root/tests/studies/quick_numbers.py" --store "$work/$study/$f" "$ref/$f"
  done
done
# The studies in stages, each a comparison plan: their HDF5 files, as digests of their numbers
# (quick_numbers.py): compare.h5, one per case (CASE/compare.h5) for a plan with cases, and the
# study's own numbers in STUDY.h5.
for study in timestep stability softness ensemble; do
  want "$study" || continue
  echo "quick-reference: $study"
  "$jamflow" study "$study" --preset quick --out "$work/$study" -j 2 --no-plots \
    > "$work/$study.log" 2>&1 || { echo "quick-reference: $study failed" >&2; exit 1; }
  ref="$root/tests/studies/data/quick/$study"
  rm -rf "$ref"
  outs=$(cd "$work/$study" && find . \( -name compare.h5 -o -name "$study.h5" \) -not -path "*/runs/*" | sed 's|^\./||' | sort)
  for f in $outs; do
    mkdir -p "$(dirname "$ref/$f")"
    /usr/bin/python3 "$root/tests/studies/quick_numbers.py" --digest "$work/$study/$f" \
      "$ref/$f.digest.json"
  done
done
echo "quick-reference: written under tests/studies/data/quick/"
