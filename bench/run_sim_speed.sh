#!/usr/bin/env bash
# Simulation speed (see bench/README.md): real-time factors of
#   (a) a bare ODE loop of the default world, (b) core::PhysicsWorld, (c) the xpersim node in fast mode.
#
#   bash bench/run_sim_speed.sh [build_dir=/tmp/bench-build] [out_dir=bench/results/sim_speed-<date>]
#   env: PORT (default 11412), SIM_SECONDS (a, b: per run, default 60), REPS (default 5),
#        WALL (c: seconds measured per variant, default 10), PERF (1 = also profile the node with perf),
#        LOCAL (1 = run a and b), SCALING (1 = physics alone for the 100- and 1000-node Table I worlds),
#        VARIANTS (node variants to run, in order; default: all six, see below)
set -eo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/.." && pwd)
BUILD=${1:-/tmp/bench-build}
OUT=${2:-$HERE/results/sim_speed-$(date +%Y%m%d-%H%M%S)}
PORT=${PORT:-11412}
SIM_SECONDS=${SIM_SECONDS:-60}
REPS=${REPS:-5}
WALL=${WALL:-10}
PERF=${PERF:-1}
LOCAL=${LOCAL:-1}
SCALING=${SCALING:-1}
VARIANTS=${VARIANTS-"default default_clock_subscriber default_tf_subscriber tf_rate_100 tf_rate_10 tf_rate_10_sensor_rate_1"}
WORLD=$ROOT/worlds/default.yaml
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)

export PATH=/usr/bin:$PATH
set +u
# shellcheck disable=SC1091
source "$BUILD/devel/setup.bash"
set -u
export ROS_IP=127.0.0.1 ROS_HOSTNAME=127.0.0.1 ROS_MASTER_URI=http://127.0.0.1:$PORT ROS_LOG_DIR=$OUT/ros_log
BIN=$BUILD/devel/lib/xpersif
for b in sim_speed xpersim_node; do
  [ -x "$BIN/$b" ] || { echo "missing $BIN/$b: cmake --build $BUILD --target bench" >&2; exit 1; }
done

NODE_PID=
ROSCORE_PID=
stop() {  # stop <pid>: SIGINT, then SIGKILL after 5 s
  [ -n "$1" ] || return 0
  kill -INT "$1" 2>/dev/null || true
  for _ in $(seq 50); do kill -0 "$1" 2>/dev/null || break; sleep 0.1; done
  kill -KILL "$1" 2>/dev/null || true
  wait "$1" 2>/dev/null || true
}
cleanup() { stop "$NODE_PID"; stop "$ROSCORE_PID"; }
trap cleanup EXIT

{
  echo "date: $(date -Is)"
  echo "host: $(uname -srm), nproc $(nproc), $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')"
  echo "uptime at start: $(uptime)"
  echo "git: $(git -C "$HERE" rev-parse --short HEAD) $(git -C "$HERE" status --porcelain | grep -q . && echo '(with local changes)')"
} | tee "$OUT/machine.txt"

if [ "$LOCAL" = 1 ]; then
  echo "== (a) bare ODE and (b) PhysicsWorld: $WORLD, $SIM_SECONDS simulated s per run, $REPS runs each, interleaved"
  "$BIN/sim_speed" local "$WORLD" "$SIM_SECONDS" "$REPS" | tee -a "$OUT/local.jsonl"
fi

if (exec 3<>"/dev/tcp/127.0.0.1/$PORT") 2>/dev/null; then echo "port $PORT is in use; set PORT" >&2; exit 1; fi
roscore -p "$PORT" >"$OUT/roscore.log" 2>&1 &
ROSCORE_PID=$!
for _ in $(seq 100); do rosparam get /rosdistro >/dev/null 2>&1 && break; sleep 0.2; done

# CPU ticks (user + system) of every thread of a process: "tid ticks" lines.
thread_ticks() { for t in /proc/"$1"/task/*; do echo "${t##*/} $(awk '{print $14 + $15}' "$t/stat" 2>/dev/null)"; done; }

# variant <name> <clock_subscriber 0|1> <tf_subscriber 0|1> <extra node params...>
# Prints the sim_speed JSON line plus the node's busiest threads' CPU % over the measurement.
variant() {
  local name=$1 clock=$2 tf=$3
  shift 3
  "$BIN/xpersim_node" _world:="$WORLD" _clock_mode:=fast _autostart:=true __name:=xpersim "$@" \
    >"$OUT/node_$name.log" 2>&1 &
  NODE_PID=$!
  sleep 2
  local tf_pid=
  if [ "$tf" = 1 ]; then
    "$BIN/tf_client" _mode:=stamp _period:=0.002 _duration:=$((WALL + 2)) _label:=sim_speed \
      >"$OUT/tf_client_$name.json" 2>/dev/null &
    tf_pid=$!
  fi
  local before t0 line after t1 threads
  before=$(thread_ticks "$NODE_PID"); t0=$(date +%s.%N)
  line=$("$BIN/sim_speed" node "$WALL" /xpersim/status "$clock" 2>>"$OUT/sim_speed_node.err" || true)
  after=$(thread_ticks "$NODE_PID"); t1=$(date +%s.%N)
  threads=$(join <(sort <<<"$before") <(sort <<<"$after") |
    awk -v hz="$(getconf CLK_TCK)" -v dt="$(awk -v a="$t0" -v b="$t1" 'BEGIN{print b - a}')" \
      '{printf "%.0f\n", ($3 - $2) / hz / dt * 100}' | sort -rn | head -3 | paste -sd, -)
  echo "${line%\}},\"variant\":\"$name\",\"params\":\"$*\",\"node_busiest_threads_cpu_pct\":[$threads],\"loadavg\":\"$(cut -d' ' -f1-3 /proc/loadavg)\"}" | tee -a "$OUT/node.jsonl"
  [ -n "$tf_pid" ] && stop "$tf_pid"
  stop "$NODE_PID"
  NODE_PID=
}

echo "== (c) xpersim node, fast mode, $WALL wall s per variant"
for v in $VARIANTS; do
  case $v in
    default) variant default 0 0 ;;
    default_clock_subscriber) variant default_clock_subscriber 1 0 ;;
    default_tf_subscriber) variant default_tf_subscriber 0 1 ;;
    tf_rate_100) variant tf_rate_100 0 0 _tf_rate:=100 ;;
    tf_rate_10) variant tf_rate_10 0 0 _tf_rate:=10 ;;
    tf_rate_10_sensor_rate_1) variant tf_rate_10_sensor_rate_1 0 0 _tf_rate:=10 _sensor_rate:=1 ;;
    *) echo "unknown variant $v" >&2 ;;
  esac
done

# profile <name> <clock_subscriber 0|1>: perf (flat, 999 Hz) of the node in fast mode for 8 s.
profile() {
  local name=$1 clock=$2 sub_pid=
  echo "== perf: xpersim node, fast mode, default rates, clock subscriber $clock, 8 s"
  "$BIN/xpersim_node" _world:="$WORLD" _clock_mode:=fast _autostart:=true __name:=xpersim >"$OUT/node_perf_$name.log" 2>&1 &
  NODE_PID=$!
  sleep 2
  if [ "$clock" = 1 ]; then
    "$BIN/sim_speed" node 12 /xpersim/status 1 >"$OUT/perf_$name.sim_speed.json" 2>/dev/null &
    sub_pid=$!
    sleep 1.5
  fi
  perf record -F 999 -p "$NODE_PID" -o "$OUT/perf.data" -- sleep 8 >"$OUT/perf_record_$name.log" 2>&1 || true
  [ -n "$sub_pid" ] && stop "$sub_pid"
  stop "$NODE_PID"
  NODE_PID=
  perf report -i "$OUT/perf.data" --sort dso --stdio 2>/dev/null | grep -E '^ +[0-9]' | head -15 >"$OUT/perf_${name}_dso.txt" || true
  perf report -i "$OUT/perf.data" --sort dso,sym --stdio 2>/dev/null | grep -E '^ +[0-9]' | head -40 >"$OUT/perf_${name}_sym.txt" || true
  # Everything outside ODE, by symbol (what the simulator and ROS add to the physics).
  perf report -i "$OUT/perf.data" --sort dso,sym --stdio 2>/dev/null | grep -E '^ +[0-9]' | grep -v libode | head -30 \
    >"$OUT/perf_${name}_not_ode.txt" || true
  rm -f "$OUT/perf.data" "$OUT/perf.data.old"
  echo "-- by library (self time):"; head -8 "$OUT/perf_${name}_dso.txt"
  echo "-- outside ODE, by symbol:"; head -12 "$OUT/perf_${name}_not_ode.txt"
}
if [ "$PERF" = 1 ] && command -v perf >/dev/null; then
  profile default 0
  profile clock_subscriber 1
fi
[ "$SCALING" = 1 ] && echo "== physics alone for the bigger Table I worlds (1 ms step; what xpersim needs to keep 1 kHz in realtime mode)"
for n in $([ "$SCALING" = 1 ] && echo 100 1000); do
  "$BIN/sim_speed" local "$HERE/worlds/table1_n$n.yaml" "$([ "$n" = 1000 ] && echo 2 || echo 10)" 1 | tail -1 | tee -a "$OUT/scaling.jsonl"
done

echo "uptime at end: $(uptime)" | tee -a "$OUT/machine.txt"
