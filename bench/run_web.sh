#!/usr/bin/env bash
# WEBBRIDGE under load (issue 18; see bench/web.md): 0, 1, 10, 50 and 100 headless WebSocket clients (one process,
# bench/web_clients.cpp) at 30 Hz and at the simulator's full rate, in one run on one machine.
#
#   bash bench/run_web.sh [build_dir=build] [out_dir=bench/results/web-<date>]
#   env: CLIENTS ("1 10 50 100"), RATES ("30 full"), DURATION (10), WARMUP (3), FRAME_RATE (1000),
#        PROTOCOL (page; foxglove: the clients speak foxglove.websocket.v1 and subscribe to /tf, every message, with
#        CLIENTS "1 8 32" and RATES "all" by default; see bench/foxglove.md)
#
# XPERSim runs the default world in fast mode, its frames capped at FRAME_RATE per wall second (the simulator's
# full rate here); the bridge is a node of its own, read-only, port chosen at random. Per configuration: frames
# delivered per client, latency from the bridge's receipt of XPERSim's /tf message (stamped into the frame) to the
# client's receipt, the bridge's CPU and RSS, the simulator's CPU and real-time factor (from /clock). The baseline,
# measured in the same run, is the same window without clients. Writes results.jsonl and prints a table.
set -eo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
BUILD=$(cd "${1:-$HERE/../build}" && pwd)
OUT=${2:-$HERE/results/web-${PROTOCOL:-page}-$(date +%Y%m%d-%H%M%S)}
PROTOCOL=${PROTOCOL:-page}
if [[ "$PROTOCOL" == foxglove ]]; then
  CLIENTS=${CLIENTS-"1 8 32"}
  RATES=${RATES-"all"}
else
  CLIENTS=${CLIENTS-"1 10 50 100"}
  RATES=${RATES-"30 full"}
fi
SECONDS_PER_RUN=${DURATION:-10}
WARMUP=${WARMUP:-3}
FRAME_RATE=${FRAME_RATE:-1000}
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
export PATH=/usr/bin:$PATH
set +u
# shellcheck disable=SC1091
source "$BUILD/devel/setup.bash"
set -u
PORT=$(/usr/bin/python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
export ROS_IP=127.0.0.1 ROS_MASTER_URI=http://127.0.0.1:$PORT ROS_LOG_DIR=$OUT/ros_log
BIN=$BUILD/devel/lib/xpersif
for b in web_clients web_bridge xpersim_node; do
  [ -x "$BIN/$b" ] || { echo "missing $BIN/$b: cmake --build $BUILD --target bench" >&2; exit 1; }
done
PIDS=()
cleanup() {
  for p in "${PIDS[@]}"; do kill -INT "$p" 2>/dev/null || true; done
  sleep 1
  for p in "${PIDS[@]}"; do kill -KILL "$p" 2>/dev/null || true; done
}
trap cleanup EXIT
roscore -p "$PORT" >"$OUT/roscore.log" 2>&1 &
PIDS+=($!)
for _ in $(seq 1 50); do rosparam list >/dev/null 2>&1 && break; sleep 0.2; done
rosparam set /use_sim_time true
"$BIN/xpersim_node" __name:=xpersim __ns:=/xpersif _world:="$HERE/../worlds/default.yaml" _clock_mode:=fast \
  _max_frame_rate:="$FRAME_RATE" _tf_rate:=1000 _autostart:=true >"$OUT/xpersim.log" 2>&1 &
SIM=$!
PIDS+=($SIM)
"$BIN/web_bridge" __name:=web_bridge _ns:=/xpersif _port:=0 _autostart:=true _max_clients:=200 >"$OUT/bridge.log" 2>&1 &
BRIDGE=$!
PIDS+=($BRIDGE)
WEB_PORT=""
for _ in $(seq 1 100); do
  WEB_PORT=$(rosparam get /web_bridge/bound_port 2>/dev/null || true)
  [[ "$WEB_PORT" =~ ^[1-9][0-9]*$ ]] && break
  sleep 0.2
done
[[ "$WEB_PORT" =~ ^[1-9][0-9]*$ ]] || { cat "$OUT/bridge.log"; echo "the bridge did not listen" >&2; exit 1; }
URL="ws://127.0.0.1:$WEB_PORT/"
{
  echo "{\"date\": \"$(date -u +%FT%TZ)\", \"host\": \"$(uname -n)\", \"cores\": $(nproc), \"frame_rate\": $FRAME_RATE," \
       "\"protocol\": \"$PROTOCOL\"," \
       "\"seconds\": $SECONDS_PER_RUN, \"code\": \"$(git -C "$HERE/.." describe --always --dirty 2>/dev/null)\"}"
} >"$OUT/meta.json"
: >"$OUT/results.jsonl"
run() {  # N RATE
  local probe clients=""
  /usr/bin/python3 "$HERE/web_probe.py" "$BRIDGE" "$SIM" "$WARMUP" "$SECONDS_PER_RUN" >"$OUT/probe.json" &
  probe=$!
  if (($1 > 0)); then
    clients=$("$BIN/web_clients" "$URL" "$1" "$2" "$SECONDS_PER_RUN" "$WARMUP" "$PROTOCOL")
  fi
  wait "$probe"
  /usr/bin/python3 - "$1" "$2" "$clients" "$OUT/probe.json" >>"$OUT/results.jsonl" <<'PY'
import json, sys
n, rate, clients, probe = int(sys.argv[1]), sys.argv[2], sys.argv[3], json.load(open(sys.argv[4]))
row = {"clients": n, "rate": rate}
row.update(probe)
if clients:
    row.update({k: v for k, v in json.loads(clients).items() if k not in ("clients", "rate")})
print(json.dumps(row))
PY
  tail -1 "$OUT/results.jsonl"
}
run 0 none
for rate in $RATES; do
  for n in $CLIENTS; do run "$n" "$rate"; done
done
run 0 none
/usr/bin/python3 - "$OUT/results.jsonl" <<'PY' | tee "$OUT/table.md"
import json, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
print("| clients | rate | frames/client (min / mean) in the window | latency p50 / p95 / p99 ms | bridge CPU % | bridge RSS MB | sim CPU % | sim real-time factor |")
print("|---|---|---|---|---|---|---|---|")
for r in rows:
    if r["clients"]:
        f = "%d / %.0f" % (r["frames_min"], r["frames_mean"])
        l = "%.2f / %.2f / %.2f" % (r["latency_ms"]["p50"], r["latency_ms"]["p95"], r["latency_ms"]["p99"])
    else:
        f = l = "–"
    print("| %d | %s | %s | %s | %.0f | %.1f | %.0f | %.1f |" % (r["clients"], r["rate"], f, l, r["bridge_cpu_pct"],
          r["bridge_rss_mb"], r["sim_cpu_pct"], r["rtf"]))
PY
echo "results in $OUT"
