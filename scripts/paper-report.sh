#!/usr/bin/env bash
# The combined report of a preset's committed results (studies/paper/results/PRESET/report.md):
# every study's studies/<study>/results/PRESET/ is copied into a scratch folder, `jamflow study
# paper --report-only` rebuilds there what can be rebuilt from the tables (nothing is run), and
# its report.md is written with its links pointed at each study's committed folder. The studies'
# own committed results are not touched.
# usage: scripts/paper-report.sh [PRESET]   (default standard; needs build/jamflow)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
preset="${1:-standard}"
exe="$root/build/jamflow"
[ -x "$exe" ] || { echo "paper-report: $exe is missing; build first (scripts/setup.sh build)" >&2; exit 2; }
scratch="$(mktemp -d "${TMPDIR:-/tmp}/jamflow-paper-report.XXXXXX")"
trap 'rm -rf "$scratch"' EXIT
studies=(timestep ensemble softness stability hard-sphere finite-size soft-rheology olsson-teitel)
for s in "${studies[@]}"; do
  src="$root/studies/$s/results/$preset"
  [ -d "$src" ] && cp -r "$src" "$scratch/$s"
done
set +e
"$exe" study paper --preset "$preset" --report-only --no-plots --quiet --out "$scratch" >"$scratch/log" 2>&1
status=$?
set -e
# Exit 1: some study has parts not computed, which the report says; anything else is a failure.
if [ "$status" -gt 1 ]; then
  cat "$scratch/log" >&2
  exit "$status"
fi
dest="$root/studies/paper/results/$preset"
mkdir -p "$dest"
# Links into OUT/<study>/ become links into studies/<study>/results/PRESET/.
sed_args=()
for s in "${studies[@]}"; do
  sed_args+=(-e "s#](${s}/#](../../../${s}/results/${preset}/#g")
done
sed "${sed_args[@]}" "$scratch/report.md" >"$dest/report.md.part"
mv "$dest/report.md.part" "$dest/report.md"
echo "paper-report: $dest/report.md (study paper exit $status)"
