#!/usr/bin/env bash
# Standard presets that take longer than one sitting (hard-sphere: about 6 CPU-hours). While
# such a sweep runs, its folder (point scenes, checkpoints, journal) is kept in the repository
# under studies/<study>/results/standard-running/, so that it continues on any machine from
# where it stopped; a finished preset's results go to studies/<study>/results/standard/ as
# usual, and the running folder is removed.
#
#   bash scripts/standard-runs.sh start STUDY...  copy the kept folder (if any) to
#                                                  out/running/STUDY and start `jamflow study
#                                                  STUDY --preset standard` there in the
#                                                  background (nice 10, -j 2; a copy of
#                                                  build/jamflow, so rebuilding does not touch it)
#   bash scripts/standard-runs.sh start STUDY... --reuse DIR   the same, passing the options
#                                                  after the studies to `jamflow study` (here:
#                                                  copy in the finished runs of the same scenes
#                                                  from DIR, e.g. out/running/hard-sphere for
#                                                  finite-size's N = 1000 points)
#   bash scripts/standard-runs.sh save STUDY...   stop it (SIGTERM: every run checkpoints) and
#                                                  copy its folder back, without lock files
#   bash scripts/standard-runs.sh status          each running study's last progress line
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cmd="${1:-}"
[ $# -gt 0 ] && shift
work="$root/out/running"
mkdir -p "$work"

kept() { echo "$root/studies/$1/results/standard-running"; }

study_pid() {  # the study process of STUDY started here, if it runs
  pgrep -f "jamflow-$1 study $1 --preset standard --out $work/$1( |$)" || true
}

case "$cmd" in
  start)
    [ $# -gt 0 ] || { echo "usage: $0 start STUDY... [--reuse DIR]" >&2; exit 2; }
    studies=()
    while [ $# -gt 0 ] && [ "${1#--}" = "$1" ]; do
      studies+=("$1")
      shift
    done
    extra=()  # options for `jamflow study`; a --reuse folder made absolute (the study runs elsewhere)
    while [ $# -gt 0 ]; do
      if [ "$1" = "--reuse" ] && [ $# -gt 1 ]; then
        extra+=("$1" "$(realpath -m "$2")")
        shift 2
      else
        extra+=("$1")
        shift
      fi
    done
    for s in "${studies[@]}"; do
      [ -d "$root/studies/$s" ] || { echo "standard-runs: no study '$s' in studies/" >&2; exit 2; }
      if [ -n "$(study_pid "$s")" ]; then
        echo "standard-runs: $s runs already (pid $(study_pid "$s"))"
        continue
      fi
      if [ -d "$(kept "$s")" ]; then
        # A run left in out/running (a sweep that went on after the last save, or finished) has
        # progress the kept folder lacks: keep it, and say how to fold it in.
        kj="$(kept "$s")/runs/journal.log" wj="$work/$s/runs/journal.log"
        if [ -f "$wj" ] && [ "$(wc -l <"$wj")" -gt "$(wc -l <"$kj" 2>/dev/null || echo 0)" ]; then
          echo "standard-runs: $work/$s has progress the kept folder lacks; run '$0 save $s' first" >&2
          exit 1
        fi
        rm -rf "${work:?}/$s"
        cp -r "$(kept "$s")" "$work/$s"
        rm -f "$work/$s/README.md"
      fi
      cp "$root/build/jamflow" "$work/jamflow-$s"
      (cd "$work" && nohup nice -n 10 "$work/jamflow-$s" study "$s" --preset standard \
        --out "$work/$s" -j 2 "${extra[@]}" >>"$work/$s.log" 2>&1 &)
      echo "standard-runs: $s started in $work/$s (log $work/$s.log)"
    done
    ;;
  save)
    [ $# -gt 0 ] || { echo "usage: $0 save STUDY..." >&2; exit 2; }
    for s in "$@"; do
      pid="$(study_pid "$s")"
      if [ -n "$pid" ]; then
        kill -TERM $pid
        for _ in $(seq 120); do
          [ -z "$(study_pid "$s")" ] && break
          sleep 1
        done
        [ -z "$(study_pid "$s")" ] || { echo "standard-runs: $s did not stop in 120 s" >&2; exit 1; }
      fi
      [ -d "$work/$s" ] || { echo "standard-runs: nothing to save for $s ($work/$s)" >&2; exit 1; }
      dest="$(kept "$s")"
      rm -rf "$dest"
      mkdir -p "$(dirname "$dest")"
      cp -r "$work/$s" "$dest"
      find "$dest" -name '*.lock' -delete
      cat >"$dest/README.md" <<EOF
# $s, standard preset: a sweep still running

The folder of \`jamflow study $s --preset standard\` as it stood when it was saved
($(date -u +%Y-%m-%dT%H:%M:%SZ)): the point scenes, the finished runs, the checkpoints
(\`*.h5.part\`) of the unfinished ones and the journal. \`bash scripts/standard-runs.sh start $s\`
continues it from there. Nothing in it is a result until the preset finishes.

$(tail -1 "$work/$s.log" 2>/dev/null | tr '\r' '\n' | tail -1)
EOF
      echo "standard-runs: $s saved to ${dest#"$root"/}"
    done
    ;;
  status)
    for log in "$work"/*.log; do
      [ -e "$log" ] || continue
      s="$(basename "$log" .log)"
      state="stopped"
      [ -n "$(study_pid "$s")" ] && state="running"
      echo "$s ($state): $(tail -1 "$log" | tr '\r' '\n' | tail -1)"
    done
    ;;
  *)
    echo "usage: $0 {start|save|status} [STUDY...]" >&2
    exit 2
    ;;
esac
