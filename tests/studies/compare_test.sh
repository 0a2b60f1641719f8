#!/usr/bin/env bash
# `jamflow compare` end to end on a small scene (N = 64, harmonic, constant volume, gdot = 1e-2):
# three integrator settings (Euler dt = 0.05 as the reference, Euler dt = 0.2, RKC), Euler at
# dt = 1 (twice the step at which Euler first oscillates, SPEC §4) and the reference's integrator
# at constant pressure, 3 replicas each from 3 prepared states.
#  - bad compare files: one line on stderr naming the key, exit 2, nothing written;
#  - the table has a row per setting; the unstable setting is flagged and not recommended;
#    the ranking follows the paired errors; report, HDF5 and plots are written;
#  - --dry-run counts the stages; a SIGTERM stops the sweep, and the same command again does
#    not redo the runs that had finished.
#  - the examples examples/compare_rkc_euler.toml, compare_ensembles.toml and
#    compare_two_pressures.toml are valid compare files (their dry runs).
#  - start = "mean_phi": a constant-volume setting runs at one packing fraction, the mean of its
#    preparations' window-mean phi over the steady ones; from = "np": a setting continues from
#    another's replica k in a third stage, at that setting's mean phi; integrator.atol_overlaps
#    sets atol in units of the typical overlap; bad start and from values
#    and mean_phi at constant pressure are one-line errors.
#  - [[case]]: the same settings at two state points run together, each case a report of its
#    own (the second a subset of the settings, its own preparation step and run budget), one
#    joint table with a case column; with
#    diagnose = true every run is classified by its diagnostic window; bad case keys are
#    one-line errors.
#  - on the sweep engine's other runners: --slurm writes the next stage's job array, and under
#    mpirun -n 2 the comparison gives the local one's numbers.
# usage: compare_test.sh JAMFLOW_BINARY SOURCE_DIR
set -uo pipefail
jamflow="$(realpath "$1")"
source_dir="$(realpath "$2")"
work="$(mktemp -d /tmp/jamflow-compare-test.XXXXXX)"
trap 'rm -rf "$work"' EXIT
cd "$work"
passed=0
failed=0
ok() { echo "ok: $*"; passed=$((passed + 1)); }
bad() { echo "FAILED: $*"; failed=$((failed + 1)); }

# $1: file name, $2: t_av of the settings.
write_compare() {
  cat >"$1" <<TOML
reference = "euler-0.05"
replicas = 3
observables = ["sigma_xy", "pressure"]

[base.system]
N = 64
phi = 0.60
seed = 1
[base.ensemble]
kind = "constant_volume"
[base.shear]
rate = 1e-2
[base.integrator]
kind = "euler"
dt = 0.05
[base.run]
t_eq = 0.0
t_av = 100.0
sample_every = 1.0

[prepare]
t = 200.0

[run]
t_eq = 20.0
t_av = $2
sample_every = 1.0

[[setting]]
label = "euler-0.05"

[[setting]]
label = "euler-0.2"
integrator.dt = 0.2

[[setting]]
label = "rkc"
integrator = { kind = "rkc" }

[[setting]]
label = "euler-1"
integrator.dt = 1.0

[[setting]]
label = "euler-0.05-np"
ensemble = { kind = "constant_pressure", pressure = 0.01 }
TOML
}
write_compare small.toml 200.0

# ---- Bad files: one line naming the key, exit 2, before anything runs.
expect_error() {  # $1: what, $2: a grep pattern the message must match; the file is bad.toml
  "$jamflow" compare bad.toml --out bad.out >out.txt 2>err.txt
  local rc=$?
  if [ "$rc" -eq 2 ] && [ "$(wc -l <err.txt)" -eq 1 ] && grep -q -- "$2" err.txt &&
    [ ! -e bad.out ]; then
    ok "bad file ($1): $(cat err.txt)"
  else
    bad "bad file ($1): exit $rc, stderr '$(cat err.txt)', output folder $([ -e bad.out ] && echo written || echo absent)"
  fi
}
sed 's/^reference = .*/reference = "nope"/' small.toml >bad.toml
expect_error "unknown reference" 'reference = .nope.; allowed the label of a setting'
sed 's/^observables = .*/observables = ["sigma_xy", "volume"]/' small.toml >bad.toml
expect_error "unknown observable" '.volume. is not allowed; allowed sigma_xy'
sed 's/^replicas = .*/replicas = 0/' small.toml >bad.toml
expect_error "replicas out of range" 'replicas = 0 is out of range'
sed 's/^integrator.dt = 0.2/integrator.dt = -0.2/' small.toml >bad.toml
expect_error "a setting's scene value" "'euler-0.2'.*dt.*-0.2"
sed 's/^integrator.dt = 0.2/system.phi = 0.5/' small.toml >bad.toml
expect_error "a key a setting may not set" "system.phi = 0.5 cannot be overridden here; allowed"
sed 's/^label = "rkc"/label = "r k c"/' small.toml >bad.toml
expect_error "a bad label" 'label = .r k c.; allowed'
sed 's/^t = 200.0/init = "start.xyz"/' small.toml >bad.toml
expect_error "replicas from one init file" "replicas = 3 with \[prepare\] init"
sed 's/^t_av = 200.0/t_av = 0.0/' small.toml >bad.toml
expect_error "run length" '\[run\] t_av = 0 is out of range'

# ---- Dry run: both stages counted, nothing run.
dry=$("$jamflow" compare small.toml --out dry.out --dry-run 2>&1)
dry_rc=$?
if [ "$dry_rc" -eq 0 ] && echo "$dry" | grep -q "compare (stage prepare): 3 points" &&
  echo "$dry" | grep -q "compare (stage settings): 15 points" &&
  [ ! -d dry.out/settings/runs/points ]; then
  ok "dry-run counts 3 preparations and 15 runs"
else
  bad "dry-run: exit $dry_rc, output '$dry', files: $(find dry.out -type f | head -20)"
fi

example=$("$jamflow" compare "$source_dir/examples/compare_rkc_euler.toml" --out example --dry-run 2>&1)
echo "$example" | grep -q "compare (stage settings): 15 points" &&
  ok "the example's dry run counts its 15 runs" || bad "example: $example"
example=$("$jamflow" compare "$source_dir/examples/compare_ensembles.toml" --out ensembles --dry-run 2>&1)
echo "$example" | grep -q "compare (stage settings): 6 points" &&
  ok "the ensemble example's dry run counts its 6 runs" || bad "ensemble example: $example"
example=$("$jamflow" compare "$source_dir/examples/compare_two_pressures.toml" --out two --dry-run 2>&1)
echo "$example" | grep -q "compare (stage settings): 36 points" &&
  ok "the two-pressure example's dry run counts its 36 runs" || bad "two-pressure example: $example"

# ---- The whole comparison.
"$jamflow" compare small.toml --out full -j 2 -q >full.txt 2>full.err
rc=$?
[ "$rc" -eq 0 ] && ok "compare exits 0" || bad "compare exit $rc: $(tail -3 full.err)"
for f in table.csv compare.h5 report.md work_precision_sigma_xy.png work_precision_pressure.png; do
  [ -s "full/$f" ] && ok "wrote $f" || bad "no full/$f"
done
/usr/bin/python3 - full <<'PY' && ok "table: a row per setting, euler-1 flagged, ranking by paired error" || bad "table checks"
import csv, math, sys
rows = list(csv.DictReader(open(sys.argv[1] + "/table.csv")))
labels = [r["setting"] for r in rows]
assert labels == ["euler-0.05", "euler-0.2", "rkc", "euler-1", "euler-0.05-np"], labels
by = {r["setting"]: r for r in rows}
assert by["euler-1"]["stable"] == "0", by["euler-1"]
assert by["euler-1"]["recommended"] == "0" and by["euler-1"]["within"] == "0"
for s in ("euler-0.05", "euler-0.2", "rkc"):
    assert by[s]["stable"] == "1", s
assert sum(int(r["recommended"]) for r in rows) == 1
assert by["euler-0.05"]["reference"] == "1" and by["euler-0.05"]["rank"] == "1"
# The rank orders the settings by their worst |difference| / floor over the observables.
def worst(r):
    return max(abs(float(r[o + "_diff"])) / float(r[o + "_floor"]) for o in ("sigma_xy", "pressure"))
ranked = sorted(rows, key=lambda r: int(r["rank"]))
w = [worst(r) for r in ranked]
assert all(a <= b for a, b in zip(w, w[1:])), list(zip([r["setting"] for r in ranked], w))
# Errors of the differences come from the replica scatter (3 replicas).
assert by["rkc"]["sigma_xy_diff_source"] == "replica scatter"
# The recommended setting is the cheapest of those within tolerance.
within = [r for r in rows if r["within"] == "1"]
best = min(within, key=lambda r: float(r["cpu_per_particle_tau"]))
assert best["recommended"] == "1", best["setting"]
PY
grep -q "^- euler-1: " full/report.md && grep -q "cheapest setting within tolerance is \*\*" full/report.md &&
  ok "report lists euler-1 as unstable and recommends a setting" || bad "report: $(tail -5 full/report.md)"
/usr/bin/python3 -c "
import h5py, sys
f = h5py.File('full/compare.h5', 'r')
assert set(f['settings'].keys()) == {'euler-0.05', 'euler-0.2', 'rkc', 'euler-1', 'euler-0.05-np'}
assert f['settings/euler-1'].attrs['stable'] == 0
assert 'block_std_ratio' in f['settings/euler-0.05-np/pressure'].attrs
" && ok "compare.h5 has a group per setting" || bad "compare.h5"

# ---- Resume after SIGTERM: longer settings runs, one at a time.
write_compare long.toml 3000.0
"$jamflow" compare long.toml --out resume -j 1 -q >resume1.txt 2>resume1.err &
pid=$!
done_files=()
for _ in $(seq 1 600); do
  mapfile -t done_files < <(ls resume/settings/runs/points/*/r0.h5 2>/dev/null)
  [ "${#done_files[@]}" -ge 2 ] && break
  sleep 0.1
done
kill -TERM "$pid"
wait "$pid"
rc=$?
if [ "$rc" -eq 143 ] && [ "${#done_files[@]}" -ge 2 ]; then
  ok "SIGTERM stops compare with 143 after ${#done_files[@]} finished settings runs"
else
  bad "SIGTERM: exit $rc with ${#done_files[@]} finished runs"
fi
declare -A stamp
for f in "${done_files[@]}"; do stamp[$f]=$(stat -c '%i %Y.%y' "$f"); done
lines_before=$(wc -l <resume/settings/runs/journal.log)
"$jamflow" compare long.toml --out resume -j 2 -q >resume2.txt 2>resume2.err
rc=$?
same=1
for f in "${done_files[@]}"; do
  [ "$(stat -c '%i %Y.%y' "$f")" = "${stamp[$f]}" ] || same=0
  name=$(basename "$(dirname "$f")")
  # After the first launch's lines, no "started" or "resumed" line for a finished run.
  tail -n +"$((lines_before + 1))" resume/settings/runs/journal.log |
    grep -q "^[^ ]* $name r0 \(started\|resumed\)" && same=0
done
if [ "$rc" -eq 0 ] && [ "$same" -eq 1 ] && [ "$(tail -n +2 resume/table.csv | wc -l)" -eq 5 ]; then
  ok "rerun finishes (exit 0, 5 rows) without redoing the ${#done_files[@]} finished runs"
else
  bad "rerun: exit $rc, finished runs untouched: $same; $(tail -3 resume2.err)"
fi

# ---- An ensemble comparison: constant volume started at the preparation's mean phi.
cat > ens.toml <<'TOML'
reference = "np"
replicas = 2
observables = ["sigma_xy", "phi"]
[base.system]
N = 64
phi = 0.60
seed = 3
[base.ensemble]
kind = "constant_pressure"
pressure = 1e-2
xi_V = 1.0
[base.shear]
rate = 1e-2
[base.integrator]
kind = "euler"
dt = 0.05
[base.run]
t_eq = 0.0
t_av = 100.0
[prepare]
t = 200.0
[run]
t_eq = 10.0
t_av = 60.0
sample_every = 1.0
[[setting]]
label = "np"
[[setting]]
label = "nv"
ensemble = { kind = "constant_volume" }
start = "mean_phi"
TOML
"$jamflow" compare ens.toml --out ens.out -j 2 -q --no-plots > ens.txt 2>&1
rc=$?
# Every constant-volume replica runs at one packing fraction: the mean over the steady sources
# (all if none is steady) of their window-mean phi, not at the phi of a last frame nor at each
# replica's own mean. $1: the source's folder and label, $2: the setting's.
same_phi() {
  /usr/bin/python3 - ens.out "$1" "$2" <<'PY'
import glob, sys, h5py, numpy as np
out, source, setting = sys.argv[1:]
means, steady, lasts = [], [], []
for k in (0, 1):
    with h5py.File(glob.glob(f"{out}/{source}_r{k}/r0.h5")[0]) as p:
        means.append(p["summary"].attrs["phi"])
        steady.append(p["summary"].attrs["steady"] == 1)
        lasts.append(p["timeseries/phi"][-1])
use = [m for m, s in zip(means, steady) if s] or means
target = np.mean(use)
assert abs(means[0] - means[1]) > 1e-6, means  # the test tells a replica's mean from the pool's
assert all(abs(target - x) > 1e-6 for x in lasts), (target, lasts)
for k in (0, 1):
    with h5py.File(glob.glob(f"{out}/{setting}_r{k}/r0.h5")[0]) as v:
        phi = v["timeseries/phi"][:]
        assert np.allclose(phi, target, rtol=1e-9, atol=0), (k, phi[:3], target, means, steady)
PY
}
if [ "$rc" -eq 0 ] && same_phi prepare/runs/points/prepare settings/runs/points/nv; then
  ok "start = \"mean_phi\": every constant-volume replica runs at the preparations' mean phi"
else bad "mean_phi: exit $rc, $(tail -3 ens.txt)"; fi
grep -q 'start = "mean_phi"' ens.out/report.md && ok "the report says where nv started" ||
  bad "report does not say start = mean_phi"
# from = "np": constant volume continues from the constant-pressure setting's replica k (a third
# stage, continued/), at that setting's mean phi.
cat ens.toml - > from.toml <<'TOML'
[[setting]]
label = "nv-from-np"
from = "np"
start = "mean_phi"
ensemble = { kind = "constant_volume" }
run = { t_eq = 5.0 }
TOML
"$jamflow" compare from.toml --out ens.out -j 2 -q --no-plots > from.txt 2>&1
rc=$?
if [ "$rc" -eq 0 ] && [ -d ens.out/continued/runs/points/nv-from-np_r1 ] &&
  same_phi settings/runs/points/np continued/runs/points/nv-from-np &&
  [ "$(tail -n +2 ens.out/table.csv | wc -l)" -eq 3 ] &&
  grep -q '`nv-from-np` continues from replica k of `np`' ens.out/report.md; then
  ok "from = \"np\": a third stage continues from np's replicas at their mean phi"
else bad "from: exit $rc, $(tail -3 from.txt)"; fi
# integrator.atol_overlaps = x: atol = x delta, delta = P (alpha_r = 2) the typical overlap: the
# imposed P at constant pressure, the mean P_hat of the runs it continues from at constant volume.
cat from.toml - > atol.toml <<'TOML'
[[setting]]
label = "rkc-np"
integrator = { kind = "rkc", atol_overlaps = 0.1 }
[[setting]]
label = "rkc-nv"
from = "np"
start = "mean_phi"
ensemble = { kind = "constant_volume" }
integrator = { kind = "rkc", atol_overlaps = 0.1 }
TOML
"$jamflow" compare atol.toml --out ens.out -j 2 -q --no-plots > atol.txt 2>&1
rc=$?
if [ "$rc" -eq 0 ] && /usr/bin/python3 - ens.out <<'PY'
import sys, tomllib, h5py, numpy as np
out = sys.argv[1]
def atol(path):
    with open(path, "rb") as f:
        return tomllib.load(f)["integrator"]["atol"]
assert abs(atol(f"{out}/settings/runs/points/rkc-np_r0/r0.toml") - 0.1 * 1e-2) < 1e-15
p, steady = [], []
for k in (0, 1):
    with h5py.File(f"{out}/settings/runs/points/np_r{k}/r0.h5") as f:
        p.append(f["summary"].attrs["pressure"])
        steady.append(f["summary"].attrs["steady"] == 1)
use = [x for x, s in zip(p, steady) if s] or p
got = atol(f"{out}/continued/runs/points/rkc-nv_r1/r0.toml")
assert abs(got - 0.1 * np.mean(use)) < 1e-12 * got, (got, p, steady)
PY
then ok "atol_overlaps: atol = 0.1 P imposed, and 0.1 <P_hat> of the source at constant volume"
else bad "atol_overlaps: exit $rc, $(tail -3 atol.txt)"; fi
sed 's/^integrator = { kind = "rkc", atol_overlaps = 0.1 }$/integrator = { kind = "rkc", atol_overlaps = 0.1, atol = 1e-3 }/' atol.toml > bad.toml
expect_error "atol and atol_overlaps" "bad.toml: \[\[setting\]\] 'rkc-np': integrator.atol with integrator.atol_overlaps; allowed one of them"
sed 's/^from = "np"$/from = "nv-from-np"/' from.toml > bad.toml
expect_error "from a later setting" 'from = "nv-from-np"; allowed the label of an earlier \[\[setting\]\]: np, nv$'
cat from.toml - > bad.toml <<'TOML'
[[setting]]
label = "chain"
from = "nv-from-np"
TOML
expect_error "a chain of from" "from = \"nv-from-np\", which itself continues from 'np'; allowed a setting that starts from the preparation"
sed 's/^run = { t_eq = 5.0 }$/run = { t_av = 5.0 }/' from.toml > bad.toml
expect_error "a setting's t_av" "key run.t_av = 5.0 cannot be overridden here; allowed"
sed 's/^start = "mean_phi"$/start = "middle"/' ens.toml > bad.toml
expect_error "a bad start" 'start = .middle.; allowed "final".*"mean_phi"'
sed 's/^ensemble = { kind = "constant_volume" }$//' ens.toml > bad.toml
expect_error "mean_phi at constant pressure" 'start = "mean_phi" at constant pressure; allowed'

# ---- [[case]]: the same settings at two state points, run together, a report per case.
cat > cases.toml <<'TOML'
reference = "euler-0.05"
replicas = 2
observables = ["sigma_xy"]
diagnose = true
[base.system]
N = 64
phi = 0.60
seed = 5
[base.ensemble]
kind = "constant_volume"
[base.shear]
rate = 1e-2
[base.integrator]
kind = "euler"
dt = 0.05
[base.run]
t_eq = 0.0
t_av = 100.0
[prepare]
t = 100.0
[run]
t_eq = 10.0
t_av = 60.0
sample_every = 1.0
[[setting]]
label = "euler-0.05"
[[setting]]
label = "euler-1"
integrator.dt = 1.0
[[setting]]
label = "euler-0.1"
integrator.dt = 0.1
[[case]]
label = "phi0.60"
[[case]]
label = "phi0.64-slow"
settings = ["euler-0.05", "euler-1"]
system = { phi = 0.64 }
shear = { rate = 1e-3 }
run = { t_av = 80.0, max_force_evaluations = 100000000 }
prepare = { integrator = { dt = 0.02 } }
TOML
"$jamflow" compare cases.toml --out cases.out -j 2 -q --no-plots > cases.txt 2>&1
rc=$?
# Each case is a comparison of its own at its state point, with its own report and a row per
# setting it runs in the joint table (the second case runs two of the three); with diagnose the
# diagnostic window classifies every run, and the unstable dt = 1 is flagged in both.
if [ "$rc" -eq 0 ] && [ -s cases.out/phi0.60/report.md ] && [ -s cases.out/phi0.64-slow/compare.h5 ] &&
  [ "$(tail -n +2 cases.out/table.csv | wc -l)" -eq 5 ] && head -1 cases.out/table.csv | grep -q '^case,setting,' &&
  [ ! -d "cases.out/settings/runs/points/phi0.64-slow.euler-0.1_r0" ] &&
  grep -q '| diagnostic window (replicas) |' cases.out/phi0.60/report.md &&
  ! grep -Eq '\| euler-0.05 \| .*(oscillating|diverged)' cases.out/phi0.60/report.md &&
  grep -Eq '\| euler-1 \| unstable: .*\| (oscillating|diverged)' cases.out/phi0.60/report.md &&
  [ -d "cases.out/settings/runs/points/phi0.64-slow.euler-1_r1" ] &&
  grep -q 'phi0.64-slow.*| euler-1' cases.out/report.md &&
  /usr/bin/python3 - cases.out <<'PY'
import sys, tomllib, h5py
out = sys.argv[1]
for case, phi, rate, t_av in (("phi0.60", 0.60, 1e-2, 60.0), ("phi0.64-slow", 0.64, 1e-3, 80.0)):
    with h5py.File(f"{out}/settings/runs/points/{case}.euler-0.05_r0/r0.h5") as f:
        scene = f.attrs["scene"]
        scene = scene.decode() if isinstance(scene, bytes) else scene
        assert f"rate = {rate:g}".replace("0.001", "0.001") in scene or f"rate = {rate}" in scene, scene
        assert f"t_av = {t_av}" in scene, scene
        assert abs(f["timeseries/phi"][0] - phi) < 1e-9, f["timeseries/phi"][0]
    with open(f"{out}/prepare/runs/points/{case}.prepare_r0/r0.toml", "rb") as f:
        prep = tomllib.load(f)
    assert prep["integrator"]["dt"] == (0.05 if case == "phi0.60" else 0.02), prep["integrator"]
    with open(f"{out}/settings/runs/points/{case}.euler-1_r0/r0.toml", "rb") as f:
        budget = tomllib.load(f)["run"]["max_force_evaluations"]
    assert budget == (0 if case == "phi0.60" else 100000000), budget
    with h5py.File(f"{out}/{case}/compare.h5") as f:
        assert f["settings/euler-1"].attrs["stable"] == 0
        v = f["settings/euler-1/replicas/0"].attrs["verdict"]
        v = v.decode() if isinstance(v, bytes) else v
        assert v.startswith("oscillating") or v.startswith("diverged"), v
PY
then ok "[[case]]: two state points run together, each with its report, the table has a case column"
else bad "cases: exit $rc, $(tail -3 cases.txt)"; fi
sed 's/^system = { phi = 0.64 }$/system = { seed = 2 }/' cases.toml > bad.toml
expect_error "a case's system.seed" "\[\[case\]\] 'phi0.64-slow': key system.seed = 2; allowed system.N, system.phi"
sed 's/^label = "phi0.64-slow"$/label = "phi0.60"/' cases.toml > bad.toml
expect_error "a case label twice" 'label "phi0.60" given twice; allowed unique labels'
sed 's/^run = { t_av = 80.0, max_force_evaluations = 100000000 }$/run = { t_av = -1.0 }/' cases.toml > bad.toml
expect_error "a case's t_av" "'phi0.64-slow': \[run\] t_av = -1 is out of range; allowed > 0"
sed 's/^settings = \["euler-0.05", "euler-1"\]$/settings = ["euler-1"]/' cases.toml > bad.toml
expect_error "a case without its reference" "settings: the reference 'euler-0.05' is not among them"
sed 's/^settings = \["euler-0.05", "euler-1"\]$/settings = ["euler-0.05", "euler-9"]/' cases.toml > bad.toml
expect_error "a case's unknown setting" 'settings: .euler-9. is not a setting; allowed euler-0.05, euler-1, euler-0.1'
sed 's/^prepare = { integrator = { dt = 0.02 } }$/prepare = { replicas = 2 }/' cases.toml > bad.toml
expect_error "a case's preparation key" "bad.toml: \[\[case\]\] 'phi0.64-slow': prepare: unknown key replicas = 2; allowed t, sample_every, and overrides"
sed 's/^diagnose = true$/diagnose = 1/' cases.toml > bad.toml
expect_error "diagnose not a bool" "diagnose = 1; allowed true or false"
sed 's/^label = "phi0.64-slow"$/label = "phi0.64-slow"\nreference = "euler-2"/' cases.toml > bad.toml
expect_error "a case's reference not a setting" "'phi0.64-slow': reference = .euler-2.; allowed the label of a setting: euler-0.05, euler-1, euler-0.1"
sed 's/^label = "phi0.64-slow"$/label = "phi0.64-slow"\nreference = "euler-0.1"/' cases.toml > bad.toml
expect_error "a case's reference outside its settings" "settings: the reference 'euler-0.1' is not among them"
sed 's/^label = "euler-0.1"$/label = "euler-0.1"\nconverged = 1/' cases.toml > bad.toml
expect_error "converged not a bool" "'euler-0.1': converged = 1; allowed true or false"

# ---- The sweep engine's other runners: a Slurm job array for the next stage, and MPI ranks.
"$jamflow" compare small.toml --slurm --out slurm.out > slurm.txt 2>&1
rc=$?
if [ "$rc" -eq 0 ] && grep -q "#SBATCH --array" slurm.out/prepare/runs/sweep.sbatch 2>/dev/null &&
  [ -z "$(find slurm.out -name '*.h5*')" ]; then
  ok "--slurm writes the preparation's job array and runs nothing"
else
  bad "--slurm: exit $rc, $(cat slurm.txt | tail -3)"
fi
if command -v mpirun >/dev/null && "$jamflow" --help | grep -q mpirun; then
  export OMPI_MCA_rmaps_base_oversubscribe=1
  mpi_env=()
  [ -n "${ASAN_OPTIONS:-}" ] && mpi_env=(-x "ASAN_OPTIONS=${ASAN_OPTIONS}:detect_leaks=0")
  # A launch that ran a stage before the last ends there; the same command goes on.
  for launch in 1 2; do
    mpirun --allow-run-as-root --oversubscribe "${mpi_env[@]}" -n 2 "$jamflow" compare small.toml \
      --out mpi.out -q > mpi$launch.txt 2>&1 || true
  done
  # The same runs as the local comparison: the same numbers (the cost and what it chooses aside).
  if /usr/bin/python3 - full/table.csv mpi.out/table.csv <<'PY'
import csv, sys
def rows(p):
    return [{k: v for k, v in r.items() if not k.startswith("cpu_") and k != "recommended"}
            for r in csv.DictReader(open(p))]
sys.exit(0 if rows(sys.argv[1]) == rows(sys.argv[2]) else 1)
PY
  then ok "under mpirun -n 2 the comparison gives the local one's numbers"
  else bad "mpirun compare: $(tail -3 mpi2.txt)"; fi
else
  echo "skip: no MPI launcher"
fi

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
