#!/usr/bin/env bash
# Recording at full rate (issue 6): /tf frames dropped by rosbag record, the recorder's CPU share, and bytes per
# simulated second with and without images and compression. See bench/traces.md.
#
#   bash bench/run_traces.sh [build_dir=build] [out_dir=bench/results/traces-<date>]
#   env: PORT (default 11412), DURATION (wall s per measurement, default 20)
#
# Part A: xpersim_node alone (/tf at 1 kHz of simulated time, 1 ms step, world bench/worlds/table1.yaml),
#         recorded by launch/record.launch (lz4, no images): clock realtime (1000 frames per wall s), and fast
#         with ~max_frame_rate 100000 so that every simulated millisecond's frame is published (XPERSim caps
#         fast mode at 1000 frames per wall s by default, which would make skipped stamps look like drops).
# Part B: launch/embodiment.launch record:=true (XPERSim + the embodiment's components and cameras, realtime),
#         for: no images lz4 | no images none | images lz4 | images none | images bz2.
# Each: the recorder's CPU (utime+stime from /proc over the window / window wall time; 100 % = one core),
# then SIGINT, then bench/summarize_traces.py over the bags.
set -eo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
SRC=$(cd "$HERE/.." && pwd)
BUILD=$(cd "${1:-$SRC/build}" && pwd)
OUT=${2:-$HERE/results/traces-$(date +%Y%m%d-%H%M%S)}
PORT=${PORT:-11412}
DURATION=${DURATION:-20}
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
export PATH=/usr/bin:$PATH
set +u
# shellcheck disable=SC1091
source "$BUILD/devel/setup.bash"
set -u
export ROS_IP=127.0.0.1 ROS_HOSTNAME=127.0.0.1 ROS_MASTER_URI=http://127.0.0.1:$PORT ROS_LOG_DIR=$OUT/ros_log
BIN=$BUILD/devel/lib/xpersif
PIDS=()
ROSCORE_PID=
cleanup() {
  for p in "${PIDS[@]}"; do kill -INT "$p" 2>/dev/null || true; done
  sleep 1
  for p in "${PIDS[@]}"; do kill -KILL "$p" 2>/dev/null || true; done
  [ -z "$ROSCORE_PID" ] || kill -INT "$ROSCORE_PID" 2>/dev/null || true
}
trap cleanup EXIT
if (exec 3<>/dev/tcp/127.0.0.1/$PORT) 2>/dev/null; then echo "port $PORT is in use; set PORT" >&2; exit 1; fi
roscore -p "$PORT" >"$OUT/roscore.log" 2>&1 &
ROSCORE_PID=$!
for _ in $(seq 100); do rosparam get /rosdistro >/dev/null 2>&1 && break; sleep 0.2; done
cpu_ticks() { awk '{print $14 + $15}' "/proc/$1/stat" 2>/dev/null || echo 0; }
wait_gone() { for _ in $(seq 200); do kill -0 "$1" 2>/dev/null || return 0; sleep 0.1; done; return 1; }
recorder_of() {  # the `record` process under a roslaunch pid
  local launch=$1 p
  for _ in $(seq 200); do
    for p in $(pgrep -P "$launch" || true); do
      [ "$(ps -o comm= -p "$p")" = record ] && { echo "$p"; return 0; }
    done
    sleep 0.1
  done
  return 1
}
# measure TAG LAUNCH_PID RUN_DIR -> OUT/TAG.json (drops: XPERSim's /tf frames, by stamp, see summarize_traces.py)
measure() {
  local tag=$1 launch=$2 dir=$3 rec t0 c0 t1 c1 cpu
  rec=$(recorder_of "$launch") || { echo "$tag: no recorder" >&2; return 1; }
  sleep 3
  t0=$(date +%s.%N); c0=$(cpu_ticks "$rec")
  sleep "$DURATION"
  t1=$(date +%s.%N); c1=$(cpu_ticks "$rec")
  cpu=$(awk -v a="$c0" -v b="$c1" -v t0="$t0" -v t1="$t1" -v hz="$(getconf CLK_TCK)" 'BEGIN{printf "%.1f", (b - a) / hz / (t1 - t0) * 100}')
  local load; load=$(cut -d' ' -f1-3 /proc/loadavg)
  kill -INT "$launch"; wait_gone "$launch" || kill -KILL "$launch" 2>/dev/null || true
  wait "$launch" 2>/dev/null || true
  local summary; summary=$(/usr/bin/python3 "$HERE/summarize_traces.py" "$dir" auto)
  echo "{\"run\":\"$tag\",\"recorder_cpu_pct\":$cpu,\"window_wall_s\":$DURATION,\"loadavg\":\"$load\",\"summary\":$summary}" \
    | tee "$OUT/$tag.json"
  rm -rf "$dir"
}

{
  echo "date: $(date -Is)"
  echo "host: $(uname -srm), nproc $(nproc), $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')"
  echo "git: $(git -C "$SRC" describe --always --dirty)"
  echo "uptime at start: $(uptime)"
} | tee "$OUT/machine.txt"

# ---- Part A: /tf at 1 kHz from xpersim_node alone ----
rosparam set /use_sim_time true
for mode in realtime fast; do
  "$BIN/xpersim_node" _world:="$HERE/worlds/table1.yaml" _clock_mode:=$mode _tf_rate:=1000 _max_frame_rate:=100000 \
    _autostart:=true \
    __name:=xpersim __ns:=/xpersif >"$OUT/xpersim_$mode.log" 2>&1 &
  sim=$!; PIDS+=("$sim")
  sleep 2
  dir=$OUT/run_tf_$mode
  roslaunch xpersif record.launch run_dir:="$dir" >"$OUT/record_tf_$mode.log" 2>&1 &
  launch=$!; PIDS+=("$launch")
  measure "tf1k_$mode" "$launch" "$dir"
  kill -INT "$sim"; wait_gone "$sim" || kill -KILL "$sim"
done
rosparam delete /xpersif >/dev/null 2>&1 || true

# ---- Part B: the embodiment, recorded ----
for cfg in "false lz4" "false none" "true lz4" "true none" "true bz2"; do
  set -- $cfg
  tag=embodiment_images-$1_$2
  dir=$OUT/run_$tag
  roslaunch xpersif embodiment.launch record:=true run_dir:="$dir" record_images:=$1 record_compression:=$2 \
    >"$OUT/$tag.log" 2>&1 &
  launch=$!; PIDS+=("$launch")
  sleep 5   # XPERSim and the components up
  measure "$tag" "$launch" "$dir"
  rosparam delete /xpersif >/dev/null 2>&1 || true
done
echo "uptime at end: $(uptime)" | tee -a "$OUT/machine.txt"
