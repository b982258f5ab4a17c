#!/usr/bin/env bash
# Wall time per experiment of the loop in each clock mode, on fresh systems, one after the other in one run:
#   bash bench/run_loop_speed.sh [EXPERIMENTS (16)] [GOALS (2)] [MODES ("realtime lockstep")]
# realtime runs at the main launch's former 8x real time. Prints one line per mode.
set -euo pipefail
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
experiments=${1:-16} goals=${2:-2} modes=${3:-"realtime lockstep"}
work=$(mktemp -d)
launch=0
cleanup() {
  [ "$launch" -gt 0 ] && kill -INT "$launch" 2>/dev/null && wait "$launch" 2>/dev/null
  rm -rf "$work"
}
trap cleanup EXIT
for mode in $modes; do
  XPERSIF_NEW_MASTER=1 source "$repo/scripts/env.sh"
  set -u
  roslaunch -p "${ROS_MASTER_URI##*:}" xpersif xpersif.launch clock_mode:="$mode" real_time_factor:=8 \
    database:="$work/$mode.db" run_dir:="$work/$mode" snapshot:=false >"$work/$mode.log" 2>&1 &
  launch=$!
  xpersif wait --timeout 180 /xpersif/loop_model >/dev/null
  started=$(date +%s.%N)
  result=$(xpersif run speed --experiments "$experiments" --goals "$goals" --design random --seed 5 | tail -1)
  ended=$(date +%s.%N)
  wall=$(awk -v a="$started" -v b="$ended" 'BEGIN { printf "%.1f", b - a }')
  per=$(awk -v w="$wall" -v n="$((experiments + goals))" 'BEGIN { printf "%.2f", w / n }')
  # Simulated seconds per push (MANIPULATION's push command, from the knowledge base): in lockstep the wall time
  # is this times the wall cost of a control tick, so it says how much of a change is the robot's motion.
  sim=$(python3 - "$work/$mode.db" <<'PY'
import sqlite3, sys
n, total = sqlite3.connect(sys.argv[1]).execute(
    "select count(*), sum(duration) from calls where name = 'push' and component like '%/manipulation'").fetchone()
print(f"{total / n:.2f} s simulated per push ({n} pushes)" if n else "no pushes recorded")
PY
)
  echo "$mode: $experiments experiments + $goals goals in $wall s = $per s per push; $sim; $result"
  # Where a lockstep tick's wall time went (XPERSim's ~status, part lockstep_timing).
  if [ "$mode" = lockstep ]; then
    timeout 10 python3 - <<'PY' || true
import rospy
from xpersif.msg import ComponentStatus
rospy.init_node("loop_speed_timing", anonymous=True)
status = rospy.wait_for_message("/xpersif/xpersim/status", ComponentStatus, timeout=5)
print("  " + "; ".join(p.message for p in status.parts if p.name == "lockstep_timing"))
PY
  fi
  kill -INT "$launch"
  wait "$launch" || true
  launch=0
done
