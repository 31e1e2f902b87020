#!/usr/bin/env bash
# scripts/slurm-fit-array.sh under a real Slurm: a single-node cluster on this machine (munged,
# slurmctld and slurmd with a temporary config and ports of their own, on 127.0.0.1) fits an
# array of 3 stored scans of the simulated tac7-mini, then a resubmission that adds a 4th,
# broken scan: the 3 finished tasks are skipped and the broken one fails alone, its log naming
# the missing frame. Exits 77 (skipped) only where Slurm cannot start, saying why.
# Usage: slurm_fit_array_test.sh LOOM SOURCE_DIR WORK_DIR
set -euo pipefail
trap 'echo "FAILED: line $LINENO: $BASH_COMMAND" >&2' ERR
loom=$1 src=$2 work=$3

skip() {
  echo "SKIPPED: $*" >&2
  exit 77
}
fail() {
  echo "FAILED: $*" >&2
  exit 1
}

for tool in munged slurmctld slurmd sbatch scontrol sinfo; do
  command -v "$tool" >/dev/null || skip "$tool is not installed (scripts/install-deps.sh installs slurm-wlm and munge)"
done
[[ $(id -u) -eq 0 ]] || skip "slurmd runs jobs as their submitter only when started as root"

rm -rf "$work"
mkdir -p "$work"/{munge,state,spool,logs,scans}
cd "$work"
stop_cluster() {
  for pid_file in slurmd.pid slurmctld.pid munge/munged.pid; do
    [[ -f $pid_file ]] && kill "$(cat "$pid_file")" 2>/dev/null || true
  done
}
trap stop_cluster EXIT

start_munge() {
  dd if=/dev/urandom of=munge/munge.key bs=1024 count=1 status=none
  chmod 400 munge/munge.key
  munged --force --key-file="$work/munge/munge.key" --socket="$work/munge/socket" --pid-file="$work/munge/munged.pid" \
    --log-file="$work/munge/munged.log" --seed-file="$work/munge/seed" || skip "munged did not start: $(tail -3 munge/munged.log)"
}

write_slurm_conf() {
  local host
  host=$(hostname)
  cat > slurm.conf <<CONF
ClusterName=loomtest
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=46817
SlurmdPort=46818
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$work/munge/socket
CredType=cred/munge
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldLogFile=$work/logs/slurmctld.log
SlurmdLogFile=$work/logs/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
MpiDefault=none
ReturnToService=2
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
MinJobAge=600
NodeName=loomnode NodeHostname=$host NodeAddr=127.0.0.1 CPUs=$(nproc) RealMemory=2000 State=UNKNOWN
PartitionName=test Nodes=loomnode Default=YES MaxTime=INFINITE State=UP
CONF
}

start_slurm() {
  export SLURM_CONF=$work/slurm.conf
  slurmctld -i || skip "slurmctld did not start: $(tail -3 logs/slurmctld.log 2>/dev/null)"
  slurmd -N loomnode || skip "slurmd did not start: $(tail -3 logs/slurmd.log 2>/dev/null)"
  for _ in $(seq 60); do
    [[ $(sinfo -h -o %T 2>/dev/null) == idle ]] && return
    sleep 0.5
  done
  skip "the node never became idle: $(sinfo 2>&1; tail -3 logs/slurmctld.log)"
}

# Three small scans of different fabrics (a 3.2 mm crop, a few images of each kind) and a
# fourth whose first frame is gone.
scan_materials() {
  cat > small-plan.yaml <<PLAN
schema_version: 1
preset: small
turntable_deg: [0]
colour_views_deg: [0]
linear_light_positions: 4
led_current_ma: 1000
probe_exposure_us: 10000
max_exposures: 2
structured_light: {gray_bits: 0, phase_steps: 3}
PLAN
  for seed in 1 2 3; do
    "$loom" scan --rig "$src/configs/rig/tac7-mini.yaml" --object "fabric:$seed" --preset small-plan.yaml \
      --crop-mm 3.2 --out "scans/fabric-$seed" --quiet > /dev/null 2>&1
    echo "$work/scans/fabric-$seed" >> scans.txt
  done
  cp -r scans/fabric-1 scans/broken
  # sed, not head: head's early exit would fail the pipe (SIGPIPE) under pipefail.
  broken_frame=$(find scans/broken/frames -type f -name '*.exr' | sort | sed -n 1p)
  rm "$broken_frame"
  cp scans.txt scans-and-broken.txt
  echo "$work/scans/broken" >> scans-and-broken.txt
}

# Runs the fit array over the scans listed in $1; sbatch --wait's exit status is the array's.
fit_array() {
  local list=$1 tasks
  tasks=$(wc -l < "$list")
  LOOM=$loom LOOM_FIT_METHOD=refine LOOM_RECONSTRUCT_ARGS="--size 16" \
    sbatch --wait --array="1-$tasks" --cpus-per-task=1 --mem=200M --output="$work/logs/$2-%a.log" \
    "$src/scripts/slurm-fit-array.sh" "$list" nominal "$work/results" > /dev/null
}

start_munge
write_slurm_conf
start_slurm
scan_materials

fit_array scans.txt first || fail "the first array failed: $(cat logs/first-*.log)"
for seed in 1 2 3; do
  for result in fit/fit.json fit/svbrdf.exr report/index.html; do
    [[ -s results/fabric-$seed/$result ]] || fail "task $seed left no results/fabric-$seed/$result"
  done
done
echo "first array: 3 scans fitted"

if fit_array scans-and-broken.txt second; then fail "the resubmission succeeded with a broken scan in it"; fi
for task in 1 2 3; do
  grep -q "already fitted" "logs/second-$task.log" || fail "task $task was not skipped: $(cat "logs/second-$task.log")"
done
grep -q "$broken_frame" logs/second-4.log || fail "the broken task's log does not name the missing frame: $(cat logs/second-4.log)"
[[ ! -e results/broken/fit/fit.json ]] || fail "the broken scan has a fit"
echo "resubmission: 3 tasks skipped, the broken scan failed alone: $(grep -m1 error logs/second-4.log)"
