#!/usr/bin/env bash
# Recording robustness and SNAPSHOTRECORDER, against a real roscore, XPERSim (/tf at 1 kHz, /clock) and
# Debian's rosbag record started by launch/record.launch:
#  1. SIGINT to roslaunch        -> closed, readable, exportable bags and run.yaml with the code version
#  2. SIGTERM to the recorder    -> closed, readable bags
#  3. SIGKILL to the recorder    -> X.bag.active; the exporter refuses it (exit 3, names the file, gives advice);
#                                   xpersif_recover_bag reindexes it and says how many messages were kept;
#                                   the exporter then reads the run
#  4. SNAPSHOTRECORDER           -> surprise above ~threshold writes surprise_<t>.bag holding <= ~seconds of
#                                   /tf; below it nothing; the snapshot operation writes snapshot_<t>.bag
#   bash test/traces_recording.sh BUILD_DIR      (env PORT, default 11533)
set -eo pipefail
HERE=$(cd "$(dirname "$0")/.." && pwd)
BUILD=$(cd "${1:-$HERE/build}" && pwd)
PORT=${PORT:-11533}
export PATH=/usr/bin:$PATH
set +u
# shellcheck disable=SC1091
source "$BUILD/devel/setup.bash"
set -u
T=$(mktemp -d /tmp/xpersif-traces-rec-XXXXXX)
export ROS_IP=127.0.0.1 ROS_HOSTNAME=127.0.0.1 ROS_MASTER_URI=http://127.0.0.1:$PORT ROS_LOG_DIR=$T/ros_log
BIN=$BUILD/devel/lib/xpersif
PIDS=()
cleanup() {
  for p in "${PIDS[@]}"; do kill -INT "$p" 2>/dev/null || true; done
  sleep 1
  for p in "${PIDS[@]}"; do kill -KILL "$p" 2>/dev/null || true; done
  [ -n "${KEEP:-}" ] || rm -rf "$T"
}
trap cleanup EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
ok() { echo "ok: $*"; }
wait_gone() { for _ in $(seq 100); do kill -0 "$1" 2>/dev/null || return 0; sleep 0.1; done; return 1; }

if (exec 3<>/dev/tcp/127.0.0.1/$PORT) 2>/dev/null; then fail "port $PORT is in use; set PORT"; fi
roscore -p "$PORT" >"$T/roscore.log" 2>&1 &
PIDS+=($!)
for _ in $(seq 100); do rosparam get /rosdistro >/dev/null 2>&1 && break; sleep 0.2; done
rosparam set /use_sim_time true
"$BIN/xpersim_node" _world:="$HERE/worlds/default.yaml" _clock_mode:=realtime _tf_rate:=1000 _autostart:=true \
  __name:=xpersim __ns:=/xpersif >"$T/xpersim.log" 2>&1 &
PIDS+=($!)
for _ in $(seq 120); do grep -qx /clock <(rostopic list 2>/dev/null) && break; sleep 0.5; done
grep -qx /clock <(rostopic list 2>/dev/null) || fail "xpersim did not start (see $T/xpersim.log)"

# start_recording DIR -> sets LAUNCH (roslaunch pid) and REC (the recorder's pid)
start_recording() {
  roslaunch --wait xpersif record.launch run_dir:="$1" split_size:=1 >"$1.launch.log" 2>&1 &
  LAUNCH=$!
  PIDS+=("$LAUNCH")
  REC=
  for _ in $(seq 100); do
    REC=$(ps -o pid= --ppid "$LAUNCH" | tr -d ' ' | head -1 || true)
    [ -n "$REC" ] && [ "$(ps -o comm= -p "$REC" || true)" = record ] && break
    sleep 0.1
  done
  [ -n "$REC" ] || fail "the recorder did not start (see $1.launch.log)"
  sleep 4   # subscriptions up, some seconds of /tf
}
check_closed() {
  local dir=$1
  ls "$dir"/*.active >/dev/null 2>&1 && fail "$dir: a bag is still .active"
  ls "$dir"/xpersif_*.bag >/dev/null 2>&1 || fail "$dir: no bag"
  for b in "$dir"/xpersif_*.bag; do rosbag info "$b" >/dev/null || fail "rosbag info $b"; done
  grep -q "^code_version: '" "$dir/run.yaml" || fail "$dir/run.yaml has no code_version"
  grep -q "xpersim:" "$dir/run.yaml" || fail "$dir/run.yaml lacks the /xpersif parameters"
  mkdir -p "$dir/csv"
  "$BIN/xpersif_export" -o "$dir/csv" "$dir" >"$dir/export.log" || fail "export of $dir: $(cat "$dir/export.log")"
  local rows
  rows=$(($(wc -l <"$dir/csv/poses.csv") - 1))
  [ "$rows" -gt 1000 ] || fail "$dir: only $rows poses exported"
  echo "$rows"
}

# 1. SIGINT to roslaunch
start_recording "$T/int"
kill -INT "$LAUNCH"; wait_gone "$LAUNCH" || fail "roslaunch did not stop on SIGINT"; wait_gone "$REC" || true
ok "SIGINT: $(ls "$T/int"/xpersif_*.bag | wc -l) closed bag(s), $(check_closed "$T/int") poses exported"

# 2. SIGTERM to the recorder
start_recording "$T/term"
kill -TERM "$REC"; wait_gone "$REC" || fail "the recorder did not stop on SIGTERM"
kill -INT "$LAUNCH"; wait_gone "$LAUNCH" || true
ok "SIGTERM: $(ls "$T/term"/xpersif_*.bag | wc -l) closed bag(s), $(check_closed "$T/term") poses exported"

# 3. SIGKILL to the recorder
start_recording "$T/kill"
kill -KILL "$REC"; wait_gone "$REC" || fail "the recorder survived SIGKILL"
kill -INT "$LAUNCH"; wait_gone "$LAUNCH" || true
active=$(ls "$T/kill"/*.bag.active 2>/dev/null | head -1)
[ -n "$active" ] || fail "SIGKILL left no .active bag: $(ls "$T/kill")"
set +e
"$BIN/xpersif_export" -o "$T" "$T/kill" 2>"$T/kill.err"; rc=$?
set -e
[ "$rc" = 3 ] || fail "export of a killed run exited $rc, not 3 (a bad input file)"
grep -q "xpersif_recover_bag" "$T/kill.err" && grep -qF "$active" "$T/kill.err" || fail "no advice: $(cat "$T/kill.err")"
"$BIN/xpersif_recover_bag" "$active" | tee "$T/recover.log"
kept=$(sed -n 's/.*kept \([0-9]*\) messages.*/\1/p' "$T/recover.log" | head -1)
[ -n "$kept" ] && [ "$kept" -gt 1000 ] || fail "recovery kept '$kept' messages"
mkdir -p "$T/kill/csv"
"$BIN/xpersif_export" -o "$T/kill/csv" "$T/kill" || fail "export after recovery"
ok "SIGKILL: recovered $active, kept $kept messages; exported"

# 4. SNAPSHOTRECORDER
# A list must go through the parameter server: roscpp reads "_topics:=[/tf, /clock]" on a command line as a string
# (which the recorder refuses: ~topics is declared a string list).
rosparam set /snapshot_recorder/topics "[/tf, /clock]"
rosrun nodelet nodelet standalone xpersif/SnapshotRecorderNodelet __name:=snapshot_recorder _autostart:=true \
  _run_dir:="$T/snap" _seconds:=2.0 _threshold:=0.05 _min_interval:=0 \
  >"$T/snapshot.log" 2>&1 &
PIDS+=($!)
for _ in $(seq 150); do grep -qx /snapshot_recorder/snapshot <(rosservice list 2>/dev/null) && break; sleep 0.2; done
sleep 4  # configured, activated, buffer filled (> 2 s of /tf)
rostopic pub -1 /xpersif/motivation/motivation xpersif/Motivation "{surprise: 0.01}" >/dev/null
sleep 2
ls "$T/snap"/*.bag >/dev/null 2>&1 && fail "a snapshot was written below the threshold"
rostopic pub -1 /xpersif/motivation/motivation xpersif/Motivation "{surprise: 0.2}" >/dev/null
for _ in $(seq 100); do ls "$T/snap"/surprise_*.bag >/dev/null 2>&1 && break; sleep 0.1; done
snap=$(ls "$T/snap"/surprise_*.bag 2>/dev/null | head -1)
[ -n "$snap" ] || fail "no surprise snapshot (see $T/snapshot.log)"
sleep 1
dur=$(rosbag info -y -k duration "$snap")
msgs=$(rosbag info -y -k messages "$snap")
awk -v d="$dur" 'BEGIN{exit !(d > 1.5 && d <= 2.05)}' || fail "snapshot spans $dur s, not ~2 s"
[ "$msgs" -gt 200 ] || fail "snapshot holds only $msgs messages"
ok "surprise snapshot $snap: $msgs messages over $dur s"
resp=$(rosservice call /snapshot_recorder/snapshot)
echo "$resp" | grep -q "success: True" || fail "snapshot operation: $resp"
for _ in $(seq 100); do ls "$T/snap"/snapshot_*.bag >/dev/null 2>&1 && break; sleep 0.1; done
ls "$T/snap"/snapshot_*.bag >/dev/null 2>&1 || fail "no on-demand snapshot"
ok "on-demand snapshot $(ls "$T/snap"/snapshot_*.bag)"
echo "PASS"
