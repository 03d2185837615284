#!/usr/bin/env bash
# The cluster test (issue 20): a real single-node Slurm cluster on this machine runs rectify and
# stereo-batch as job arrays of 4 shards over 40 simulated pairs, each followed by its merge
# job (--dependency=afterok), through scripts/cluster/submit-slurm; the merged outputs must be
# byte-identical to a one-machine run (timings aside). Then a shard's summary and some of its
# pairs are deleted (as a killed task leaves them), shard-merge must find the set incomplete,
# and the shard resubmitted alone (--resubmit 2, --shard auto/4 --resume) must complete it.
#
#   tests/cluster/slurm_test.sh BIN_DIR COMPARE_RUNS SCRIPTS_CLUSTER_DIR
#
# Installs Debian's slurm-wlm and munge when missing (apt-get, idempotent; needs root or sudo),
# starts munged (a key made on the spot), slurmctld and slurmd (one node, one partition,
# proctrack/linuxproc, task/none: no cgroups) with their state, spool, sockets and logs in a
# temporary directory and ports of their own, and stops them on exit. Exit 0 passed, 1 failed,
# 77 skipped: only when a daemon truly cannot run here, with what failed (CTest reports SKIP).
# LUNARNAV_KEEP_CLUSTER_TEST=1 keeps the temporary directory.
set -euo pipefail
[[ $# -eq 3 ]] || { echo "usage: $0 BIN_DIR COMPARE_RUNS SCRIPTS_CLUSTER_DIR" >&2; exit 2; }
bin=$(cd "$1" && pwd)
compare=$(cd "$(dirname "$2")" && pwd)/$(basename "$2")
cluster=$(cd "$3" && pwd)
timeout_s=300  # bound of every wait on the cluster

say() { echo "slurm_test: $*" >&2; }
fail() { say "FAIL: $*"; exit 1; }
skip() { say "SKIP: $*"; exit 77; }

# --- Slurm and munge from Debian's packages ------------------------------------------------
missing=()
for p in slurm-wlm munge; do
  [[ $(dpkg-query -W -f='${Status}' "$p" 2>/dev/null || true) == "install ok installed" ]] || missing+=("$p")
done
if [[ ${#missing[@]} -gt 0 ]]; then
  sudo=""
  if [[ $(id -u) -ne 0 ]]; then
    command -v sudo >/dev/null || skip "${missing[*]} not installed, and not root and no sudo to install them"
    sudo="sudo -n"
  fi
  say "installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  $sudo apt-get update -qq || fail "apt-get update failed"
  $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null || fail "apt-get install ${missing[*]} failed"
fi
[[ $(id -u) -eq 0 ]] || skip "the daemons run as root here (SlurmUser=root); this user is $(id -un)"

# --- A temporary cluster -------------------------------------------------------------------
work=$(mktemp -d "${TMPDIR:-/tmp}/lunarnav-slurm.XXXXXX")
chmod 755 "$work"  # munged wants its socket's directory reachable by everyone
pids=()
cleanup() {
  local status=$?
  for ((i = ${#pids[@]} - 1; i >= 0; --i)); do kill "${pids[i]}" 2>/dev/null || true; done
  for pid in "${pids[@]}"; do
    for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    kill -9 "$pid" 2>/dev/null || true
  done
  if [[ ${LUNARNAV_KEEP_CLUSTER_TEST:-0} == 1 ]]; then say "kept $work"; else rm -rf "$work"; fi
  exit "$status"
}
trap cleanup EXIT
trap 'exit 1' INT TERM
mkdir -p "$work"/{key,run,state,spool,log,jobs}
chmod 700 "$work/key"
logs() { for f in "$work"/log/*; do echo "--- $f" >&2; tail -n 15 "$f" >&2; done; }

# munged, with a key made now.
head -c 1024 /dev/urandom > "$work/key/munge.key"
chmod 400 "$work/key/munge.key"
socket=$work/run/munge.socket
munged -F --key-file="$work/key/munge.key" --socket="$socket" --pid-file="$work/run/munged.pid" \
  --log-file="$work/log/munged.log" --seed-file="$work/key/munged.seed" >"$work/log/munged.out" 2>&1 &
pids+=($!)
for _ in $(seq 100); do [[ -S $socket ]] && break; kill -0 "${pids[0]}" 2>/dev/null || break; sleep 0.1; done
[[ -S $socket ]] || { logs; skip "munged cannot run here: $(tail -n 1 "$work/log/munged.out")"; }

# Two free TCP ports for slurmctld and slurmd (other tests or clusters may hold the usual ones).
port_free() { ! (exec 3<>"/dev/tcp/127.0.0.1/$1") 2>/dev/null; }
base=0
for _ in $(seq 50); do
  candidate=$((20000 + RANDOM % 30000))
  if port_free "$candidate" && port_free $((candidate + 1)); then base=$candidate; break; fi
done
[[ $base -gt 0 ]] || fail "no two free ports found"

node=$(hostname -s)
export SLURM_CONF=$work/slurm.conf
cat > "$SLURM_CONF" <<CONF
ClusterName=lunarnavtest
SlurmctldHost=$node(127.0.0.1)
SlurmctldPort=$base
SlurmdPort=$((base + 1))
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$socket
CredType=cred/munge
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/run/slurmctld.pid
SlurmdPidFile=$work/run/slurmd.pid
SlurmctldLogFile=$work/log/slurmctld.log
SlurmdLogFile=$work/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
MpiDefault=none
ReturnToService=2
MinJobAge=600
NodeName=$node NodeAddr=127.0.0.1 CPUs=$(nproc)
PartitionName=lunarnav Nodes=ALL Default=YES MaxTime=INFINITE State=UP
CONF
slurmctld -D -c -f "$SLURM_CONF" >"$work/log/slurmctld.out" 2>&1 &
pids+=($!)
slurmd -D -f "$SLURM_CONF" >"$work/log/slurmd.out" 2>&1 &
pids+=($!)
state=""
for _ in $(seq 300); do
  kill -0 "${pids[1]}" 2>/dev/null || { logs; skip "slurmctld cannot run here (exited; its log above)"; }
  kill -0 "${pids[2]}" 2>/dev/null || { logs; skip "slurmd cannot run here (exited; its log above)"; }
  state=$(sinfo -h -n "$node" -o %T 2>/dev/null || true)
  [[ $state == idle ]] && break
  sleep 0.2
done
[[ $state == idle ]] || { logs; skip "the node never became idle in 60 s (state '${state:-none}'): slurmd cannot serve jobs here"; }
say "cluster up: node $node idle, ports $base-$((base + 1)), in $work"

# --- The data and the one-machine run ------------------------------------------------------
# 40 simulated raw pairs, small (160 x 120, one ray per pixel, a 0.3 m baseline: disparities
# within 0..47 px) to keep the test short.
"$bin/simulate" stereo -o "$work/sim" --frames 40 --width 160 --height 120 --focal 185 --baseline 0.3 --rays 1 -q ||
  fail "simulate stereo failed"
# The same relative paths in both runs, so that the paths the outputs record are the same.
mkdir -p "$work/one" "$work/cluster"
stereo_options=(--rig ../sim/rig.json --disparity 0:47 --preview)
(cd "$work/one" && "$bin/rectify" ../sim -o rect --rig ../sim/rig.json -q -j 2) || fail "one-machine rectify failed"
(cd "$work/one" && "$bin/stereo-batch" rect -o disp "${stereo_options[@]}" -q -j 2) || fail "one-machine stereo-batch failed"

# --- The cluster run -------------------------------------------------------------------------
wait_jobs() {  # waits until jobs $@ have left the queue, at most timeout_s
  local deadline=$((SECONDS + timeout_s))
  while [[ -n $(squeue -h -j "$(IFS=,; echo "$*")" 2>/dev/null) ]]; do
    [[ $SECONDS -lt $deadline ]] || { squeue >&2; logs; fail "jobs $* still queued after ${timeout_s} s"; }
    sleep 1
  done
}
job_state() { scontrol show job "$1" | sed -n 's/.*JobState=\([A-Z_]*\).*/\1/p' | sort -u | tr '\n' ' '; }
expect_completed() {  # job $1 (all its tasks) completed
  local s
  s=$(job_state "$1")
  [[ $s == "COMPLETED " ]] || { cat "$work"/jobs/* >&2 2>/dev/null || true; fail "job $1 ($2) ended $s"; }
}
submit=("$cluster/submit-slurm" --bin "$bin" --logs "$work/jobs")
cd "$work/cluster"
read -r rect_array rect_merge < <("${submit[@]}" -n 4 -- rectify ../sim -o rect --rig ../sim/rig.json -q)
read -r disp_array disp_merge < <("${submit[@]}" -n 4 --after "$rect_merge" -- stereo-batch rect -o disp "${stereo_options[@]}")
say "submitted rectify array $rect_array + merge $rect_merge, stereo-batch array $disp_array + merge $disp_merge"
wait_jobs "$rect_array" "$rect_merge" "$disp_array" "$disp_merge"
for job in "$rect_array:rectify shards" "$rect_merge:rectify merge" "$disp_array:stereo-batch shards" "$disp_merge:stereo-batch merge"; do
  expect_completed "${job%%:*}" "${job#*:}"
done
for dir in rect disp; do
  for k in 0 1 2 3; do
    [[ -f $dir/summary.shard-$k-of-4.json ]] || fail "$dir/summary.shard-$k-of-4.json missing"
  done
  grep -q '"complete": true' "$dir/summary.json" || fail "$dir/summary.json: merge not complete"
  "$compare" "$work/one/$dir" "$work/cluster/$dir" || fail "$dir: the Slurm run differs from the one-machine run"
done
grep -q "shard 3 of 4 (Slurm array job $disp_array, task 3" "$work"/jobs/*"$disp_array"_3.out ||
  fail "task 3's log does not say it took its shard from the Slurm array"

# --- A shard lost midway, resubmitted alone --------------------------------------------------
# What a task killed midway leaves: some of its pairs done, others not, and no shard summary.
rm disp/summary.shard-2-of-4.json disp/summary.json disp/disparity/000010.* disp/preview/000014.png
set +e
"$bin/shard-merge" disp -q
status=$?
set -e
[[ $status -eq 4 ]] || fail "shard-merge with shard 2 missing exited $status, not 4"
grep -q '"complete": false' disp/summary.json || fail "the incomplete merge does not say so"
read -r again_array again_merge < <("${submit[@]}" -n 4 --resubmit 2 -- stereo-batch rect -o disp "${stereo_options[@]}")
wait_jobs "$again_array" "$again_merge"
expect_completed "$again_array" "stereo-batch shard 2 resubmitted"
expect_completed "$again_merge" "merge after the resubmission"
grep -q '"complete": true' disp/summary.json || fail "disp/summary.json: not complete after the resubmission"
grep -q '"pairs_resumed": 8' disp/summary.shard-2-of-4.json ||
  fail "the resubmitted shard did not resume its 8 complete pairs"
for f in disparity/000010.pfm preview/000014.png confidence/000030.tif; do
  cmp -s "$work/one/disp/$f" "disp/$f" || fail "disp/$f differs from the one-machine run after the resubmission"
done
say "PASS: 40 pairs, rectify and stereo-batch as 4-task Slurm arrays with afterok merges, identical to one machine; shard 2 resubmitted alone completed the set (${SECONDS} s)"
