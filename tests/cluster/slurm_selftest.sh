#!/usr/bin/env bash
# The SLURM profile (workflow/profiles/slurm) against a real single-node SLURM (issue 16).
#
#   bash tests/cluster/slurm_selftest.sh [--no-fault]
#
# 1. Installs slurm-wlm and munge with apt-get if they are missing (needs root, as in CI).
# 2. Starts a private SLURM in a temp dir: its own munge key and socket, slurm.conf (SLURM_CONF) with its own
#    ports, state, spool, pid and log files; no accounting daemon, so squeue is the status command and
#    MinJobAge keeps finished jobs visible to it for an hour. A SLURM already on the machine is never touched:
#    every client command here reads the private SLURM_CONF, and only the daemons started here are stopped.
# 3. Runs a small study (workflow/studies/cluster_selftest.yaml: 14 blind cases, 2 PSO seeds, the tables they
#    feed) through the profile in one fresh copy of the repository and with `-c2` in another, and compares
#    results/ byte for byte (logs excluded, as tests/workflow_util.tree_digest does).
# 4. Fault (unless --no-fault): cancels one running cluster job with scancel; the profile's `retries: 1`
#    must submit it again, and results/ must still be identical.
# 5. Stops exactly the daemons it started (by PID) and removes its temp dir, also on failure (trap).
# 6. Last line: jobs, cluster jobs after grouping, wall time, identical yes/no. Exit 0 only if identical.
#
# Python: $MRHYST_PYTHON, else the clone's .venv/bin/python (which .ci/run creates), else python3. It must
# import mrhyst and snakemake_executor_plugin_slurm (pip install -e '.[test]' or '.[slurm]').
# MRHYST_SELFTEST_TIMEOUT (seconds, default 1200) bounds the cluster run.
# MRHYST_SELFTEST_KEEP=1 keeps the temp dir (copies, daemon logs) for a look afterwards.
set -euo pipefail

FAULT=1
for arg in "$@"; do
  case $arg in
    --no-fault) FAULT=0 ;;
    -h|--help) sed -n '2,23p' "$0"; exit 0 ;;
    *) echo "slurm_selftest: unknown option '$arg' (known: --no-fault)" >&2; exit 2 ;;
  esac
done

ROOT=$(cd "$(dirname "$0")/../.." && pwd)
UTIL=$ROOT/tests/cluster/selftest_util.py
STUDY=workflow/studies/cluster_selftest.yaml
TARGETS=(blind tables)
T0=$(date +%s)
say() { echo "slurm_selftest: $*"; }
die() { echo "slurm_selftest: FAILED: $*" >&2; exit 1; }
mmss() { printf '%d min %02d s' $(($1 / 60)) $(($1 % 60)); }

# ---- Python and the SLURM packages -----------------------------------------------------------------------
if [ -n "${MRHYST_PYTHON:-}" ]; then PY=$MRHYST_PYTHON
elif [ -x "$ROOT/.venv/bin/python" ]; then PY=$ROOT/.venv/bin/python
else PY=python3
fi
PY=$(command -v "$PY") || die "no Python at '${MRHYST_PYTHON:-python3}'"
"$PY" -c 'import mrhyst, snakemake, snakemake_executor_plugin_slurm' 2>/dev/null \
  || die "$PY cannot import mrhyst, snakemake and snakemake_executor_plugin_slurm: pip install -e '.[slurm]'"
export PATH="$(dirname "$PY"):$PATH:/usr/sbin:/sbin" NUMBA_NUM_THREADS=1 MPLBACKEND=agg

SLURM_BINS=(munged slurmctld slurmd sbatch srun squeue scancel sinfo scontrol)
missing() { for b in "${SLURM_BINS[@]}"; do command -v "$b" >/dev/null || return 0; done; return 1; }
if missing; then
  [ "$(id -u)" = 0 ] || die "slurm-wlm and munge are not installed and this is not root: apt-get install slurm-wlm munge"
  say "installing slurm-wlm and munge (apt-get)"
  apt-get update -q -o DPkg::Lock::Timeout=600 >/dev/null
  DEBIAN_FRONTEND=noninteractive apt-get install -y -q -o DPkg::Lock::Timeout=600 slurm-wlm munge >/dev/null
  missing && die "apt-get install slurm-wlm munge left a command missing (${SLURM_BINS[*]})"
fi

# ---- the private SLURM -----------------------------------------------------------------------------------
TMP=$(mktemp -d "${TMPDIR:-/tmp}/mrhyst-slurm.XXXXXX")
DAEMONS=()      # "name:pid" of every daemon started here, in start order
SMK_PID=""      # the cluster run of Snakemake while it runs in the background
cleanup() {
  local rc=$? entry name pid i
  set +e
  trap - EXIT INT TERM
  if [ -n "$SMK_PID" ] && kill -0 "$SMK_PID" 2>/dev/null; then
    # SIGTERM: Snakemake submits nothing more but waits for its running jobs, so cancel them; it notices at
    # its next status check. Whatever is still there after 30 s is killed.
    kill -TERM "$SMK_PID"
    for _ in $(seq 30); do
      squeue -h -o %i 2>/dev/null | xargs -r scancel 2>/dev/null
      kill -0 "$SMK_PID" 2>/dev/null || break
      sleep 1
    done
    kill -0 "$SMK_PID" 2>/dev/null && kill -KILL "$SMK_PID"
    wait "$SMK_PID" 2>/dev/null
  fi
  if [ ${#DAEMONS[@]} -gt 0 ] && [ -f "${SLURM_CONF:-}" ]; then
    # jobs left in the private cluster (after a failure): cancel them so no slurmstepd outlives slurmd
    squeue -h -o %i 2>/dev/null | xargs -r scancel 2>/dev/null
    for _ in $(seq 30); do [ -z "$(squeue -h -o %i 2>/dev/null)" ] && break; sleep 1; done
  fi
  for ((i = ${#DAEMONS[@]} - 1; i >= 0; i--)); do        # slurmd, slurmctld, munged: reverse start order
    entry=${DAEMONS[$i]}; name=${entry%%:*}; pid=${entry#*:}
    kill -TERM "$pid" 2>/dev/null
    for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.2; done
    kill -0 "$pid" 2>/dev/null && { say "$name ($pid) ignored SIGTERM: SIGKILL"; kill -KILL "$pid"; }
    wait "$pid" 2>/dev/null
  done
  if [ "$rc" != 0 ] && [ -d "$TMP/log" ]; then
    for f in "$TMP"/log/*.log; do echo "--- last lines of $f" >&2; tail -n 15 "$f" >&2; done
  fi
  if [ "${MRHYST_SELFTEST_KEEP:-0}" = 1 ]; then say "kept $TMP"; else rm -rf "$TMP"; fi
  exit "$rc"
}
trap cleanup EXIT
trap 'exit 130' INT TERM

mkdir -p "$TMP"/{etc,munge,state,spool,run,log}
chmod 700 "$TMP"/munge
export SLURM_CONF=$TMP/etc/slurm.conf
SOCK=$TMP/munge/munge.socket
PORTS=($("$PY" "$UTIL" ports 2)); CTLD_PORT=${PORTS[0]}; SLURMD_PORT=${PORTS[1]}
NODE_LINE=$(slurmd -C | head -n 1)    # "NodeName=HOST CPUs=.. ... RealMemory=..": this machine as it is
HOST=$(hostname -s)
cat > "$SLURM_CONF" <<EOF
# private single-node SLURM of tests/cluster/slurm_selftest.sh; everything under $TMP
ClusterName=mrhystselftest
SlurmctldHost=$HOST(127.0.0.1)
SlurmctldPort=$CTLD_PORT
SlurmdPort=$SLURMD_PORT
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$SOCK
StateSaveLocation=$TMP/state
SlurmdSpoolDir=$TMP/spool
SlurmctldPidFile=$TMP/run/slurmctld.pid
SlurmdPidFile=$TMP/run/slurmd.pid
SlurmctldLogFile=$TMP/log/slurmctld.log
SlurmdLogFile=$TMP/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
MpiDefault=none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MailProg=/bin/true
# no accounting daemon: squeue is the status command, and it sees a finished job for MinJobAge seconds
MinJobAge=3600
$NODE_LINE NodeAddr=127.0.0.1 State=UNKNOWN
PartitionName=selftest Nodes=ALL Default=YES MaxTime=INFINITE State=UP
EOF

dd if=/dev/urandom of="$TMP/etc/munge.key" bs=1024 count=1 status=none
chmod 400 "$TMP/etc/munge.key"
munged -F --force --key-file="$TMP/etc/munge.key" --socket="$SOCK" --pid-file="$TMP/run/munged.pid" \
  --log-file="$TMP/log/munged.log" --seed-file="$TMP/munge/munged.seed" >>"$TMP/log/munged.log" 2>&1 &
DAEMONS+=("munged:$!")
for _ in $(seq 50); do [ -S "$SOCK" ] && break; sleep 0.2; done
[ -S "$SOCK" ] || die "munged did not open $SOCK"

slurmctld -D -c -f "$SLURM_CONF" >>"$TMP/log/slurmctld.out" 2>&1 &
DAEMONS+=("slurmctld:$!")
for _ in $(seq 60); do scontrol ping 2>/dev/null | grep -q UP && break; sleep 0.5; done
scontrol ping | grep -q UP || die "slurmctld did not come up on port $CTLD_PORT"

slurmd -D -f "$SLURM_CONF" -N "$HOST" >>"$TMP/log/slurmd.out" 2>&1 &
DAEMONS+=("slurmd:$!")
for _ in $(seq 60); do [ "$(sinfo -h -o %t 2>/dev/null)" = idle ] && break; sleep 0.5; done
[ "$(sinfo -h -o %t)" = idle ] || die "node $HOST is not idle: $(sinfo -h -o '%t %E')"
# Inside a job, the slurm-jobstep plugin starts the rule with `srun`, but first drops every SLURM_* variable
# but the job's identity, SLURM_CONF too (the plugin's issue 164): that srun would look for /etc/slurm and
# fail. A cluster keeps its slurm.conf there; this private one puts a shim first on the jobs' PATH that
# gives srun its SLURM_CONF back.
mkdir -p "$TMP/bin"
printf '#!/bin/sh\nSLURM_CONF=%s exec %s "$@"\n' "$SLURM_CONF" "$(command -v srun)" >"$TMP/bin/srun"
chmod +x "$TMP/bin/srun"
say "private SLURM up: $TMP (slurmctld :$CTLD_PORT, slurmd :$SLURMD_PORT, ${DAEMONS[*]})"

# ---- the study on one machine (-c2) and through the profile ----------------------------------------------
"$PY" "$UTIL" copy "$TMP/local"
"$PY" "$UTIL" copy "$TMP/cluster"
say "local run: snakemake -c2 ${TARGETS[*]} --configfile $STUDY"
t=$(date +%s)
(cd "$TMP/local" && "$PY" -m snakemake -c2 "${TARGETS[@]}" --configfile "$STUDY" >"$TMP/local.log" 2>&1) \
  || { tail -n 30 "$TMP/local.log" >&2; die "the local run failed"; }
T_LOCAL=$(($(date +%s) - t))

# The profile as a user runs it, plus the status command of a cluster without accounting and, for a test of
# a few minutes, a first status check after 5 s instead of 40 s (the plugin then polls every 5 s while jobs
# finish).
say "cluster run: snakemake ${TARGETS[*]} --profile workflow/profiles/slurm --configfile $STUDY --slurm-status-command squeue"
t=$(date +%s)
(cd "$TMP/cluster" && PATH="$TMP/bin:$PATH" exec "$PY" -m snakemake "${TARGETS[@]}" --profile workflow/profiles/slurm \
  --configfile "$STUDY" --slurm-status-command squeue --slurm-init-seconds-before-status-checks 5 \
  >"$TMP/cluster.log" 2>&1) &
SMK_PID=$!

# Wait for it, within MRHYST_SELFTEST_TIMEOUT seconds. Fault: once a fit job has run for 3 s (it is then in its
# own Snakemake, mid-rule), scancel it. A job that ends before the scancel lands is COMPLETED, not CANCELLED:
# then the next one.
CANCELLED=""
SCANCELLED=()   # every job id scancel was sent to
deadline=$(($(date +%s) + ${MRHYST_SELFTEST_TIMEOUT:-1200}))
while kill -0 "$SMK_PID" 2>/dev/null; do
  [ "$(date +%s)" -lt "$deadline" ] || die "the cluster run took longer than ${MRHYST_SELFTEST_TIMEOUT:-1200} s"
  if [ "$FAULT" = 1 ] && [ -z "$CANCELLED" ]; then
    line=$(squeue -h -t RUNNING -o '%i|%M|%k' | awk -F'|' '$2 !~ /^0:0[0-2]$/ && $3 ~ /^rule_fit_/' | head -n 1 || true)
    if [ -n "$line" ]; then
      id=${line%%|*}
      scancel "$id" 2>/dev/null || true
      # Wait for the job's final state: under load it stays RUNNING/COMPLETING for seconds after scancel
      # (CI once saw two jobs cancelled while a 1 s look still read RUNNING; both were then counted as
      # failures). Every job scancelled here is recorded, whatever state it ends in.
      state=""
      for _ in $(seq 120); do
        state=$(squeue -h --states=all -j "$id" -o %T 2>/dev/null || true)
        case $state in RUNNING|COMPLETING|CONFIGURING|PENDING|"") sleep 0.5 ;; *) break ;; esac
      done
      SCANCELLED+=("$id")
      if [ "$state" = CANCELLED ]; then
        CANCELLED="$id|${line##*|}"
        t_run=${line#*|}; say "fault: scancel $id (${line##*|}) after ${t_run%%|*} of running"
      else
        say "fault: scancel $id came too late (it ended $state): the next fit job"
      fi
    fi
  fi
  sleep 0.5
done
rc=0; wait "$SMK_PID" || rc=$?
SMK_PID=""
T_CLUSTER=$(($(date +%s) - t))
[ "$rc" = 0 ] || { tail -n 40 "$TMP/cluster.log" >&2; die "the cluster run exited $rc"; }

# What SLURM ran (finished jobs stay listed for MinJobAge): one line per cluster job; the comment names the rule.
squeue -h --states=all -o '%i|%T|%C|%m|%l|%k' | sort -n >"$TMP/slurm_jobs.txt"
N_CLUSTER=$(wc -l <"$TMP/slurm_jobs.txt")
N_JOBS=$("$PY" "$UTIL" jobs "$TMP/cluster.log")
# Not COMPLETED is a failure, except a job this script scancelled (its rerun is checked below).
EXPECTED_CANCELLED=$(for i in "${SCANCELLED[@]}"; do echo "^$i|CANCELLED|"; done)
grep -v '|COMPLETED|' "$TMP/slurm_jobs.txt" | { if [ -n "$EXPECTED_CANCELLED" ]; then grep -v -f <(echo "$EXPECTED_CANCELLED"); else cat; fi; } >&2 \
  && die "cluster jobs that did not complete (above)"
# Every cluster job, the bundle of blind cases too, asks for one CPU (profile: cores: 1), not one per case.
awk -F'|' '$3 != 1' "$TMP/slurm_jobs.txt" | grep . >&2 && die "cluster jobs that ask for more than one CPU (above)"
RERUN=""
if [ "$FAULT" = 1 ]; then
  [ -n "$CANCELLED" ] || die "fault: no fit job was running long enough to cancel"
  comment=${CANCELLED#*|}
  n=$(awk -F'|' -v c="$comment" '$6 == c && $2 == "COMPLETED"' "$TMP/slurm_jobs.txt" | wc -l)
  [ "$n" = 1 ] || die "fault: $comment was cancelled and not rerun to completion (retries: 1)"
  # every scancelled job that ended CANCELLED must have its rerun COMPLETED, too
  NRERUN=0
  for i in "${SCANCELLED[@]}"; do
    c=$(awk -F'|' -v i="$i" '$1 == i && $2 == "CANCELLED" {print $6}' "$TMP/slurm_jobs.txt")
    [ -z "$c" ] && continue
    awk -F'|' -v c="$c" '$6 == c && $2 == "COMPLETED"' "$TMP/slurm_jobs.txt" | grep -q . \
      || die "fault: $c (job $i) was cancelled and not rerun to completion (retries: 1)"
    N_CLUSTER=$((N_CLUSTER - 1)); NRERUN=$((NRERUN + 1))
  done
  RERUN=" (+$NRERUN: $comment cancelled, rerun by retries: 1)"
fi

"$PY" "$UTIL" compare "$TMP/local" "$TMP/cluster" && SAME=yes || SAME=no
WALL=$(($(date +%s) - T0))
say "cluster jobs as SLURM lists them (id|state|cpus|memory|time limit|comment):"
sed 's/^/    /' "$TMP/slurm_jobs.txt"
say "cluster run $(mmss "$T_CLUSTER"), local -c2 run $(mmss "$T_LOCAL")"
echo "slurm selftest: $N_JOBS jobs, $N_CLUSTER cluster jobs after grouping$RERUN, wall $(mmss "$WALL"), identical $SAME"
[ "$SAME" = yes ]
