#!/usr/bin/env bash
# `make cluster-batch` on a real SLURM cluster: a single-node one stood up on this (Debian) machine --
# munge, MariaDB + slurmdbd (accounting: sacct answers), slurmctld and slurmd on 127.0.0.1 -- running the
# shipped profile (pipelines/profiles/slurm, its partition and account set as a lab sets them) over the
# fixture sessions plus a corrupt one. Checked:
#   - the profile's placeholders are refused in one line before anything is submitted;
#   - one SLURM job per session; outputs equal to the local `make batch` within 1e-9;
#   - the corrupt session refused with its error line, retried once as a new job with twice the memory;
#   - a scancel'led job noticed (one line) and resubmitted; a sbatch refusal shown with sbatch's words;
#   - a rerun submits nothing; a changed raw file resubmits only its session;
#   - a run stopped by Ctrl-C writes a summary that does not call the stopped session ok;
#   - a killed run's lock refused in one line, removed by UNLOCK=1; exit status 0 when all are ok.
#
#   bash pipelines/slurm/test-slurm.sh          (or: make slurm-test)
#
# Needs root and Debian's packages (slurm-wlm slurmdbd munge mariadb-server, installed when missing).
# Where that is impossible (not root, no apt, packages unreachable, a SLURM already configured here) it
# says why and exits 0: skipped. A failed check exits 1. Everything it started is stopped and everything
# it wrote is removed on exit, failure included (SLURM_TEST_KEEP=1 keeps its folder with the logs).
# About 10 minutes on 2 cores shared with other work (10.4 min measured at a load of ~11).
set -euo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
cd "$ROOT"
PY="$ROOT/.venv/bin/python"
say() { echo "slurm-test: $*"; }
skip() { say "skipped: $*"; exit 0; }
fail() { say "FAILED: $*"; exit 1; }
elapsed() { echo $(( $(date +%s) - $1 )); }

# ------------------------------------------------------------------------------------------ can it run?
[ "$(uname -s)" = Linux ] || skip "not Linux"
[ "$(id -u)" = 0 ] || skip "needs root (it installs Debian packages and starts SLURM's daemons)"
command -v apt-get > /dev/null || skip "not a Debian machine (no apt-get)"
for d in slurmctld slurmd slurmdbd; do
  ! pgrep -x "$d" > /dev/null || skip "a $d runs here already: not touching a live SLURM"
done
[ ! -e /etc/slurm/slurm.conf ] || skip "/etc/slurm/slurm.conf exists (a configured SLURM): not touching it"
[ ! -e /etc/slurm/slurmdbd.conf ] || skip "/etc/slurm/slurmdbd.conf exists (a configured SLURM): not touching it"

D=$(mktemp -d /tmp/sportfusion-slurm.XXXXXX)
mkdir -p "$D/log" "$D/spool/ctld" "$D/spool/d"
WROTE_CONF=
OWN_MUNGE=
BG=
stop_pidfile() {  # stop the daemon whose pid file this test told it to write
  [ -s "$1" ] || return 0
  local p
  p=$(cat "$1")
  kill "$p" 2> /dev/null || return 0
  for _ in $(seq 50); do kill -0 "$p" 2> /dev/null || return 0; sleep 0.2; done
  kill -9 "$p" 2> /dev/null || true
}
cleanup() {
  local rc=$?
  set +e
  if [ -n "$BG" ]; then  # a cluster-batch still running: Ctrl-C its engine (it cancels its jobs), then make
    kill -INT -- "-$BG" 2> /dev/null
    for _ in $(seq 40); do kill -0 "$BG" 2> /dev/null || break; sleep 0.5; done
    kill -- "-$BG" 2> /dev/null
  fi
  if [ -s "$D/slurmctld.pid" ]; then
    scancel --full --user=root 2> /dev/null
    for _ in $(seq 40); do [ -z "$(squeue -h -o %i 2> /dev/null)" ] && break; sleep 0.5; done
  fi
  for d in slurmd slurmctld slurmdbd mariadb; do stop_pidfile "$D/$d.pid"; done
  [ -z "$OWN_MUNGE" ] || stop_pidfile "$D/munged.pid"
  [ -z "$WROTE_CONF" ] || rm -f /etc/slurm/slurm.conf /etc/slurm/slurmdbd.conf
  if [ -n "${SLURM_TEST_KEEP:-}" ]; then say "kept $D"; else rm -rf "$D"; fi
  exit "$rc"
}
trap cleanup EXIT
trap 'exit 130' INT TERM

need=()
for pair in slurmctld:slurm-wlm slurmd:slurm-wlm sbatch:slurm-client slurmdbd:slurmdbd munged:munge \
  mariadbd:mariadb-server; do
  command -v "${pair%%:*}" > /dev/null || [[ " ${need[*]} " == *" ${pair#*:} "* ]] || need+=("${pair#*:}")
done
if [ "${#need[@]}" -gt 0 ]; then
  say "installing Debian's ${need[*]}, about a minute"
  if ! { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
    "${need[@]}"; } > "$D/log/apt.log" 2>&1; then
    skip "Debian packages not reachable (apt-get: $(tail -n 1 "$D/log/apt.log" | cut -c1-200))"
  fi
fi
if [ ! -x "$ROOT/.venv/bin/snakemake" ]; then
  say "setting up .venv (make .venv/.installed)"
  make --no-print-directory .venv/.installed > "$D/log/venv.log" 2>&1 || fail "make .venv/.installed: $(tail -n 1 "$D/log/venv.log")"
fi

# ------------------------------------------------------------------------------------------ the cluster
T0=$(date +%s)
free_port() {  # the first port from $1 on that nothing listens on
  local p=$1
  while (exec 3<> "/dev/tcp/127.0.0.1/$p") 2> /dev/null; do p=$((p + 1)); done
  echo "$p"
}
DB_PORT=$(free_port 23306)
DBD_PORT=$(free_port 26819)
CTLD_PORT=$(free_port 26817)
SLURMD_PORT=$(free_port 26828)
HOST=$(hostname -s)
CPUS=$(nproc)
MEM=$(slurmd -C | sed -n 's/.*RealMemory=\([0-9]*\).*/\1/p')
PARTITION=batch
ACCOUNT=sportlab

# munge: the machine's own when one answers, else ours (the socket SLURM looks for by default)
if ! munge -n 2> /dev/null | unmunge > /dev/null 2>&1; then
  [ -s /etc/munge/munge.key ] || fail "no /etc/munge/munge.key (the munge package makes one)"
  mkdir -p /run/munge
  munged --force --num-threads=10 --pid-file="$D/munged.pid" --log-file="$D/log/munged.log" \
    --seed-file="$D/munged.seed" || fail "munged did not start: $(tail -n 1 "$D/log/munged.log")"
  OWN_MUNGE=1
fi

# MariaDB for slurmdbd: a private server in $D on a free port
mariadb-install-db --no-defaults --datadir="$D/db" --user=root --auth-root-authentication-method=normal \
  --skip-test-db > "$D/log/mariadb-install.log" 2>&1 || fail "mariadb-install-db: $(tail -n 1 "$D/log/mariadb-install.log")"
mariadbd --no-defaults --datadir="$D/db" --user=root --socket="$D/mysql.sock" --port="$DB_PORT" \
  --bind-address=127.0.0.1 --pid-file="$D/mariadb.pid" --log-error="$D/log/mariadb.log" \
  --innodb-buffer-pool-size=32M --skip-name-resolve > /dev/null 2>&1 &
for _ in $(seq 60); do mariadb-admin --no-defaults -S "$D/mysql.sock" -u root ping > /dev/null 2>&1 && break; sleep 0.5; done
mariadb-admin --no-defaults -S "$D/mysql.sock" -u root ping > /dev/null 2>&1 || fail "MariaDB did not start: $(tail -n 1 "$D/log/mariadb.log")"

# slurm.conf where srun inside a job looks for it (the SLURM plugin's job step drops SLURM_CONF)
mkdir -p /etc/slurm
WROTE_CONF=1
cat > /etc/slurm/slurm.conf << EOF
# written by sportfusion's pipelines/slurm/test-slurm.sh (removed when it ends)
ClusterName=sportfusion-ci
SlurmctldHost=$HOST(127.0.0.1)
SlurmctldPort=$CTLD_PORT
SlurmdPort=$SLURMD_PORT
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
StateSaveLocation=$D/spool/ctld
SlurmdSpoolDir=$D/spool/d
SlurmctldPidFile=$D/slurmctld.pid
SlurmdPidFile=$D/slurmd.pid
SlurmctldLogFile=$D/log/slurmctld.log
SlurmdLogFile=$D/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
MpiDefault=none
MailProg=/bin/true
ReturnToService=2
AccountingStorageType=accounting_storage/slurmdbd
AccountingStorageHost=localhost
AccountingStoragePort=$DBD_PORT
AccountingStorageEnforce=associations
EnforcePartLimits=ALL
JobCompType=jobcomp/none
NodeName=$HOST NodeAddr=127.0.0.1 CPUs=$CPUS RealMemory=$MEM State=UNKNOWN
PartitionName=$PARTITION Nodes=$HOST Default=YES MaxTime=INFINITE State=UP
EOF
cat > /etc/slurm/slurmdbd.conf << EOF
AuthType=auth/munge
DbdHost=localhost
DbdPort=$DBD_PORT
SlurmUser=root
LogFile=$D/log/slurmdbd.log
PidFile=$D/slurmdbd.pid
StorageType=accounting_storage/mysql
StorageHost=127.0.0.1
StoragePort=$DB_PORT
StorageUser=root
StorageLoc=sportfusion_ci_acct
EOF
chmod 600 /etc/slurm/slurmdbd.conf

wait_for() {  # seconds, what, command...
  local n=$1 what=$2
  shift 2
  for _ in $(seq $((n * 2))); do "$@" > /dev/null 2>&1 && return 0; sleep 0.5; done
  fail "$what did not come up in $n s (logs: $D/log)"
}
slurmdbd || fail "slurmdbd did not start: $(tail -n 1 "$D/log/slurmdbd.log")"
wait_for 60 slurmdbd sacctmgr -n list cluster
slurmctld || fail "slurmctld did not start: $(tail -n 1 "$D/log/slurmctld.log")"
wait_for 60 slurmctld scontrol ping
slurmd || fail "slurmd did not start: $(tail -n 1 "$D/log/slurmd.log")"
node_idle() { [ "$(sinfo -h -n "$HOST" -o %T)" = idle ]; }
wait_for 60 "node $HOST" node_idle
sacctmgr -i add account "$ACCOUNT" Description=ci Organization=ci > /dev/null
sacctmgr -i add user root Account="$ACCOUNT" > /dev/null
say "single-node SLURM $(sinfo --version | cut -d' ' -f2) up in $(elapsed "$T0") s: partition $PARTITION, account $ACCOUNT, $CPUS CPUs, $MEM MB"

# ------------------------------------------------------------------------------------------ the batch
S="$D/sessions"
mkdir -p "$S"
for s in skijump skirace gates climbing; do cp -r "fixtures/$s" "$S/$s"; done
cp -r fixtures/climbing "$S/corrupt"
echo "this is not a recording" > "$S/corrupt/session.parquet"
PROFILE="$D/profile"
mkdir -p "$PROFILE"
sed -e "s/slurm_partition: \"normal\"/slurm_partition: \"$PARTITION\"/" \
  -e "s/slurm_account: \"your_account\"/slurm_account: \"$ACCOUNT\"/" pipelines/profiles/slurm/config.yaml > "$PROFILE/config.yaml"
grep -q "slurm_account: \"$ACCOUNT\"" "$PROFILE/config.yaml" || fail "the shipped profile's account placeholder moved"
OUT="$D/slurm-out"
CB=(make --no-print-directory cluster-batch SESSIONS="$S" BATCH="$OUT" PROFILE="$PROFILE")
cb() { "${CB[@]}" "$@"; }
submitted() { [ -e "$1" ] || return 0; sed -n 's/.*submitted with SLURM jobid \([0-9]*\) (log: .*rule_session\/\([^/]*\)\/.*/\2 \1/p' "$1"; }
jobs_of() { submitted "$1" | awk -v s="$2" '$1 == s {print $2}' | tr '\n' ' '; }
sacct_of() { sacct -X -n -P -o State,ReqMem -j "$1" | head -n 1; }
mem_of() { sacct_of "$1" | sed 's/.*|\([0-9]*\).*/\1/'; }
running_job() {  # $1: log, $2: session; the job id once that session's job runs
  local j=
  for _ in $(seq 240); do
    j=$(jobs_of "$1" "$2")
    [ -n "$j" ] && [ "$(squeue -h -j "${j%% *}" -o %T 2> /dev/null)" = RUNNING ] && break
    sleep 0.5
  done
  echo "${j%% *}"
}

# 1. the shipped profile as it is: its placeholders refused before anything is submitted
t=$(date +%s)
if make --no-print-directory cluster-batch SESSIONS="$S" BATCH="$OUT" PROFILE=pipelines/profiles/slurm > "$D/log/placeholder.log" 2>&1; then
  fail "the profile's placeholder partition was accepted"
fi
grep -q "^Error: cluster-batch: partition 'normal' (slurm_partition in " "$D/log/placeholder.log" || fail "no one-line partition error: $(head -n 3 "$D/log/placeholder.log")"
[ -z "$(sacct -X -n -o JobID)" ] || fail "jobs were submitted with the placeholder profile"
say "ok: the placeholder profile refused in $(elapsed "$t") s: $(grep '^Error' "$D/log/placeholder.log")"

# 2. the reference: the same sessions with make on this machine
t=$(date +%s)
make --no-print-directory batch SESSIONS="$S" BATCH="$D/local-out" JOBS="$CPUS" > "$D/log/local.log" 2>&1 && fail "make batch: the corrupt session did not fail"
LOCAL_S=$(elapsed "$t")
say "ok: make batch (local, -j $CPUS) in $LOCAL_S s"

# 3. the cluster run; the ski-jump job cancelled while it runs
t=$(date +%s)
set -m  # its own process group, SIGINT not ignored (as a Ctrl-C in a terminal reaches it)
"${CB[@]}" > "$D/log/run1.log" 2>&1 &
BG=$!
set +m
jid=$(running_job "$D/log/run1.log" skijump)
[ -n "$jid" ] || fail "the ski-jump session was never submitted: $(tail -n 3 "$D/log/run1.log")"
sleep 2
scancel "$jid"
rc=0
wait "$BG" || rc=$?
BG=
RUN1_S=$(elapsed "$t")
say "make cluster-batch: $RUN1_S s (5 sessions; one job cancelled and resubmitted, the corrupt one retried)"
[ "$rc" = 2 ] || fail "first cluster run: exit status $rc, expected 2 (one failed session): $(tail -n 5 "$D/log/run1.log")"
grep -q "^cluster-batch: 1 session(s) failed" "$D/log/run1.log" || fail "no 'cluster-batch: 1 session(s) failed' line"
grep -q "^cluster-batch: skijump: SLURM job $jid ended CANCELLED" "$D/log/run1.log" || fail "the cancelled job $jid was not reported: $(grep cluster-batch "$D/log/run1.log")"
say "ok: scancel $jid noticed: $(grep "SLURM job $jid ended" "$D/log/run1.log")"
for s in climbing gates skirace; do
  j=$(jobs_of "$D/log/run1.log" $s)
  [ "$(echo $j | wc -w)" = 1 ] || fail "$s: SLURM jobs '$j', expected one"
  [ "$(sacct_of $j | cut -d'|' -f1)" = COMPLETED ] || fail "$s: job $j $(sacct_of $j)"
done
read -r j1 j2 rest <<< "$(jobs_of "$D/log/run1.log" skijump)"
[ -n "$j2" ] && [ -z "$rest" ] || fail "skijump: jobs '$j1 $j2 $rest', expected the cancelled one and its resubmission"
[[ "$(sacct_of "$j1")" == CANCELLED* ]] && [[ "$(sacct_of "$j2")" == COMPLETED* ]] || fail "skijump: $j1 $(sacct_of "$j1"), $j2 $(sacct_of "$j2")"
[ "$(mem_of "$j2")" = $((2 * $(mem_of "$j1"))) ] || fail "skijump: resubmitted with $(mem_of "$j2") MB after $(mem_of "$j1") MB, expected twice"
read -r c1 c2 rest <<< "$(jobs_of "$D/log/run1.log" corrupt)"
[ -n "$c2" ] && [ -z "$rest" ] || fail "corrupt: jobs '$c1 $c2 $rest', expected two (one retry)"
[[ "$(sacct_of "$c1")" == FAILED* ]] || fail "corrupt: first job $c1 $(sacct_of "$c1"), expected FAILED"
[ "$(mem_of "$c2")" = $((2 * $(mem_of "$c1"))) ] || fail "corrupt: retried with $(mem_of "$c2") MB after $(mem_of "$c1") MB, expected twice"
say "ok: one job per session (climbing gates skirace), skijump resubmitted $j1 -> $j2 and corrupt retried $c1 -> $c2 as new jobs with twice the memory ($(mem_of "$c1") -> $(mem_of "$c2") MB)"

"$PY" - "$D/local-out" "$OUT" << 'EOF' || fail "the cluster's outputs differ from make batch's"
import sys
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

local, cluster = Path(sys.argv[1]), Path(sys.argv[2])
worst, n = 0.0, 0
for name in ("climbing", "gates", "skijump", "skirace"):
    files = sorted(p.relative_to(local) for p in (local / name).rglob("*.parquet"))
    assert files, name
    for rel in files:
        a, b = pq.read_table(local / rel), pq.read_table(cluster / rel)
        assert a.column_names == b.column_names and a.num_rows == b.num_rows, rel
        for col in a.column_names:
            x, y = a.column(col), b.column(col)
            if pa.types.is_floating(x.type) or pa.types.is_integer(x.type):
                x, y = x.to_numpy(zero_copy_only=False).astype(float), y.to_numpy(zero_copy_only=False).astype(float)
                assert np.array_equal(np.isnan(x), np.isnan(y)), (rel, col)
                d = float(np.nanmax(np.abs(x - y), initial=0.0))
                assert d <= 1e-9, (rel, col, d)
                worst = max(worst, d)
            else:
                assert x.equals(y), (rel, col)
        n += 1
rows = {r["session"]: r for r in pq.read_table(cluster / "summary.parquet").to_pylist()}
assert [s for s, r in rows.items() if r["status"] == "ok"] == ["climbing", "gates", "skijump", "skirace"], rows
assert rows["corrupt"]["status"] == "failed" and rows["corrupt"]["error"].startswith("Error: detect-events:"), rows["corrupt"]
print(f"slurm-test: ok: {n} result tables equal to make batch's (largest difference {worst:.1e}); corrupt refused: {rows['corrupt']['error']}")
EOF

# 4. a rerun submits nothing
t=$(date +%s)
rc=0
cb > "$D/log/run2.log" 2>&1 || rc=$?
[ "$rc" = 2 ] || fail "rerun: exit status $rc, expected 2 (the corrupt session still failed)"
[ -z "$(submitted "$D/log/run2.log")" ] || fail "rerun submitted jobs: $(submitted "$D/log/run2.log")"
say "ok: a rerun submits nothing ($(elapsed "$t") s)"

# 5. a changed raw file resubmits its session only
printf '\n' >> "$S/skirace/raw/gnss.nmea"
t=$(date +%s)
rc=0
cb > "$D/log/run3.log" 2>&1 || rc=$?
RUN3_S=$(elapsed "$t")
[ "$rc" = 2 ] || fail "changed-file rerun: exit status $rc, expected 2"
[ "$(submitted "$D/log/run3.log" | cut -d' ' -f1 | tr '\n' ' ')" = "skirace " ] || fail "a changed skirace file submitted: $(submitted "$D/log/run3.log")"
t=$(date +%s)
make --no-print-directory batch SESSIONS="$S" BATCH="$D/local-out" JOBS="$CPUS" > "$D/log/local3.log" 2>&1 || true
LOCAL3_S=$(elapsed "$t")
say "ok: a changed skirace file resubmitted skirace only: $RUN3_S s (make batch: $LOCAL3_S s)"

# 6. every session ok: exit status 0
mv "$S/corrupt" "$D/corrupt-away"
rc=0
cb > "$D/log/run4.log" 2>&1 || rc=$?
[ "$rc" = 0 ] || fail "all sessions ok, yet exit status $rc: $(tail -n 3 "$D/log/run4.log")"
grep -q "^4 of 4 sessions ok, 0 failed" "$OUT/summary.txt" || fail "summary: $(tail -n 2 "$OUT/summary.txt")"
say "ok: all sessions ok: exit status 0"

# 7. Ctrl-C during a rerun: the summary written then does not call the stopped session ok
printf '\n' >> "$S/gates/raw/$(ls "$S/gates/raw" | head -n 1)"
set -m  # its own process group, SIGINT not ignored (as a Ctrl-C in a terminal reaches it)
"${CB[@]}" > "$D/log/run5.log" 2>&1 &
BG=$!
set +m
jid=$(running_job "$D/log/run5.log" gates)
[ -n "$jid" ] || fail "the gates session was never submitted: $(tail -n 3 "$D/log/run5.log")"
kill -INT -- "-$BG"  # Ctrl-C: to make and the engine, as a terminal sends it
rc=0
wait "$BG" || rc=$?
BG=
[ "$rc" != 0 ] || fail "a run stopped by Ctrl-C exited 0"
grep -q "^gates .* failed" "$OUT/summary.txt" || fail "after Ctrl-C the summary says: $(grep '^gates' "$OUT/summary.txt")"
grep -q "FAILED gates: not finished" "$OUT/summary.txt" || fail "after Ctrl-C: $(grep 'FAILED gates' "$OUT/summary.txt")"
say "ok: Ctrl-C: job $jid $(sacct_of "$jid" | cut -d'|' -f1); the summary says $(grep 'FAILED gates' "$OUT/summary.txt" | sed 's/^ *//')"

# 8. a killed run leaves its lock: refused in one line, UNLOCK=1 removes it, the run completes
set -m  # its own process group, SIGINT not ignored (as a Ctrl-C in a terminal reaches it)
"${CB[@]}" > "$D/log/run6.log" 2>&1 &
BG=$!
set +m
jid=$(running_job "$D/log/run6.log" gates)
[ -n "$jid" ] || fail "the gates session was never resubmitted"
engine=$(pgrep -P "$BG" -f snakemake || true)
[ -n "$engine" ] || fail "no snakemake under make (pid $BG)"
kill -9 "$engine"
wait "$BG" || true
BG=
scancel "$jid"
rc=0
cb > "$D/log/run7.log" 2>&1 || rc=$?
[ "$rc" = 2 ] && grep -q "^cluster-batch: .* is locked: .*make cluster-batch UNLOCK=1" "$D/log/run7.log" \
  || fail "a killed run's lock: exit status $rc, $(tail -n 2 "$D/log/run7.log")"
say "ok: the lock refused: $(grep '^cluster-batch' "$D/log/run7.log" | cut -c1-100)..."
rc=0
cb UNLOCK=1 > "$D/log/run8.log" 2>&1 || rc=$?
[ "$rc" = 0 ] || fail "UNLOCK=1: exit status $rc: $(tail -n 3 "$D/log/run8.log")"
[ "$(submitted "$D/log/run8.log" | cut -d' ' -f1)" = gates ] || fail "UNLOCK=1 submitted: $(submitted "$D/log/run8.log")"
grep -q "^4 of 4 sessions ok, 0 failed" "$OUT/summary.txt" || fail "after UNLOCK=1: $(tail -n 1 "$OUT/summary.txt")"
say "ok: UNLOCK=1 removed the lock, gates rerun, all ok, exit status 0"

# 9. a submission the scheduler refuses: sbatch's own words (the profile check passes, sbatch does not)
mkdir -p "$D/profile-feature" "$D/one"
sed -e 's/^\(  cpus_per_task: 1 .*\)$/\1\n  constraint: "no_such_feature"/' "$PROFILE/config.yaml" > "$D/profile-feature/config.yaml"
grep -q 'constraint: "no_such_feature"' "$D/profile-feature/config.yaml" || fail "could not add a constraint to the profile"
cp -r "$S/climbing" "$D/one/climbing"
rc=0
make --no-print-directory cluster-batch SESSIONS="$D/one" BATCH="$D/feature-out" PROFILE="$D/profile-feature" > "$D/log/run9.log" 2>&1 || rc=$?
[ "$rc" != 0 ] || fail "a job asking for a feature no node has was accepted"
grep -q "^cluster-batch: climbing: sbatch refused the job: sbatch: error: " "$D/log/run9.log" || fail "sbatch's refusal not shown: $(grep -i error "$D/log/run9.log" | head -n 3)"
grep -q "FAILED climbing: sbatch refused the job" "$D/feature-out/summary.txt" || fail "the summary lacks sbatch's words: $(tail -n 1 "$D/feature-out/summary.txt")"
say "ok: $(grep -m1 '^cluster-batch: climbing: sbatch' "$D/log/run9.log")"

say "passed in $(elapsed "$T0") s; 5 sessions: make batch $LOCAL_S s, make cluster-batch $RUN1_S s; one changed session: make batch $LOCAL3_S s, make cluster-batch $RUN3_S s"
