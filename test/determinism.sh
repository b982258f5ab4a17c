#!/usr/bin/env bash
# Whether the lockstep loop is deterministic: the same campaign (6 experiments and 1 goal, one seed) run twice, each on a
# fresh system, gives the same knowledge base, every stored field of every experiment, goal and notion (times
# aside: scripts/compare_kb.py). Usage: determinism.sh [WORLD]
# Not in the suite yet: about one take in three still differs in the robot's pose after a push (issue 13 note).
set -euo pipefail
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
world=${1:-$repo/worlds/default.yaml}
work=$(mktemp -d)
launch=0
cleanup() {
  [ "$launch" -gt 0 ] && kill -INT "$launch" 2>/dev/null && wait "$launch" 2>/dev/null
  rm -rf "$work"
}
trap cleanup EXIT
for take in first second; do
  XPERSIF_NEW_MASTER=1 source "$repo/scripts/env.sh"
  set -u
  roslaunch -p "${ROS_MASTER_URI##*:}" xpersif xpersif.launch world:="$world" database:="$work/$take.db" \
    run_dir:="$work/$take" snapshot:=false >"$work/$take.launch.log" 2>&1 &
  launch=$!
  xpersif wait --timeout 180 /xpersif/loop_model >/dev/null || { tail -20 "$work/$take.launch.log"; exit 1; }
  started=$(date +%s)
  xpersif run campaign --experiments 6 --goals 1 --design random --seed 11 | tail -1
  echo "determinism: $take campaign took $(($(date +%s) - started)) s"
  kill -INT "$launch"
  wait "$launch" || true
  launch=0
done
/usr/bin/python3 "$repo/scripts/compare_kb.py" "$work/first.db" "$work/second.db"
echo "1 passed, 0 failed"
