#!/usr/bin/env bash
# The main job: the default experiment, headless, faster than real time, on embedded defaults (a SQLite
# knowledge base in the run directory, a roscore of its own).
#
#  1. bring up XPERSim, the embodiment and the loop (launch/xpersif.launch) and wait until all are ACTIVE;
#  2. run 'evaluation': random pushes that every design's model is judged on afterwards;
#  3. run 'random' and 'curiosity' (the same number of experiments each, from the same arena), then
#     goal-directed pushes with the model curiosity learned;
#  4. xpersif_report: notions, prediction error against the number of experiments for both designs (table
#     and PNG), experiments curiosity needed to reach random's final error, goal success.
# Everything goes to runs/<time>/ (report.md, learning_curve.png/.csv, knowledge.db, logs).
#   --experiments N (default 32)  --evaluation N (16)  --goals N (5)  --seed S (1)  --keep (stay up at the end)
#   --record (record the run with rosbag into the run directory, doc/traces.md)  --record-images (with images)
#   --record-compression lz4|bz2|none (lz4)  --world FILE (worlds/default.yaml: any world file, see README)
# SNAPSHOTRECORDER writes surprise_<t>.bag files into the run directory either way.
set -euo pipefail
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
experiments=32 evaluation=16 goals=5 seed=1 keep=0 record=false record_images=false record_compression=lz4
world="$repo/worlds/default.yaml"
while (($#)); do
  case "$1" in
    --experiments) experiments=$2; shift 2 ;;
    --evaluation) evaluation=$2; shift 2 ;;
    --goals) goals=$2; shift 2 ;;
    --seed) seed=$2; shift 2 ;;
    --keep) keep=1; shift ;;
    --record) record=true; shift ;;
    --record-images) record=true record_images=true; shift ;;
    --record-compression) record_compression=$2; shift 2 ;;
    --world) world=$2; shift 2 ;;
    *) echo "run.sh: unknown option $1" >&2; exit 2 ;;
  esac
done

[[ -f "$world" ]] || { echo "run.sh: --world $world: no such file" >&2; exit 2; }
world=$(cd "$(dirname "$world")" && pwd)/$(basename "$world")  # absolute: the nodes run elsewhere
bash "$repo/scripts/setup.sh"
XPERSIF_NEW_MASTER=1 source "$repo/scripts/env.sh"
set -u
# A bad world starts nothing: one sentence naming the file and what is wrong, exit 2.
xpersif check-world "$world" >/dev/null || exit 2
run_dir="${XPERSIF_RUN_DIR:-$repo/runs/$(date +%Y%m%d-%H%M%S)}"
mkdir -p "$run_dir"
run_dir=$(cd "$run_dir" && pwd)  # absolute: the nodes run in another working directory
export ROS_LOG_DIR="$run_dir/ros_log"
database="$run_dir/knowledge.db"

port=${ROS_MASTER_URI##*:}
roslaunch -p "$port" xpersif xpersif.launch world:="$world" database:="$database" seed:="$seed" run_dir:="$run_dir" \
  record:="$record" record_images:="$record_images" record_compression:="$record_compression" >"$run_dir/launch.log" 2>&1 &
launch_pid=$!
stop() {
  # roslaunch may ignore SIGINT while it is still starting: escalate rather than wait forever.
  for signal in INT INT TERM KILL; do
    kill -"$signal" "$launch_pid" 2>/dev/null || break
    for _ in $(seq 1 50); do
      kill -0 "$launch_pid" 2>/dev/null || break 2
      sleep 0.2
    done
  done
  wait "$launch_pid" 2>/dev/null || true
}
trap stop EXIT

started=$(date +%s)
echo "run: master $ROS_MASTER_URI, results in $run_dir"
if ! xpersif wait --timeout 180 /xpersif/loop_model >"$run_dir/status.txt" 2>"$run_dir/wait.err"; then
  cat "$run_dir/wait.err"
  echo "run: the system did not come up; see $run_dir/launch.log" >&2
  tail -30 "$run_dir/launch.log" >&2
  exit 1
fi
xpersif status --timeout 2 >"$run_dir/status.txt"

loop() {  # NAME DESIGN EXPERIMENTS GOALS SEED
  echo "run: $1: $3 experiments by $2 design, $4 goals"
  xpersif run "$1" --design "$2" --experiments "$3" --goals "$4" --seed "$5" | tee "$run_dir/$1.log" |
    grep -E "^run |goal|failed" || true
  grep -q "SUCCEEDED" "$run_dir/$1.log" || { echo "run: $1 did not finish; see $run_dir/$1.log" >&2; exit 1; }
}
loop evaluation random "$evaluation" 0 $((seed + 1000))
loop random random "$experiments" 0 "$seed"
loop curiosity curiosity "$experiments" "$goals" "$seed"

echo "run: report"
xpersif_report --database "$database" --out "$run_dir" --evaluation evaluation --designs curiosity,random \
  --goals curiosity >/dev/null
cat "$run_dir/report.md"
echo
echo "run: the default experiment took $(($(date +%s) - started)) s after the build; results in $run_dir"

if ((keep)); then
  echo "run: running; press Ctrl-C to stop"
  wait "$launch_pid"
fi
