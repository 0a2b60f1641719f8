#!/usr/bin/env bash
# `jamflow study paper` from the command line, without running the studies' points:
#  - --dry-run counts the runs that studies share once, and on a new folder none finished (hard-sphere and finite-size share the
#    N = 256 points of their quick presets), so its total is below the sum of the parts;
#  - --slurm writes one batch script that runs the whole of it and resubmits itself;
#  - --only with an unknown study, --only on another study, and an MPI launch are one line each,
#    exit 2, before anything runs.
#  - end to end on three quick studies, two of which share points and one in stages: each shared
#    point runs once, the report has a row per study with its CPU hours, Table 2's section and
#    each study's figures, every link resolves, and a --dry-run after it finds every run finished
#    and nothing left.
# usage: paper_test.sh JAMFLOW_BINARY
set -uo pipefail
jamflow="$(realpath "$1")"
work="$(mktemp -d /tmp/jamflow-paper-test.XXXXXX)"
trap 'rm -rf "$work"' EXIT
cd "$work"
passed=0
failed=0
ok() { echo "ok: $*"; passed=$((passed + 1)); }
bad() { echo "FAILED: $*"; failed=$((failed + 1)); }

runs_of() { sed -n 's/.* = \([0-9]*\) runs,.*/\1/p'; }
hs=$("$jamflow" study hard-sphere --preset quick --dry-run --out d1 | runs_of)
fs=$("$jamflow" study finite-size --preset quick --dry-run --out d2 | runs_of)
line=$("$jamflow" study paper --preset quick --dry-run --out dp --only hard-sphere,finite-size)
total=$(echo "$line" | sed -n 's/.*: \([0-9]*\) distinct runs.*/\1/p')
if [ -n "$hs" ] && [ -n "$fs" ] && [ -n "$total" ] && [ "$total" -lt $((hs + fs)) ] &&
  [ "$total" -ge "$fs" ]; then
  ok "dry-run counts shared runs once: $total distinct of $hs + $fs"
else
  bad "dry-run: hard-sphere $hs, finite-size $fs, paper '$line'"
fi
[ ! -d dp/hard-sphere/runs/points ] && ok "dry-run runs nothing" || bad "dry-run created points"
echo "$line" | grep -q "; 0 finished, about [0-9.e+-]* CPU-hours left" &&
  ok "dry-run on a new folder: nothing finished" || bad "dry-run 'finished': '$line'"

# Shortened under a sanitizer (JAMFLOW_SHORT_TESTS, scripts/sanitize.sh): the two studies that
# share points, without the one in stages.
studies=ensemble,hard-sphere,finite-size
if [ -n "${JAMFLOW_SHORT_TESTS:-}" ] && [ "${JAMFLOW_SHORT_TESTS}" != 0 ]; then
  studies=hard-sphere,finite-size
  echo "[shortened] Studies.Paper: end to end on $studies"
fi
parts=$(echo "$studies" | tr ',' '\n' | wc -l)
"$jamflow" study paper --preset quick --only "$studies" --out e2e -j 2 \
  > e2e.out 2> e2e.err
status=$?
# 1: the quick presets' tiny systems leave parts of the analysis unfitted, and the report says so.
[ "$status" -le 1 ] && ok "paper (quick, three studies) ran (exit $status)" ||
  bad "paper end to end: exit $status: $(tail -2 e2e.err)"
reused=$(grep -l "reused" e2e/finite-size/runs/points/*/r*.log 2>/dev/null | wc -l)
[ "$reused" -ge 1 ] && ok "finite-size reused $reused runs of hard-sphere" ||
  bad "no run was reused between hard-sphere and finite-size"
if [ -s e2e/report.md ] && grep -q "^| Figs. 2, 3, 4, 7: .* | hard-sphere |" e2e/report.md &&
  grep -q "^| Figs. 5, 6 and Table 2: .* | finite-size |" e2e/report.md &&
  grep -q "^## Table 2 (N -> infinity)" e2e/report.md; then
  ok "the report has a row per study and Table 2's section"
else
  bad "report.md: $(head -c 600 e2e/report.md 2>/dev/null)"
fi
# The CPU hours of each part, a study in stages (ensemble) included: the runs' own CPU seconds.
hours=$(sed -n 's/^| .* | \(ensemble\|hard-sphere\|finite-size\) | .* | \([0-9.e+-]*\) | \[.*$/\1=\2/p' e2e/report.md)
nonzero=$(echo "$hours" | awk -F= '$2 > 0' | wc -l)
[ "$nonzero" -eq "$parts" ] && ok "every part's CPU hours are counted: $(echo $hours)" ||
  bad "CPU hours per part: '$(echo $hours)'"
figs=$(sed -n 's/^!\[.*\](\(.*\.png\))$/\1/p' e2e/report.md)
missing=0
for f in $figs; do [ -s "e2e/$f" ] || missing=$((missing + 1)); done
[ -n "$figs" ] && [ "$missing" -eq 0 ] && ok "the report shows $(echo "$figs" | wc -l) figures, all present" ||
  bad "report figures: '$figs', $missing missing"
# Every link of the report resolves from its folder, those of the studies' openings (a
# comparison plan's table of cases links each case's report) included.
links=$(grep -o '](\([^)#:]*\))' e2e/report.md | sed 's/^](//; s/)$//' | sort -u)
broken=""
for f in $links; do [ -e "e2e/$f" ] || broken="$broken $f"; done
[ -n "$links" ] && [ -z "$broken" ] && ok "the report's $(echo "$links" | wc -l) links resolve" ||
  bad "report links that do not resolve:$broken"
line=$("$jamflow" study paper --preset quick --only "$studies" --dry-run --out e2e)
runs=$(echo "$line" | sed -n 's/.*: \([0-9]*\) distinct runs.*/\1/p')
echo "$line" | grep -q "; $runs finished, about 0 CPU-hours left" &&
  ok "dry-run after the run: $runs finished, nothing left" || bad "dry-run after the run: $line"

# --report-only on a comparison plan with cases: the links of its opening (its table of cases)
# are relative to its folder, and the combined report rebases them onto the study's folder.
mkdir -p rp/timestep/case-a
printf '# timestep\n\n| case |\n|---|\n| [case-a](case-a/report.md) |\n\n## More\n' \
  > rp/timestep/report.md
echo "# case-a" > rp/timestep/case-a/report.md
"$jamflow" study paper --preset quick --report-only --only timestep --out rp > rp.out 2>&1
grep -q '](timestep/case-a/report.md)' rp/report.md && [ -s rp/timestep/case-a/report.md ] &&
  ok "--report-only: a case's link in a study's opening resolves from the combined report" ||
  bad "--report-only case link: $(grep -n 'case-a' rp/report.md)"

"$jamflow" study paper --preset paper --slurm --out sl -j 8 > slurm.out 2> slurm.err
status=$?
if [ "$status" -eq 0 ] && [ -s sl/paper.sbatch ] && bash -n sl/paper.sbatch &&
  grep -q "study paper --preset 'paper'" sl/paper.sbatch &&
  grep -q "^#SBATCH --cpus-per-task=8" sl/paper.sbatch &&
  grep -q "^#SBATCH --signal=B:TERM@" sl/paper.sbatch && grep -q "scontrol requeue" sl/paper.sbatch
then
  ok "--slurm writes one batch script for the whole of it"
else
  bad "--slurm: exit $status: $(cat slurm.err)"
fi

one_line_exit_2() {  # description, command...
  local what="$1"
  shift
  "$@" > /dev/null 2> err.txt
  local status=$?
  if [ "$status" -eq 2 ] && [ "$(wc -l < err.txt)" -eq 1 ]; then ok "$what: one line, exit 2"; else
    bad "$what: exit $status: $(cat err.txt)"; fi
}
one_line_exit_2 "--only with an unknown study" \
  "$jamflow" study paper --preset quick --only hard-sphere,nonesuch --out x1
one_line_exit_2 "--only on another study" "$jamflow" study hard-sphere --preset quick --only finite-size \
  --out x2
OMPI_COMM_WORLD_SIZE=2 OMPI_COMM_WORLD_RANK=0 one_line_exit_2 "an MPI launch" \
  "$jamflow" study paper --preset quick --out x3
[ ! -e x1 ] && [ ! -e x2 ] && [ ! -e x3 ] && ok "nothing written for bad input" ||
  bad "bad input wrote $(ls -d x1 x2 x3 2>/dev/null)"

echo "paper_test: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
