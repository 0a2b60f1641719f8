#!/bin/bash
# `jamflow sweep --slurm` against a real single-node Slurm (Debian 12: slurm-wlm 22.05 + munge,
# no systemd needed):
#   1. installs slurm-wlm and munge with apt-get and starts munged, slurmctld -D and slurmd -D
#      with a private configuration (SLURM_CONF in a scratch folder; /etc/slurm is not touched);
#   2. writes a 4-point sweep, `--slurm --array-size 2`, checks the script (--array=0-1,
#      --signal=B:TERM@), sbatch-es it, waits for the array, checks every point's r0.h5 is
#      "complete" and `--collect` gives a header and 4 rows;
#   3. writes a 1-point sweep whose point runs ~30 s with checkpoints every 2 s, submits it,
#      sends the batch shell TERM once r0.h5.part exists (scancel -b -s TERM), checks that the
#      point checkpointed and the array task requeued itself, starts the requeued task at once
#      (scontrol update StartTime=now, instead of Slurm's ~120 s BeginTime), waits for it, and
#      checks r0.h5 is complete with root attribute resumes >= 1.
# The daemons it started are stopped on exit (by pid), with any job of theirs still running.
#
# Usage: bash tests/sweep/slurm_test.sh [PATH/TO/jamflow]      (default: build/jamflow)
# Exit status: 0 passed, 1 failed, 77 skipped (not root, apt-get cannot install the packages,
# Slurm daemons already running). Needs root, apt-get, /usr/bin/python3 with h5py.
# Environment: JAMFLOW_WAIT_SECONDS (default 2400): how long to wait for a jamflow binary with
# the `sweep` command (it may be being rebuilt); SLURM_TEST_KEEP=1 keeps the scratch folder.
set -uo pipefail

JF=${1:-$(cd "$(dirname "$0")/../.." && pwd)/build/jamflow}
case $JF in /*) ;; *) JF=$PWD/$JF ;; esac
T0=$(date +%s)
PASSED=0
W=""               # scratch folder: Slurm state, logs, the sweeps
CTLD_PID="" SLURMD_PID="" MUNGED_PID=""
JOBS=()            # job ids we submitted
STEPDS_BEFORE=" "  # slurmstepd processes that are not ours

say() { printf 'slurm_test: %s\n' "$*"; }
skip() { say "SKIP: $*"; exit 77; }
pass() { PASSED=$((PASSED + 1)); say "ok $PASSED - $*"; }
fail() { say "FAIL: $*"; diagnostics; say "FAILED after $(($(date +%s) - T0)) s ($PASSED checks had passed)"; exit 1; }
elapsed() { echo $(($(date +%s) - T0)); }

show_tail() {  # FILE [LINES]
  [ -s "$1" ] || return 0
  echo "----- tail of $1"
  tail -n "${2:-30}" "$1"
}

diagnostics() {
  [ -n "$W" ] && [ -d "$W" ] || return 0
  if [ -n "$CTLD_PID" ]; then
    echo "----- squeue"
    squeue -a -r -o '%.10A %.12i %.10T %.20r %.10M' 2>&1 | tail -n 20
    local j
    for j in "${JOBS[@]}"; do
      echo "----- scontrol show job $j"
      scontrol show job "$j" 2>&1 | grep -E 'JobId=|JobState=|Restarts=|BeginTime=|Reason=|ExitCode=' |
        head -n 20
    done
  fi
  show_tail "$W/log/slurmctld.log" 40
  show_tail "$W/log/slurmd.log" 40
  show_tail "$W/log/ctld.out" 10
  show_tail "$W/log/d.out" 10
  local f
  for f in "$W"/*/slurm/*.out "$W"/*/points/*/r0.log; do
    [ -e "$f" ] && show_tail "$f" 30
  done
}

# Whether a process runs (a zombie, ended but not yet reaped, does not).
alive() {
  local stat
  [ -n "$1" ] && stat=$(cat "/proc/$1/stat" 2>/dev/null) || return 1
  stat=${stat##*) }
  [ "${stat%% *}" != Z ]
}

# Stops one process we started: TERM, then KILL after 15 s.
stop_pid() {
  local pid=$1
  alive "$pid" || { [ -n "$pid" ] && wait "$pid" 2>/dev/null; return 0; }
  kill -TERM "$pid" 2>/dev/null
  for _ in $(seq 150); do alive "$pid" || break; sleep 0.1; done
  alive "$pid" && kill -KILL "$pid" 2>/dev/null
  wait "$pid" 2>/dev/null
  return 0
}

cleanup() {
  local rc=$? p
  trap - EXIT INT TERM
  if [ ${#JOBS[@]} -gt 0 ] && alive "$CTLD_PID"; then
    scancel "${JOBS[@]}" 2>/dev/null
    for _ in $(seq 30); do
      [ -z "$(squeue -h -j "$(IFS=,; echo "${JOBS[*]}")" -o %T 2>/dev/null |
              grep -vE 'COMPLETED|CANCELLED|FAILED|TIMEOUT')" ] && break
      sleep 0.5
    done
  fi
  stop_pid "$SLURMD_PID"
  stop_pid "$CTLD_PID"
  # Anything our jobs left behind: slurmstepd processes that were not there before, and
  # processes of our copy of the jamflow binary.
  for p in $(pgrep -x slurmstepd); do
    case $STEPDS_BEFORE in *" $p "*) ;; *) kill -KILL "$p" 2>/dev/null ;; esac
  done
  if [ -n "$W" ]; then
    for p in $(pgrep -x jamflow); do
      [ "$(readlink "/proc/$p/exe" 2>/dev/null)" = "$W/bin/jamflow" ] && kill -KILL "$p" 2>/dev/null
    done
  fi
  if alive "$MUNGED_PID"; then
    kill -TERM "$MUNGED_PID"
    for _ in $(seq 100); do alive "$MUNGED_PID" || break; sleep 0.1; done
  fi
  if [ -n "$W" ] && [ -d "$W" ]; then
    if [ "$rc" = 0 ] && [ "${SLURM_TEST_KEEP:-0}" != 1 ]; then
      rm -rf "$W"
    else
      say "scratch folder kept: $W"
    fi
  fi
  exit "$rc"
}
trap cleanup EXIT
trap 'say "interrupted"; exit 130' INT
trap 'say "terminated"; exit 143' TERM

# ---- preconditions ------------------------------------------------------------------------
[ "$(id -u)" = 0 ] || skip "needs root (installs and starts Slurm and munge)"
command -v apt-get >/dev/null || skip "no apt-get (needs Debian's slurm-wlm and munge)"
pgrep -x slurmctld >/dev/null && skip "a slurmctld is already running (pid $(pgrep -x slurmctld | head -n1)); not ours to use"
pgrep -x slurmd >/dev/null && skip "a slurmd is already running (pid $(pgrep -x slurmd | head -n1)); not ours to use"
STEPDS_BEFORE=" $(pgrep -x slurmstepd | tr '\n' ' ')"
# Our own Slurm variables only (if this runs inside a Slurm job, its variables must not leak).
for v in $(compgen -e | grep '^SLURM_\|^SBATCH_\|^SQUEUE_\|^SCONTROL_' ); do unset "$v"; done

# The binary may be missing or lack `sweep` while it is being rebuilt: wait for it.
deadline=$(($(date +%s) + ${JAMFLOW_WAIT_SECONDS:-2400}))
until [ -x "$JF" ] && "$JF" sweep --help >/dev/null 2>&1; do
  [ "$(date +%s)" -lt "$deadline" ] ||
    fail "$JF is missing or has no 'sweep' command (waited ${JAMFLOW_WAIT_SECONDS:-2400} s)"
  say "$JF is missing or has no 'sweep' command yet; retrying in 60 s"
  sleep 60
done

W=$(mktemp -d /tmp/jamflow-slurm-test.XXXXXX) || fail "mktemp"
mkdir -p "$W"/{etc,state,spool,log,bin}
# A private copy: a rebuild of build/jamflow during the test does not change what the jobs run
# (its runpath is absolute, so the copy finds the same libraries).
cp "$JF" "$W/bin/jamflow" || fail "cannot copy $JF"
JFC=$W/bin/jamflow
"$JFC" --version >/dev/null 2>&1 || fail "the copy $JFC does not run: $("$JFC" --version 2>&1 | head -n1)"

# ---- 1. install and start Slurm -------------------------------------------------------------
installed() {
  local p
  for p in slurm-wlm munge; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed' || return 1
  done
  command -v slurmctld >/dev/null && command -v slurmd >/dev/null && command -v munged >/dev/null
}
apt_install() {  # PACKAGES...
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq -o DPkg::Lock::Timeout=300 "$@" \
    >>"$W/log/apt.log" 2>&1
}
if ! installed; then
  say "installing slurm-wlm and munge with apt-get"
  apt_install slurm-wlm munge ||
    { apt-get update -qq -o DPkg::Lock::Timeout=300 >>"$W/log/apt.log" 2>&1 && apt_install slurm-wlm munge; } ||
    skip "apt-get cannot install slurm-wlm munge: $(grep -E '^E:' "$W/log/apt.log" | tail -n1)"
  installed || skip "slurm-wlm and munge are not usable after apt-get install"
  say "installed after $(elapsed) s"
fi
# A package install may have started daemons (systemd): those are not ours.
pgrep -x slurmctld >/dev/null && skip "a slurmctld is running that this test did not start"
pgrep -x slurmd >/dev/null && skip "a slurmd is running that this test did not start"
if ! /usr/bin/python3 -c 'import h5py' 2>/dev/null; then
  apt_install python3-h5py || skip "no h5py for /usr/bin/python3 and apt-get cannot install python3-h5py"
fi

# munge: reuse a running munged (e.g. started by systemd at install), else start our own.
if pgrep -x munged >/dev/null; then
  say "using the munged already running (pid $(pgrep -x munged | head -n1))"
else
  [ -s /etc/munge/munge.key ] || mungekey --create || fail "mungekey --create failed"
  chown munge:munge /etc/munge/munge.key && chmod 400 /etc/munge/munge.key
  install -d -o munge -g munge -m 755 /run/munge
  rm -f /run/munge/munged.pid
  runuser -u munge -- /usr/sbin/munged >"$W/log/munged.out" 2>&1 ||
    fail "munged did not start: $(cat "$W/log/munged.out")"
  MUNGED_PID=$(cat /run/munge/munged.pid 2>/dev/null)
  [ -n "$MUNGED_PID" ] || fail "munged started but wrote no /run/munge/munged.pid"
fi
munge -n | unmunge >/dev/null 2>&1 || fail "munge -n | unmunge fails: munged does not work"

H=$(hostname -s)
export SLURM_CONF=$W/etc/slurm.conf
cat >"$SLURM_CONF" <<CONF
ClusterName=jamflowtest
SlurmctldHost=$H
SlurmUser=root
AuthType=auth/munge
StateSaveLocation=$W/state
SlurmdSpoolDir=$W/spool
SlurmctldPidFile=$W/slurmctld.pid
SlurmdPidFile=$W/slurmd.pid
SlurmctldLogFile=$W/log/slurmctld.log
SlurmdLogFile=$W/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
MpiDefault=none
MailProg=/bin/true
ReturnToService=2
MinJobAge=600
NodeName=$H CPUs=$(nproc) RealMemory=1000 State=UNKNOWN
PartitionName=debug Nodes=ALL Default=YES MaxTime=INFINITE State=UP
CONF
# cgroup.conf beside slurm.conf: without it slurmd may die on cgroup autodetection; v1 is never
# used with proctrack/linuxproc and task/none.
echo 'CgroupPlugin=cgroup/v1' >"$W/etc/cgroup.conf"

slurmctld -D -i >"$W/log/ctld.out" 2>&1 &
CTLD_PID=$!
slurmd -D >"$W/log/d.out" 2>&1 &
SLURMD_PID=$!
for _ in $(seq 60); do
  sinfo -h -o %t 2>/dev/null | grep -qx idle && break
  alive "$CTLD_PID" || fail "slurmctld exited at start"
  alive "$SLURMD_PID" || fail "slurmd exited at start"
  sleep 1
done
sinfo -h -o %t 2>/dev/null | grep -qx idle ||
  fail "the node is not idle after 60 s: $(sinfo -h -o '%t %E' 2>&1 | head -n1)"
pass "single-node Slurm up ($(sinfo -V), node $H idle) after $(elapsed) s"

# ---- helpers ----------------------------------------------------------------------------------
# Active states of a job's array tasks, one "jobid state reason" a line; empty once all ended.
active() {
  squeue -h -r -j "$1" -o '%A %T %r' 2>/dev/null |
    grep -vE ' (COMPLETED|CANCELLED|FAILED|TIMEOUT|NODE_FAIL|PREEMPTED|BOOT_FAIL|DEADLINE|OUT_OF_MEMORY) '
}
# Waits until job $1 has no active task, at most $2 s; fails with $3 otherwise.
wait_gone() {
  local _
  for _ in $(seq "$2"); do
    [ -z "$(active "$1")" ] && return 0
    sleep 1
  done
  fail "$3: job $1 still in the queue after $2 s: $(active "$1" | tr '\n' ';')"
}
# "file<TAB>status<TAB>resumes" of HDF5 files, from their root attributes.
h5status() {
  HDF5_USE_FILE_LOCKING=FALSE /usr/bin/python3 - "$@" <<'PY'
import sys, h5py
def text(v):
    if v is None:
        return "-"
    if isinstance(v, bytes):
        return v.decode()
    try:
        return v.item().decode() if isinstance(v.item(), bytes) else str(v.item())
    except AttributeError:
        return str(v)
for f in sys.argv[1:]:
    try:
        with h5py.File(f, "r") as h:
            print(f"{f}\t{text(h.attrs.get('status'))}\t{text(h.attrs.get('resumes'))}")
    except Exception as e:
        print(f"{f}\tunreadable: {e}\t-")
PY
}
# Job states of every task of job $1 (scontrol keeps ended jobs for MinJobAge).
job_states() { scontrol -o show job "$1" 2>/dev/null | grep -o 'JobState=[A-Z_]*' | sort | uniq -c | tr -s ' \n' '  '; }

# ---- 2. a 4-point sweep as a job array of 2 ------------------------------------------------------
D1=$W/tiny
mkdir -p "$D1"
cat >"$D1/tiny.toml" <<'TOML'
[sweep]
replicas = 1
[sweep.grid]
"shear.rate" = [1e-2, 3e-3]
"ensemble.pressure" = [1e-2, 3e-3]
[scene.system]
N = 64
phi = 0.6
[scene.ensemble]
kind = "constant_pressure"
pressure = 1e-2
[scene.shear]
rate = 1e-2
[scene.integrator]
kind = "euler"
dt = 0.1
[scene.run]
t_eq = 20.0
t_av = 40.0
sample_every = 1.0
TOML
cd "$D1" || fail "cd $D1"
out=$("$JFC" sweep tiny.toml --out "$D1/out" --slurm --array-size 2 --time 00:10:00 2>&1) ||
  fail "jamflow sweep --slurm exited $?: $out"
S1=$D1/out/sweep.sbatch
[ -s "$S1" ] || fail "no $S1 after --slurm; it printed: $out"
grep -qF "$S1" <<<"$out" || fail "--slurm did not print the script's path $S1; it printed: $out"
grep -q -- '--array=0-1$' "$S1" || fail "$S1 has no '--array=0-1': $(grep SBATCH "$S1" | tr '\n' ' ')"
grep -q -- '--signal=B:TERM@' "$S1" || fail "$S1 has no '--signal=B:TERM@': $(grep SBATCH "$S1" | tr '\n' ' ')"
bash -n "$S1" || fail "$S1 is not valid bash"
pass "--slurm wrote $S1 with --array=0-1 and --signal=B:TERM@"

J1=$(sbatch --parsable "$S1" 2>&1) || fail "sbatch $S1 failed: $J1"
J1=${J1%%;*}
JOBS+=("$J1")
wait_gone "$J1" 120 "the 4-point array"
states=$(job_states "$J1")
[ "$(grep -o 'JobState=[A-Z_]*' <<<"$states" | sort -u)" = "JobState=COMPLETED" ] ||
  fail "array job $J1 did not complete: $states"
pass "array job $J1 (2 tasks) completed after $(elapsed) s"

mapfile -t files < <(ls -d "$D1"/out/points/*/ 2>/dev/null)
[ ${#files[@]} = 4 ] || fail "expected 4 point folders in $D1/out/points, found ${#files[@]}"
st=$(h5status "$D1"/out/points/*/r0.h5 2>&1)
n_complete=$(awk -F'\t' '$2 == "complete"' <<<"$st" | wc -l)
[ "$n_complete" = 4 ] || fail "not every point's r0.h5 is complete:
$st"
pass "all 4 points' r0.h5 have status \"complete\""

out=$("$JFC" sweep tiny.toml --out "$D1/out" --collect "$D1/table.csv" 2>&1) ||
  fail "--collect exited $?: $out"
grep -q "table.csv: 4 of 4 points" <<<"$out" || fail "--collect printed: $out"
[ "$(wc -l <"$D1/table.csv")" = 5 ] || fail "table.csv has $(wc -l <"$D1/table.csv") lines, expected a header and 4 rows:
$(cat "$D1/table.csv")"
header=$(head -n1 "$D1/table.csv")
for col in point N imposed_pressure shear_rate phi phi_err mu mu_err J replicas steady stable decorrelated folder; do
  tr ',' '\n' <<<"$header" | grep -qx "$col" || fail "table.csv header lacks '$col': $header"
done
pass "--collect: table.csv has the header and 4 rows"

# ---- 3. TERM to the batch shell: checkpoint, requeue, resume ----------------------------------
D2=$W/long
mkdir -p "$D2"
# One point of about 30 s here (N = 1000, 1e5 time units at ~30 ns per particle-step).
cat >"$D2/long.toml" <<'TOML'
[sweep]
replicas = 1
[sweep.grid]
"shear.rate" = [3e-3]
[scene.system]
N = 1000
phi = 0.6
[scene.ensemble]
kind = "constant_pressure"
pressure = 3e-3
[scene.shear]
rate = 3e-3
[scene.integrator]
kind = "euler"
dt = 0.1
[scene.run]
t_eq = 100.0
t_av = 100000.0
sample_every = 10.0
[scene.output]
checkpoint_every = 2
TOML
# Under a sanitizer (JAMFLOW_SHORT_TESTS) the binary is about ten times slower: a tenth of the
# window keeps the point at about 30 s, so the resumed job ends within the wait below.
if [ -n "${JAMFLOW_SHORT_TESTS:-}" ]; then
  sed -i 's/^t_av = 100000.0$/t_av = 10000.0/' "$D2/long.toml"
  echo "[shortened] Sweep.Slurm"
fi
cd "$D2" || fail "cd $D2"
out=$("$JFC" sweep long.toml --out "$D2/out" --slurm --time 00:10:00 2>&1) ||
  fail "jamflow sweep --slurm exited $?: $out"
S2=$D2/out/sweep.sbatch
[ -s "$S2" ] || fail "no $S2 after --slurm; it printed: $out"
P2=$(ls -d "$D2"/out/points/*/ 2>/dev/null | head -n1)
[ -n "$P2" ] || fail "no point folder in $D2/out/points after --slurm"
R=${P2%/}/r0.h5
J2=$(sbatch --parsable "$S2" 2>&1) || fail "sbatch $S2 failed: $J2"
J2=${J2%%;*}
JOBS+=("$J2")
for _ in $(seq 120); do
  [ -e "$R.part" ] && break
  [ -z "$(active "$J2")" ] && fail "job $J2 ended before $R.part appeared"
  sleep 0.5
done
[ -e "$R.part" ] || fail "no $R.part 60 s after submitting job $J2"
sleep 3  # past a periodic checkpoint or two
[ -e "$R" ] && fail "the long point already finished before its TERM: lengthen t_av in the test"
running=$(active "$J2")
grep -q ' RUNNING ' <<<"$running" || fail "job $J2 not running before its TERM: $running"
JT=$(awk '{print $1; exit}' <<<"$running")  # the array task's own job id
say "job $J2 (task job id $JT) is running and $R.part exists; sending its batch shell TERM"
scancel --batch --signal=TERM "$JT" || fail "scancel --batch --signal=TERM $JT failed"

# The batch shell passes TERM on, jamflow checkpoints and exits 143, and the script requeues.
RQ=""
for _ in $(seq 60); do
  RQ=$(active "$J2" | awk '$2 == "PENDING" {print $1; exit}')
  [ -n "$RQ" ] && break
  [ -z "$(active "$J2")" ] && break
  sleep 1
done
outfile=$(ls "$D2"/out/slurm/*.out 2>/dev/null | head -n1)
if [ -z "$RQ" ]; then
  fail "job $J2 was not requeued after TERM (states: $(job_states "$J2"); now: $(active "$J2" | tr '\n' ';'));
its output says: $(cat "$outfile" 2>/dev/null)"
fi
pass "job $J2 requeued itself after TERM (pending as job $RQ: $(active "$J2" | tr '\n' ' '))"

grep -q 'requeueing' "$outfile" 2>/dev/null ||
  fail "the job's output $outfile does not say it requeued: $(cat "$outfile" 2>/dev/null)"
grep -q 'status 143' "$outfile" ||
  fail "jamflow sweep did not exit 143 on TERM; the job's output: $(cat "$outfile")"
[ -e "$R" ] && fail "$R exists after the TERM: the point was not stopped"
st=$(h5status "$R.part")
grep -q $'\tinterrupted[^\t]*SIGTERM' <<<"$st" ||
  fail "after TERM, $R.part should say 'interrupted ... by SIGTERM'; it has: $st"
pass "the point checkpointed on TERM ($(cut -f2 <<<"$st"))"

scontrol update jobid="$RQ" StartTime=now || fail "scontrol update jobid=$RQ StartTime=now failed"
for _ in $(seq 60); do
  grep -q ' PENDING ' <<<"$(active "$J2")" || break
  sleep 1
done
grep -q ' PENDING ' <<<"$(active "$J2")" && fail "requeued job $RQ still pending 60 s after StartTime=now: $(active "$J2")"
wait_gone "$J2" 240 "the resumed point"
states=$(job_states "$J2")
grep -q 'JobState=COMPLETED' <<<"$states" || fail "resumed job $J2 did not complete: $states"
restarts=$(scontrol -o show job "$RQ" 2>/dev/null | grep -o 'Restarts=[0-9]*')

st=$(h5status "$R")
[ -e "$R" ] || fail "no $R after the resumed job ended (files: $(ls "$P2" | tr '\n' ' '))"
[ "$(cut -f2 <<<"$st")" = complete ] || fail "$R is not complete after the resume: $st"
resumes=$(cut -f3 <<<"$st")
[[ $resumes =~ ^[0-9]+$ ]] && [ "$resumes" -ge 1 ] ||
  fail "jamflow bug? $R is complete but its root attribute resumes = '$resumes' (expected >= 1: the point was continued from $R.part after TERM); $(grep -c . "${P2%/}/r0.log" 2>/dev/null) lines in r0.log"
pass "the resumed point finished: $R complete, resumes = $resumes ($restarts) after $(elapsed) s"

out=$("$JFC" sweep long.toml --out "$D2/out" --collect "$D2/table.csv" 2>&1) || fail "--collect exited $?: $out"
grep -q "table.csv: 1 of 1 points" <<<"$out" || fail "--collect of the long sweep printed: $out"
pass "--collect of the resumed sweep: 1 of 1 points"

say "$PASSED passed, 0 failed ($(elapsed) s)"
