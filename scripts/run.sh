#!/usr/bin/env bash
# The main job: install what is missing, build, bring up the XPERSIF system headless on its own
# roscore, print every component's state and the contracts it offers, write them to runs/<time>/, stop.
#   --keep   keep the system running until Ctrl-C (watch it with `xpersif status` from another shell)
set -euo pipefail
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
keep=0
[[ "${1:-}" == "--keep" ]] && keep=1

bash "$repo/scripts/setup.sh"
XPERSIF_NEW_MASTER=1 source "$repo/scripts/env.sh"
set -u
run_dir="$repo/runs/$(date +%Y%m%d-%H%M%S)"
mkdir -p "$run_dir"
export ROS_LOG_DIR="$run_dir/ros_log"

port=${ROS_MASTER_URI##*:}
roslaunch -p "$port" xpersif xpersif.launch >"$run_dir/launch.log" 2>&1 &
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

echo "run: master $ROS_MASTER_URI, results in $run_dir"
if ! xpersif wait --timeout 90 /xpersif/supervisor >"$run_dir/status.txt" 2>"$run_dir/wait.err"; then
  cat "$run_dir/wait.err"
  echo "run: the system did not come up; see $run_dir/launch.log" >&2
  tail -30 "$run_dir/launch.log" >&2
  exit 1
fi
{
  echo "== component states"
  xpersif status --timeout 2
  for component in /xpersif/xpersim /xpersif/counter /xpersif/statistics; do
    echo
    echo "== contracts of $component"
    xpersif contracts "$component"
  done
} | tee "$run_dir/report.txt"

if ((keep)); then
  echo "run: running; press Ctrl-C to stop"
  wait "$launch_pid"
fi
