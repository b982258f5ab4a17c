#!/usr/bin/env bash
# Where a lockstep campaign's time goes: one campaign on a fresh system under a system-wide sampling profile
# (perf, cpu-clock at 999 Hz on both cores), CPU time grouped by process and by library, against the wall time.
#   bash bench/run_loop_profile.sh [EXPERIMENTS (16)] [GOALS (0)]      (needs root for perf -a)
set -euo pipefail
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
experiments=${1:-16} goals=${2:-0}
work=$(mktemp -d)
launch=0
cleanup() {
  [ "$launch" -gt 0 ] && kill -INT "$launch" 2>/dev/null && wait "$launch" 2>/dev/null
  if [ -n "${KEEP_WORK:-}" ]; then echo "kept $work"; else rm -rf "$work"; fi
}
trap cleanup EXIT
XPERSIF_NEW_MASTER=1 source "$repo/scripts/env.sh"
set -u
roslaunch -p "${ROS_MASTER_URI##*:}" xpersif xpersif.launch database:="$work/kb.db" run_dir:="$work/run" \
  snapshot:=false ${XPERSIF_LAUNCH_ARGS:-} >"$work/launch.log" 2>&1 &
launch=$!
xpersif wait --timeout 180 /xpersif/loop_model >/dev/null
sleep 2
perf record -q -e cpu-clock -F 999 -a -g -o "$work/perf.data" -- sleep 1000000 >/dev/null 2>&1 &
perf=$!
sleep 1
tick() { timeout 10 rostopic echo -n 1 /xpersif/xpersim/tick/tick 2>/dev/null | head -1 || true; }
ticks_before=$(tick)
started=$(date +%s.%N)
xpersif run profile --experiments "$experiments" --goals "$goals" --design random --seed 5 | tail -1
ended=$(date +%s.%N)
ticks_after=$(tick)
kill -INT "$perf"
wait "$perf" || true
wall=$(awk -v a="$started" -v b="$ended" 'BEGIN { printf "%.2f", b - a }')
echo "wall: $wall s for $((experiments + goals)) pushes ($(awk -v w="$wall" -v n="$((experiments + goals))" 'BEGIN { printf "%.2f", w / n }') s per push); lockstep ticks: ${ticks_before:-?} -> ${ticks_after:-?}"
perf report -i "$work/perf.data" --no-children --sort comm,dso -g none --stdio >"$work/by_dso.txt" 2>/dev/null || true
perf report -i "$work/perf.data" --no-children --sort comm -g none --stdio >"$work/by_comm.txt" 2>/dev/null || true
kill -INT "$launch"; wait "$launch" || true; launch=0   # its log is complete once it has ended
echo "--- LOOPMODEL's steps (wall s) ---"
grep -o "run [0-9]* finished after.*" "$work/launch.log" || true
echo "--- by process (swapper: the cores idle) ---"
grep -v '^#' "$work/by_comm.txt" | grep -v '^$' | head -15 || true
/usr/bin/python3 "$repo/bench/group_profile.py" "$work/by_dso.txt"
