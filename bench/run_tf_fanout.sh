#!/usr/bin/env bash
# Table I again: tf fan-out from one publisher to N client processes over loopback (see bench/README.md).
#
#   bash bench/run_tf_fanout.sh [build_dir=/tmp/bench-build] [out_dir=bench/results/tf_fanout-<date>]
#   env: PORT (master port, default 11411), DURATION (s per run, default 5), CLIENTS ("1 3 5 10 50 100"),
#        SIZES ("7 15 100 1000"), SIZE_CLIENTS (10),
#        HOSTS=1: across hosts (as root): roscore and the publisher in one network namespace (10.213.9.1), the
#        clients in another (10.213.9.2), joined by a veth pair; created here and removed on exit. Defaults
#        then CLIENTS="1 10 50 100", SIZES="" (bench/README.md, "Across hosts").
#
# Part 1: clients in CLIENTS, 15 transforms per frame, for the raw roscpp publisher and for xpersim
#         (realtime, tf_rate 1000, 1 ms physics step, world table1_n15.yaml: 15 dynamic nodes).
# Part 2: SIZE_CLIENTS clients, scenes of SIZES dynamic nodes, for both publishers (7 = the paper's
#         scene, table1.yaml: robot base, two wheels, four cubes).
# Every client measures the same wall-clock window of DURATION s, which opens once all clients have had
# time to start. Writes clients.jsonl (one JSON line per client) and meta.json per run, and tf_fanout.md.
set -eo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
BUILD=${1:-/tmp/bench-build}
OUT=${2:-$HERE/results/tf_fanout-$(date +%Y%m%d-%H%M%S)}
PORT=${PORT:-11411}
DURATION=${DURATION:-5}
HOSTS=${HOSTS:-0}
if [ "$HOSTS" = 1 ]; then
  CLIENTS=${CLIENTS-"1 10 50 100"}
  SIZES=${SIZES-""}
else
  CLIENTS=${CLIENTS-"1 3 5 10 50 100"}
  SIZES=${SIZES-"7 15 100 1000"}
fi
SIZE_CLIENTS=${SIZE_CLIENTS:-10}
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)

export PATH=/usr/bin:$PATH   # ROS's python tools need Debian's python3
set +u
# shellcheck disable=SC1091
source "$BUILD/devel/setup.bash"
set -u
export ROS_IP=127.0.0.1 ROS_HOSTNAME=127.0.0.1 ROS_MASTER_URI=http://127.0.0.1:$PORT ROS_LOG_DIR=$OUT/ros_log
# Where the publisher side (roscore, publisher) and the clients run: here, or in two network namespaces.
PUB=()
CLI=()
NETNS_PUB="" NETNS_CLI=""
if [ "$HOSTS" = 1 ]; then
  [ "$(id -u)" = 0 ] || { echo "HOSTS=1 needs root (ip netns)" >&2; exit 1; }
  NETNS_PUB="xpfo$$pub" NETNS_CLI="xpfo$$cli"
  ip netns add "$NETNS_PUB"
  ip netns add "$NETNS_CLI"
  ip -n "$NETNS_PUB" link add eth0 type veth peer name eth0 netns "$NETNS_CLI"
  ip -n "$NETNS_PUB" addr add 10.213.9.1/24 dev eth0
  ip -n "$NETNS_CLI" addr add 10.213.9.2/24 dev eth0
  for ns in "$NETNS_PUB" "$NETNS_CLI"; do ip -n "$ns" link set eth0 up; ip -n "$ns" link set lo up; done
  PUB=(ip netns exec "$NETNS_PUB" env -u LD_PRELOAD -u XPERSIF_BIND_ADDRESS ROS_IP=10.213.9.1 ROS_HOSTNAME=10.213.9.1)
  CLI=(ip netns exec "$NETNS_CLI" env -u LD_PRELOAD -u XPERSIF_BIND_ADDRESS ROS_IP=10.213.9.2 ROS_HOSTNAME=10.213.9.2)
  export ROS_MASTER_URI=http://10.213.9.1:$PORT
fi
BIN=$BUILD/devel/lib/xpersif
for b in tf_raw_publisher tf_client xpersim_node; do
  [ -x "$BIN/$b" ] || { echo "missing $BIN/$b: cmake --build $BUILD --target bench" >&2; exit 1; }
done

PIDS=()
ROSCORE_PID=
cleanup() {
  for p in "${PIDS[@]}"; do kill -INT "$p" 2>/dev/null || true; done
  sleep 0.5
  for p in "${PIDS[@]}"; do kill -KILL "$p" 2>/dev/null || true; done
  if [ -n "$ROSCORE_PID" ]; then
    kill -INT "$ROSCORE_PID" 2>/dev/null || true
    for _ in $(seq 50); do kill -0 "$ROSCORE_PID" 2>/dev/null || break; sleep 0.1; done
    kill -KILL "$ROSCORE_PID" 2>/dev/null || true
  fi
  for ns in $NETNS_PUB $NETNS_CLI; do
    pids=$(ip netns pids "$ns" 2>/dev/null || true)
    [ -z "$pids" ] || kill -KILL $pids 2>/dev/null || true
    ip netns del "$ns" 2>/dev/null || true
  done
}
trap cleanup EXIT

if [ "$HOSTS" != 1 ] && { curl -s -m 1 "http://127.0.0.1:$PORT" >/dev/null 2>&1 || (exec 3<>/dev/tcp/127.0.0.1/$PORT) 2>/dev/null; }; then
  echo "port $PORT is in use; set PORT" >&2; exit 1
fi
"${PUB[@]}" roscore -p "$PORT" >"$OUT/roscore.log" 2>&1 &
ROSCORE_PID=$!
for _ in $(seq 100); do "${CLI[@]}" rosparam get /rosdistro >/dev/null 2>&1 && break; sleep 0.2; done
"${CLI[@]}" rosparam get /rosdistro >/dev/null || { echo "roscore did not come up (or the clients' side cannot reach it)" >&2; exit 1; }

cpu_ticks() { awk '{print $14 + $15}' "/proc/$1/stat" 2>/dev/null || echo 0; }

# run <publisher raw|xpersim> <transforms> <clients>
run() {
  local pub=$1 n=$2 clients=$3
  local tag=${pub}_n${n}_c${clients} dir=$OUT/${pub}_n${n}_c${clients}
  mkdir -p "$dir"
  local mode period world="" ppid
  if [ "$pub" = raw ]; then
    "${PUB[@]}" "$BIN/tf_raw_publisher" _n:="$n" _rate:=1000 __name:=tf_raw_publisher >"$dir/publisher.log" 2>&1 &
    ppid=$!
    mode=seq; period=0.001
    sleep 1
  else
    world=$HERE/worlds/table1_n$n.yaml
    [ "$n" = 7 ] && world=$HERE/worlds/table1.yaml
    "${PUB[@]}" "$BIN/xpersim_node" _world:="$world" _clock_mode:=realtime _tf_rate:=1000 _autostart:=true __name:=xpersim \
      >"$dir/publisher.log" 2>&1 &
    ppid=$!
    mode=stamp; period=0.001
    sleep $([ "$n" -ge 1000 ] && echo 4 || echo 2)
  fi
  PIDS+=("$ppid")
  # The window opens once every client has had time to start (a roscpp process start costs ~50 ms CPU).
  local margin start
  margin=$(awk -v c="$clients" 'BEGIN{printf "%.2f", 1.5 + 0.08 * c}')
  start=$(awk -v m="$margin" -v now="$(date +%s.%N)" 'BEGIN{printf "%.3f", now + m}')
  local cpids=()
  for i in $(seq "$clients"); do
    "${CLI[@]}" "$BIN/tf_client" _mode:=$mode _period:=$period _duration:="$DURATION" _start_wall:="$start" _label:="$tag" \
      _timeout:=$(awk -v m="$margin" -v d="$DURATION" 'BEGIN{print m + d + 20}') \
      >"$dir/client_$i.json" 2>"$dir/client_$i.err" &
    cpids+=($!)
  done
  PIDS+=("${cpids[@]}")
  # Publisher CPU over the measurement window.
  sleep "$(awk -v s="$start" -v now="$(date +%s.%N)" 'BEGIN{d = s - now; print (d > 0 ? d : 0)}')"
  local t0 c0 t1 c1
  t0=$(date +%s.%N); c0=$(cpu_ticks "$ppid")
  sleep "$DURATION"
  t1=$(date +%s.%N); c1=$(cpu_ticks "$ppid")
  local load
  load=$(cut -d' ' -f1-3 /proc/loadavg)
  for p in "${cpids[@]}"; do wait "$p" || true; done
  # One file per run: every client's JSON line (and their stderr, if any).
  cat "$dir"/client_*.json >"$dir/clients.jsonl" && rm -f "$dir"/client_*.json
  cat "$dir"/client_*.err >"$dir/clients.err" && rm -f "$dir"/client_*.err
  [ -s "$dir/clients.err" ] || rm -f "$dir/clients.err"
  kill -INT "$ppid" 2>/dev/null || true
  for _ in $(seq 50); do kill -0 "$ppid" 2>/dev/null || break; sleep 0.1; done
  kill -KILL "$ppid" 2>/dev/null || true
  wait "$ppid" 2>/dev/null || true
  PIDS=()
  local cpu
  cpu=$(awk -v a="$c0" -v b="$c1" -v t0="$t0" -v t1="$t1" -v hz="$(getconf CLK_TCK)" 'BEGIN{printf "%.0f", (b - a) / hz / (t1 - t0) * 100}')
  printf '{"publisher":"%s","transforms":%s,"clients":%s,"world":"%s","duration_s":%s,"publisher_cpu_pct":%s,"loadavg":"%s"}\n' \
    "$pub" "$n" "$clients" "${world#"$HERE"/}" "$DURATION" "$cpu" "$load" >"$dir/meta.json"
  echo "$(date +%T) $tag: publisher CPU ${cpu}%, load $load, $(grep -c '"received"' "$dir/clients.jsonl") client reports"
}

{
  echo "date: $(date -Is)"
  echo "host: $(uname -srm), nproc $(nproc), $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')"
  echo "uptime at start: $(uptime)"
  [ "$HOSTS" = 1 ] && echo "hosts: roscore and publisher in netns $NETNS_PUB (10.213.9.1), clients in $NETNS_CLI (10.213.9.2), veth"
  echo "git: $(git -C "$HERE" rev-parse --short HEAD) $(git -C "$HERE" status --porcelain | grep -q . && echo '(with local changes)')"
} | tee "$OUT/machine.txt"

for pub in raw xpersim; do
  for c in $CLIENTS; do run "$pub" 15 "$c"; done
done
for n in $SIZES; do
  for pub in raw xpersim; do
    [ -f "$OUT/${pub}_n${n}_c${SIZE_CLIENTS}/meta.json" ] || run "$pub" "$n" "$SIZE_CLIENTS"
  done
done
echo "uptime at end: $(uptime)" | tee -a "$OUT/machine.txt"

/usr/bin/python3 "$HERE/summarize_tf.py" "$OUT" | tee "$OUT/tf_fanout.md"
