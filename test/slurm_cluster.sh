# Source me: a Slurm cluster on this machine for a test (issue 39), all under one scratch directory.
#   slurm_cluster_start DIR    munged with its own key and socket, slurmctld, and two nodes n1 and n2, each a slurmd
#                              in a network namespace of its own (a veth pair to the host: n1 10.213.1.2, n2
#                              10.213.2.2; the controller listens on 10.213.1.1), one CPU each, partition "study";
#                              exports SLURM_CONF; returns when both nodes are idle
#   slurm_node_kill NODE       every process in the node's namespace, SIGKILL: its slurmd, the job steps, the cells
#   slurm_node_start NODE      its slurmd again (ReturnToService=2: the node comes back by itself)
#   slurm_cluster_stop         every daemon it started, the namespaces and the veth pairs
# Needs root, munge, slurmctld, slurmd, slurm-client, iproute2 and nsenter. No accounting (no slurmdbd): sacct has
# nothing to say, so the study backend asks `scontrol show job` (MinJobAge keeps a task's record 300 s).
# The slurmd of a node starts with `nsenter --net`, not `ip netns exec` (which remounts /sys: slurmd then finds no
# cgroup hierarchy).

SLURM_NS_PREFIX="xslurm$$"
# The daemons listen on every address: scripts/env.sh's bind-address preload (LD_PRELOAD, for ROS nodes) would pin
# them to ROS_IP (127.0.0.1), where the nodes in their namespaces cannot reach the controller, nor it them.
SLURM_DAEMON_ENV="env -u LD_PRELOAD -u XPERSIF_BIND_ADDRESS"
SLURM_PIDS=()
declare -A SLURM_NODE_PID=()

slurm_conf() {
  local dir=$1
  cat <<EOF
# Written by test/slurm_cluster.sh: a two-node cluster on one machine.
ClusterName=xpersiftest
SlurmctldHost=$(hostname)(10.213.1.1)
SlurmctldPort=16817
SlurmdPort=16818
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$dir/munge/munge.socket
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool/%n
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd-%n.pid
SlurmctldLogFile=$dir/slurmctld.log
SlurmdLogFile=$dir/slurmd-%n.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/builtin
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/none
MpiDefault=none
ReturnToService=2
SlurmdTimeout=10
KillWait=5
MinJobAge=300
InactiveLimit=0
NodeName=n1 NodeAddr=10.213.1.2 CPUs=1 RealMemory=2000 State=UNKNOWN
NodeName=n2 NodeAddr=10.213.2.2 CPUs=1 RealMemory=2000 State=UNKNOWN
PartitionName=study Nodes=n1,n2 Default=YES MaxTime=INFINITE State=UP
EOF
}

slurm_network() {
  local i ns
  for i in 1 2; do
    ns="${SLURM_NS_PREFIX}n$i"
    ip netns add "$ns"
    ip link add "${SLURM_NS_PREFIX}h$i" type veth peer name "${SLURM_NS_PREFIX}p$i"
    ip link set "${SLURM_NS_PREFIX}p$i" netns "$ns"
    ip addr add "10.213.$i.1/24" dev "${SLURM_NS_PREFIX}h$i"
    ip link set "${SLURM_NS_PREFIX}h$i" up
    ip -n "$ns" addr add "10.213.$i.2/24" dev "${SLURM_NS_PREFIX}p$i"
    ip -n "$ns" link set "${SLURM_NS_PREFIX}p$i" up
    ip -n "$ns" link set lo up  # each cell's ROS master listens on the node's loopback
    ip -n "$ns" route add default via "10.213.$i.1"
  done
}

slurm_node_start() {
  local node=$1
  mkdir -p "$SLURM_DIR/spool/$node"
  nsenter --net="/var/run/netns/${SLURM_NS_PREFIX}$node" $SLURM_DAEMON_ENV slurmd -D -f "$SLURM_CONF" -N "$node" \
    >>"$SLURM_DIR/slurmd-$node.out" 2>&1 &
  SLURM_PIDS+=($!)
  SLURM_NODE_PID[$node]=$!
  disown $!  # a node killed on purpose is no news to the shell
}

slurm_node_kill() {
  local pids
  pids=$(ip netns pids "${SLURM_NS_PREFIX}$1")
  [[ -z "$pids" ]] || kill -9 $pids 2>/dev/null || true
}

# Every daemon's log, the last lines of each, for a failure's sentence.
slurm_logs() {
  tail -n 8 "$SLURM_DIR"/*.log "$SLURM_DIR"/*.out "$SLURM_DIR"/munge/munged.log >&2 2>/dev/null || true
}

# Waits up to $2 seconds for the command $1 to succeed.
slurm_wait_for() {
  local i
  for ((i = 0; i < $2 * 5; i++)); do
    eval "$1" >/dev/null 2>&1 && return 0
    sleep 0.2
  done
  return 1
}

slurm_wait_idle() {
  local i node
  for ((i = 0; i < 120; i++)); do
    [[ $(sinfo -h -N -o "%N %t" 2>/dev/null | grep -c " idle$") == 2 ]] && return 0
    # A slurmd that exited (rather than one slow to register) is named, with its last words, and started again.
    for node in "${!SLURM_NODE_PID[@]}"; do
      kill -0 "${SLURM_NODE_PID[$node]}" 2>/dev/null && continue
      echo "the slurmd of $node exited; starting it again. Its output:" >&2
      tail -n 8 "$SLURM_DIR/slurmd-$node.out" "$SLURM_DIR/slurmd-$node.log" >&2 2>/dev/null || true
      slurm_node_start "$node"
    done
    sleep 1
  done
  echo "the cluster's nodes did not become idle in 120 s: $(sinfo -N 2>&1)" >&2
  slurm_logs
  return 1
}

slurm_cluster_start() {
  SLURM_DIR=$1
  mkdir -p "$SLURM_DIR/munge" "$SLURM_DIR/state" "$SLURM_DIR/spool"
  chmod 700 "$SLURM_DIR/munge"
  dd if=/dev/urandom of="$SLURM_DIR/munge/munge.key" bs=1024 count=1 status=none
  chmod 400 "$SLURM_DIR/munge/munge.key"
  munged --force --foreground --socket="$SLURM_DIR/munge/munge.socket" --key-file="$SLURM_DIR/munge/munge.key" \
    --pid-file="$SLURM_DIR/munge/munged.pid" --log-file="$SLURM_DIR/munge/munged.log" \
    --seed-file="$SLURM_DIR/munge/munged.seed" >"$SLURM_DIR/munge/munged.out" 2>&1 &
  SLURM_PIDS+=($!)
  export SLURM_CONF="$SLURM_DIR/slurm.conf"
  slurm_conf "$SLURM_DIR" >"$SLURM_CONF"
  slurm_network
  # Each daemon after the one it needs answers: a slurmd that starts before munged or slurmctld can answer may
  # give up registering, and its node then stays "unk*" (seen once in CI, under load).
  slurm_wait_for "munge -n --socket='$SLURM_DIR/munge/munge.socket'" 30 ||
    { echo "munged did not answer in 30 s" >&2; slurm_logs; return 1; }
  $SLURM_DAEMON_ENV slurmctld -D -i -f "$SLURM_CONF" >"$SLURM_DIR/slurmctld.out" 2>&1 &
  SLURM_PIDS+=($!)
  slurm_wait_for "[[ \$(scontrol ping 2>/dev/null) == *UP* ]]" 60 ||
    { echo "slurmctld did not answer in 60 s" >&2; slurm_logs; return 1; }
  slurm_node_start n1
  slurm_node_start n2
  slurm_wait_idle
}

slurm_cluster_stop() {
  local i pid pids
  for i in 1 2; do
    if ip netns pids "${SLURM_NS_PREFIX}n$i" >/dev/null 2>&1; then
      pids=$(ip netns pids "${SLURM_NS_PREFIX}n$i")
      [[ -z "$pids" ]] || { kill $pids 2>/dev/null; sleep 1; slurm_node_kill "n$i"; }
      ip netns delete "${SLURM_NS_PREFIX}n$i" 2>/dev/null || true
    fi
    ip link delete "${SLURM_NS_PREFIX}h$i" 2>/dev/null || true
  done
  for pid in "${SLURM_PIDS[@]}"; do
    kill "$pid" 2>/dev/null || true
  done
  for pid in "${SLURM_PIDS[@]}"; do
    i=0
    while kill -0 "$pid" 2>/dev/null && ((i++ < 50)); do sleep 0.1; done
    wait "$pid" 2>/dev/null || true
  done
}
