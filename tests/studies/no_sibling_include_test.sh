#!/usr/bin/env bash
# No study includes another: a study's folder (studies/<name>/) includes only its own headers
# and the shared parts beside the folders (studies/*.hpp: the sweep side, the point grids, the
# granular report, tables, staged runs). `study paper` composes the others and is exempt. Fails
# naming each file and include.
# usage: no_sibling_include_test.sh SOURCE_DIR
set -euo pipefail
cd "$1/studies"
hits=""
found=0
for f in */*.cpp */*.hpp; do
  own="${f%%/*}"
  [ "$own" = paper ] && continue
  while IFS= read -r line; do
    found=1
    inc="$(sed -E 's|.*"studies/([^"]+)".*|\1|' <<<"$line")"
    case "$inc" in
      */*) [ "${inc%%/*}" = "$own" ] || hits+="studies/$f includes studies/$inc"$'\n' ;;
    esac
  done < <(grep -E '^#include "studies/' "$f" || true)
done
# The scan must see includes at all, or it checks nothing.
[ "$found" = 1 ] || { echo "no study includes found: the scan checks nothing"; exit 1; }
if [ -n "$hits" ]; then
  echo "studies that include another study (move what they share beside the folders):"
  printf '%s' "$hits"
  exit 1
fi
echo "no study includes another"
