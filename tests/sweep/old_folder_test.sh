#!/usr/bin/env bash
# A sweep folder written before floats were printed in their shortest form (data/old-sweep,
# README there) resumes with the current binary: its point keeps its name and its scene.toml is
# accepted, the finished replica is not rerun, the stopped one resumes from its checkpoint
# (the digest computed from its longer scene text still matches), no lock or .last.xyz file is
# left, and --reuse finds its replicas although their r<k>.toml print floats the old way.
# usage: old_folder_test.sh JAMFLOW DATA_DIR
set -u
jamflow="$(realpath "$1")"
data="$(realpath "$2")"
py=/usr/bin/python3
work="$(mktemp -d /tmp/jamflow-old-sweep.XXXXXX)"
trap 'rm -rf "$work"' EXIT
cp -a "$data/." "$work/"
cd "$work" || exit 1
passed=0
failed=0
ok() { echo "ok: $*"; passed=$((passed + 1)); }
bad() { echo "FAILED: $*"; failed=$((failed + 1)); }

pt=old.sweep/points/rate-0.003
grep -q '^dt = 0.10000000000000001$' "$pt/scene.toml" && ok "the folder prints floats the old way" ||
  bad "fixture: $(cat "$pt/scene.toml")"
"$jamflow" sweep old.toml -j 1 -q 2> rerun.err
status=$?
[ "$status" -eq 0 ] && ok "the old folder's sweep completes" || bad "rerun: exit $status: $(cat rerun.err)"
cmp -s "$pt/r0.h5" "$data/$pt/r0.h5" && ok "finished replica not rerun" || bad "r0.h5 was rewritten"
[ -f "$pt/r1.h5" ] && [ ! -e "$pt/r1.h5.part" ] && ok "stopped replica finished" ||
  bad "r1: $(ls "$pt")"
resumes=$($py -c 'import h5py,sys; f=h5py.File(sys.argv[1]); print(int(f["/"].attrs["resumes"]), f["/"].attrs["status"])' "$pt/r1.h5" 2>&1)
[ "$resumes" = "1 complete" ] && ok "stopped replica resumed from its checkpoint" ||
  bad "r1 resumes/status: $resumes"
left=$(find old.sweep -name '*.lock' -o -name '*.last.xyz' -o -name '*.part' | wc -l)
[ "$left" -eq 0 ] && ok "no lock, .last.xyz or .part files left" ||
  bad "left: $(find old.sweep -name '*.lock' -o -name '*.last.xyz' -o -name '*.part')"
scene=$($py -c 'import h5py,sys; print(h5py.File(sys.argv[1])["/"].attrs["scene"])' "$pt/r1.h5")
echo "$scene" | grep -q '^dt = 0.1$' && ok "the resumed file's scene prints dt = 0.1" ||
  bad "resumed scene: $scene"

# A new folder of the same sweep reuses both replicas of the old one.
"$jamflow" sweep old.toml --out again --reuse old.sweep -j 1 -q 2> reuse.err
status=$?
reused=$(grep -l "^reused: " again/points/rate-0.003/r*.log 2>/dev/null | wc -l)
[ "$status" -eq 0 ] && [ "$reused" -eq 2 ] && ok "--reuse finds both old replicas" ||
  bad "--reuse: exit $status, $reused reused: $(cat reuse.err)"

echo "old_folder_test: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
