# Sourced: a one-node SLURM cluster whose every file lives in one folder, for the tests and the
# benchmark (never a production setup: docs/cluster.md). Needs root (slurmd runs tasks as their
# user) and Debian's slurm-wlm and munge.
#
#   local_cluster_start DIR   starts munged, slurmctld and slurmd with state, logs, pids, the
#                             munge key and socket under DIR; exports SLURM_CONF; waits until
#                             the node is idle. Returns 77 (with a message) where it cannot.
#                             Ports: two free ones, or $OPALINE_SLURMCTLD_PORT, $OPALINE_SLURMD_PORT.
#   local_cluster_stop DIR    stops them by the pids they wrote (never by name) and waits.

local_cluster_start() {
  local d=$1 h bin
  if [ "$(id -u)" -ne 0 ]; then
    echo "skip: a local SLURM cluster needs root (slurmd runs tasks as their user)"; return 77
  fi
  for bin in munged slurmctld slurmd sbatch squeue sacct scontrol sinfo; do
    command -v "$bin" >/dev/null || PATH=$PATH:/usr/sbin
    command -v "$bin" >/dev/null || {
      echo "skip: $bin not found (apt-get install slurm-wlm munge, or scripts/install-deps.sh)"
      return 77; }
  done
  mkdir -p "$d/munge" "$d/state" "$d/spool"
  chmod 700 "$d/munge"
  head -c 1024 /dev/urandom > "$d/munge/munge.key"
  chmod 400 "$d/munge/munge.key"
  # --force: as root munged refuses folders it does not own as the munge user; these are ours
  munged --force --key-file="$d/munge/munge.key" --socket="$d/munge/socket" \
    --pid-file="$d/munge/munged.pid" --log-file="$d/munge/munged.log" \
    --seed-file="$d/munge/seed" --num-threads=2 2>"$d/munge/start.err" || {
      echo "local cluster: munged did not start:"; cat "$d/munge/start.err"; return 1; }
  h=$(hostname -s)
  local mem cport dport
  # two free ports (another cluster of the kind may run beside this one), unless given
  read -r cport dport < <(python3 -c '
import socket
s = [socket.socket() for _ in range(2)]
for x in s: x.bind(("", 0))
print(*[x.getsockname()[1] for x in s])')
  mem=$(awk '/MemTotal/ {print int($2 / 1024 / 2)}' /proc/meminfo)
  cat > "$d/slurm.conf" <<CONF
ClusterName=opaline
SlurmctldHost=$h
AuthType=auth/munge
AuthInfo=socket=$d/munge/socket
CredType=cred/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SlurmctldPort=${OPALINE_SLURMCTLD_PORT:-$cport}
SlurmdPort=${OPALINE_SLURMD_PORT:-$dport}
StateSaveLocation=$d/state
SlurmdSpoolDir=$d/spool
SlurmctldPidFile=$d/slurmctld.pid
SlurmdPidFile=$d/slurmd.pid
SlurmctldLogFile=$d/slurmctld.log
SlurmdLogFile=$d/slurmd.log
SlurmUser=root
ReturnToService=2
JobRequeue=1
MinJobAge=600
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SchedulerParameters=defer_batch
MessageTimeout=10
NodeName=$h CPUs=$(nproc) RealMemory=$mem State=UNKNOWN
PartitionName=debug Nodes=$h Default=YES MaxTime=INFINITE State=UP
CONF
  export SLURM_CONF=$d/slurm.conf
  slurmctld -f "$SLURM_CONF" || { echo "local cluster: slurmctld did not start"; return 1; }
  slurmd -f "$SLURM_CONF" || { echo "local cluster: slurmd did not start"; return 1; }
  local i
  for i in $(seq 1 100); do
    sinfo -h -o %t 2>/dev/null | grep -qx idle && return 0
    sleep 0.2
  done
  echo "local cluster: the node is not idle after 20 s:"; sinfo 2>&1; tail -5 "$d/slurmctld.log"
  return 1
}

local_cluster_stop() {
  local d=$1 f pids=() p i
  for f in "$d/slurmd.pid" "$d/slurmctld.pid" "$d/munge/munged.pid"; do
    [ -s "$f" ] && pids+=("$(cat "$f")")
  done
  [ ${#pids[@]} -eq 0 ] && return 0
  kill "${pids[@]}" 2>/dev/null
  for i in $(seq 1 50); do
    local alive=0
    for p in "${pids[@]}"; do kill -0 "$p" 2>/dev/null && alive=1; done
    [ $alive = 0 ] && return 0
    sleep 0.1
  done
  kill -9 "${pids[@]}" 2>/dev/null
  return 0
}
