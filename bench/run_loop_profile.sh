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
  rm -rf "$work"
}
trap cleanup EXIT
XPERSIF_NEW_MASTER=1 source "$repo/scripts/env.sh"
set -u
roslaunch -p "${ROS_MASTER_URI##*:}" xpersif xpersif.launch database:="$work/kb.db" run_dir:="$work/run" \
  snapshot:=false >"$work/launch.log" 2>&1 &
launch=$!
xpersif wait --timeout 180 /xpersif/loop_model >/dev/null
sleep 2
perf record -q -e cpu-clock -F 999 -a -g -o "$work/perf.data" -- sleep 1000000 >/dev/null 2>&1 &
perf=$!
sleep 1
ticks_before=$(rosservice call /xpersif/xpersim/get_state 2>/dev/null | grep -o 'tick [0-9]*' | head -1 | awk '{print $2}')
started=$(date +%s.%N)
xpersif run profile --experiments "$experiments" --goals "$goals" --design random --seed 5 | tail -1
ended=$(date +%s.%N)
ticks_after=$(rosservice call /xpersif/xpersim/get_state 2>/dev/null | grep -o 'tick [0-9]*' | head -1 | awk '{print $2}')
kill -INT "$perf"
wait "$perf" || true
wall=$(awk -v a="$started" -v b="$ended" 'BEGIN { printf "%.2f", b - a }')
echo "wall: $wall s for $((experiments + goals)) pushes ($(awk -v w="$wall" -v n="$((experiments + goals))" 'BEGIN { printf "%.2f", w / n }') s per push); lockstep ticks: ${ticks_before:-?} -> ${ticks_after:-?}"
perf report -i "$work/perf.data" --no-children --sort comm,dso -g none --percent-limit 0.3 --stdio 2>/dev/null \
  | grep -v '^#' | grep -v '^$' > "$work/by_dso.txt"
perf report -i "$work/perf.data" --no-children --sort comm -g none --stdio 2>/dev/null | grep -v '^#' | grep -v '^$' \
  > "$work/by_comm.txt"
samples=$(perf report -i "$work/perf.data" --stdio 2>/dev/null | grep -m1 '^# Samples' | awk '{print $3}')
echo "samples: $samples (at 999 Hz on 2 cores: $(awk -v s="$samples" -v w="$wall" 'BEGIN { printf "%.0f", 100 * s / 999 / 2 / w }') % of both cores busy, idle included in the rest)"
echo "--- by process ---"; head -15 "$work/by_comm.txt"
echo "--- by process and library ---"; head -40 "$work/by_dso.txt"
/usr/bin/python3 "$repo/bench/group_profile.py" "$work/by_dso.txt"
