#!/usr/bin/env bash
# The loop under load (issue 19, item 5): the same short campaign on fresh systems, one after the other in one
# run, without and with N clients calling get_features (OBSERVATION) and get_robot_state (ROBOTMODEL) at RATE Hz
# each (bench/service_load.cpp). Prints the loop's experiments per minute for each, and the clients' figures.
#   bash bench/run_service_load.sh [EXPERIMENTS (12)] [CLIENTS ("0 100")] [RATE (50)]
# CLOCK_MODE=realtime REAL_TIME_FACTOR=1: the loop paced by simulated time (a real robot's case) instead of by the CPU.
# LOAD_NICE=19 runs the clients at the lowest CPU priority (they share the 2 cores with the loop here).
# Build first: cmake --build build --target service_load
set -euo pipefail
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
experiments=${1:-12} loads=${2:-"0 100"} rate=${3:-50}
work=$(mktemp -d)
launch=0 load=0
cleanup() {
  [ "$load" -gt 0 ] && kill -INT "$load" 2>/dev/null
  [ "$launch" -gt 0 ] && kill -INT "$launch" 2>/dev/null && wait "$launch" 2>/dev/null
  rm -rf "$work"
}
trap cleanup EXIT
for clients in $loads; do
  XPERSIF_NEW_MASTER=1 source "$repo/scripts/env.sh"
  set -u
  [ -x "$(command -v service_load)" ] || { echo "build service_load first: cmake --build build --target service_load" >&2; exit 1; }
  roslaunch -p "${ROS_MASTER_URI##*:}" xpersif xpersif.launch database:="$work/$clients.db" run_dir:="$work/$clients" \
    snapshot:=false clock_mode:="${CLOCK_MODE:-lockstep}" real_time_factor:="${REAL_TIME_FACTOR:-1}" >"$work/$clients.log" 2>&1 &
  launch=$!
  xpersif wait --timeout 180 /xpersif/loop_model >/dev/null
  if [ "$clients" -gt 0 ]; then
    nice -n "${LOAD_NICE:-0}" service_load --clients "$clients" --rate "$rate" --duration 100000 >"$work/load_$clients.txt" 2>&1 &
    load=$!
    sleep 5  # the clients connected and calling before the campaign starts
  fi
  started=$(date +%s.%N)
  result=$(xpersif run load --experiments "$experiments" --goals 0 --design random --seed 5 | tail -1)
  ended=$(date +%s.%N)
  echo "$clients clients: $experiments experiments in $(awk -v a="$started" -v b="$ended" 'BEGIN { printf "%.1f s = %.1f per minute", b - a, 60 * '"$experiments"' / (b - a) }'); $result"
  if [ "$load" -gt 0 ]; then
    kill -INT "$load"
    wait "$load" || true
    load=0
    cat "$work/load_$clients.txt"
  fi
  echo "processes died: $(grep -c "process has died" "$work/$clients.log" || true)"
  kill -INT "$launch"
  wait "$launch" || true
  launch=0
done
