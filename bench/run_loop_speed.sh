#!/usr/bin/env bash
# The loop's speed against its physics, the loop as it is and as it was, one after the other in one run:
#   bash bench/run_loop_speed.sh [EXPERIMENTS (16)] [GOALS (2)] [MODES ("before now")]
# Modes, each on a fresh system, random design, seed 5, the default world:
#   now       lockstep, as the main launch runs it
#   before    lockstep as before issue 37: the embodiment in a manager of its own
#             (bench/loop_speed_before_embodiment.yaml) and the cameras at their own rate, no fixes asked for
#             (bench/loop_speed_before.yaml)
#   apart     lockstep as now, but the embodiment in a manager of its own (bench/loop_speed_before_embodiment.yaml)
#   realtime  realtime x 8, as now
# For a lockstep mode it runs the campaign twice: once timed, once with XPERSim's trace (the same ticks: lockstep is
# deterministic), which bench/physics_replay steps again without messaging for the physics-only cost.
# Prints one line per mode: wall, wall per experiment (median, p90), simulated s per push, ticks, the physics-only
# cost and the ratio, and where a stepped tick's wall time went (XPERSim's ~status). KEEP_LOGS=DIR keeps the logs
# (and the traces); LAUNCH_ARGS='name:=value ...' adds xpersif.launch arguments to every mode (e.g. a parameters file).
set -euo pipefail
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
experiments=${1:-16} goals=${2:-2} modes=${3:-"before now"}
build=${XPERSIF_BUILD_DIR:-$repo/build}
cmake --build "$build" --target physics_replay >/dev/null
replay="$build/devel/lib/xpersif/physics_replay"
work=$(mktemp -d)
launch=0
cleanup() {
  [ "$launch" -gt 0 ] && kill -INT "$launch" 2>/dev/null && wait "$launch" 2>/dev/null
  rm -rf "$work"
}
trap cleanup EXIT

# run NAME CLOCK_MODE EXTRA_LAUNCH_ARGS...: one campaign on a fresh system; leaves $work/NAME.{db,log,timing,wall}
run() {
  local name=$1 mode=$2
  shift 2
  XPERSIF_NEW_MASTER=1 source "$repo/scripts/env.sh"
  set -u
  roslaunch -p "${ROS_MASTER_URI##*:}" xpersif xpersif.launch clock_mode:="$mode" real_time_factor:=8 \
    database:="$work/$name.db" run_dir:="$work/$name" snapshot:=false "$@" ${LAUNCH_ARGS:-} >"$work/$name.log" 2>&1 &
  launch=$!
  local began started ended
  began=$(date +%s.%N)
  xpersif wait --timeout 180 /xpersif/loop_model >/dev/null
  started=$(date +%s.%N)
  awk -v a="$began" -v b="$started" 'BEGIN { printf "%.1f", b - a }' >"$work/$name.bringup"
  xpersif run speed --experiments "$experiments" --goals "$goals" --design random --seed 5 | tail -1 >"$work/$name.result"
  ended=$(date +%s.%N)
  awk -v a="$started" -v b="$ended" 'BEGIN { printf "%.1f", b - a }' >"$work/$name.wall"
  # Where a lockstep tick's wall time went (XPERSim's ~status, part lockstep_timing).
  timeout 10 python3 - >"$work/$name.timing" <<'PY' || true
import rospy
from xpersif.msg import ComponentStatus
rospy.init_node("loop_speed_timing", anonymous=True)
status = rospy.wait_for_message("/xpersif/xpersim/status", ComponentStatus, timeout=5)
print("; ".join(p.message for p in status.parts if p.name == "lockstep_timing"))
PY
  kill -INT "$launch"
  wait "$launch" || true
  launch=0
  if [ -n "${KEEP_LOGS:-}" ]; then mkdir -p "$KEEP_LOGS" && cp "$work/$name.log" "$KEEP_LOGS/"; fi
}

for mode in $modes; do
  case $mode in
    now) args=() clock=lockstep ;;
    before) args=(embodiment:="$repo/bench/loop_speed_before_embodiment.yaml"
                  parameters:="$repo/bench/loop_speed_before.yaml") clock=lockstep ;;
    apart) args=(embodiment:="$repo/bench/loop_speed_before_embodiment.yaml") clock=lockstep ;;
    realtime) args=() clock=realtime ;;
    *) echo "run_loop_speed: unknown mode '$mode' (now, before, apart, realtime)" >&2; exit 2 ;;
  esac
  run "$mode" "$clock" ${args[@]+"${args[@]}"}
  physics="no physics-only figure (not lockstep)"
  if [ "$clock" = lockstep ]; then
    run "$mode-traced" "$clock" ${args[@]+"${args[@]}"} trace_file:="$work/$mode.trace"
    # XPERSim's seed is the launch's (seed:=1), not the design's.
    physics=$("$replay" "$repo/worlds/default.yaml" "$work/$mode.trace" 0.02 1 3 | tail -1)
    if [ -n "${KEEP_LOGS:-}" ]; then cp "$work/$mode.trace" "$KEEP_LOGS/"; fi
  fi
  python3 - "$mode" "$work" "$experiments" "$goals" "$physics" <<'PY'
import datetime, json, re, sqlite3, statistics, sys
mode, work, experiments, goals, physics = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), sys.argv[5]
wall = float(open(f"{work}/{mode}.wall").read())
bringup = float(open(f"{work}/{mode}.bringup").read())
db = sqlite3.connect(f"{work}/{mode}.db")
n, sim = db.execute("select count(*), sum(duration) from calls where name = 'push' "
                    "and component like '%/manipulation'").fetchone()
stamps = [datetime.datetime.strptime(c, "%Y-%m-%dT%H:%M:%S.%fZ").timestamp()
          for (c,) in db.execute("select created from experiments order by seq")]
gaps = sorted(b - a for a, b in zip(stamps, stamps[1:]))
p90 = gaps[min(len(gaps) - 1, int(round(0.9 * (len(gaps) - 1))))] if gaps else float("nan")
timing = open(f"{work}/{mode}.timing").read().strip()
ticks = re.search(r"over (\d+) ticks", timing)
line = (f"{mode}: {experiments} experiments + {goals} goals in {wall:.1f} s (after a bring-up of {bringup:.1f} s); "
        f"wall per experiment median "
        f"{statistics.median(gaps):.2f} s, p90 {p90:.2f} s; {sim / n:.2f} s simulated per push ({n} pushes)")
if physics.startswith("{"):
    p = json.loads(physics)
    line += (f"; {p['ticks']} stepped ticks, physics-only {p['physics_s_best']:.2f} s "
             f"({p['ms_per_tick_best']:.3f} ms per tick; replay off by at most {1e3 * p['robot_drift_max_m']:.1f} mm "
             f"for the robot, median {1e3 * p['object_drift_median_m']:.1f} mm for objects); "
             f"loop / physics = {wall / p['physics_s_best']:.2f}")
    in_all = re.search(r"([\d.]+) in all", timing)
    if in_all:
        line += f" (a stepped tick alone: {float(in_all.group(1)) / p['ms_per_tick_best']:.2f})"
else:
    line += "; " + physics
print(line)
print("  " + (timing or "no lockstep timing"))
print("  " + open(f"{work}/{mode}.result").read().strip())
PY
done
