#!/usr/bin/env bash
# Every service and action of the running main system, every kind of bad input (issue 19, item 2): brings up
# launch/xpersif.launch headless on a master of its own (lockstep, the default world, a fresh knowledge base),
# waits until every component is ACTIVE, runs test/service_battery.py against it (see its docstring: what is sent,
# what is checked) and stops the system. The table of inputs and outcomes goes to $OUT
# (default /tmp/xpersif_service_battery.md; bench/reliability.md keeps the last one). Then bad bytes on every
# topic the system subscribes to (test/topic_garbage.py; its table to $TOPIC_OUT).
#   bash test/service_battery.sh BUILD_DIR [COMPONENT]
set -euo pipefail
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
BUILD=$(cd "${1:-$HERE/build}" && pwd)
ONLY=${2:-}
OUT=${OUT:-/tmp/xpersif_service_battery.md}
export PATH=/usr/bin:$PATH
set +u
# shellcheck disable=SC1091
source "$BUILD/devel/setup.bash"
set -u
export PATH="$BUILD/devel/lib/xpersif:$PATH" ROS_IP=127.0.0.1 ROS_HOSTNAME=127.0.0.1
T=$(mktemp -d /tmp/xpersif-battery-XXXXXX)
PORT=$(/usr/bin/python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
export ROS_MASTER_URI=http://127.0.0.1:$PORT ROS_LOG_DIR=$T/ros_log
LAUNCH_PID=
cleanup() {
  if [ -n "$LAUNCH_PID" ]; then
    kill -INT "$LAUNCH_PID" 2>/dev/null || true
    for _ in $(seq 60); do kill -0 "$LAUNCH_PID" 2>/dev/null || break; sleep 0.5; done
    kill -KILL "$LAUNCH_PID" 2>/dev/null || true
  fi
  [ -n "${KEEP:-}" ] || rm -rf "$T"
}
trap cleanup EXIT
fail() { echo "FAIL: $*" >&2; tail -30 "$T/launch.log" >&2; exit 1; }

roslaunch -p "$PORT" xpersif xpersif.launch database:="$T/knowledge.db" run_dir:="$T/run" >"$T/launch.log" 2>&1 &
LAUNCH_PID=$!
# The components the launch brings up: the configured ones less LOOPMODEL's ~omit (web:=false leaves out WEBBRIDGE).
omit="[]"
for _ in $(seq 120); do
  omit=$(rosparam get /xpersif/loop_model/omit 2>/dev/null) && break
  sleep 0.5
done
components=$(/usr/bin/python3 -c '
import yaml, sys
omit = set(yaml.safe_load(sys.argv[1]) or [])
names = []
for f in sys.argv[2:]:
    names += [c["name"] for c in yaml.safe_load(open(f))["components"] if c["name"] not in omit]
print(" ".join("/xpersif/" + n for n in names))' "$omit" "$HERE/config/loop.yaml" "$HERE/config/embodiment.yaml")
xpersif wait --timeout 240 /xpersif/loop_model $components >"$T/wait.log" 2>&1 || { cat "$T/wait.log" >&2; fail "the system did not come up"; }
echo "system up: $(echo "$components" | wc -w) components ACTIVE"
started=$SECONDS
code=0
/usr/bin/python3 "$HERE/test/service_battery.py" --kb "$T/knowledge.db" --out "$OUT" ${ONLY:+--only "$ONLY"} || code=$?
echo "battery: $((SECONDS - started)) s; table in $OUT"
# Bad bytes on every topic connection: a forged publisher per subscribed topic (see test/topic_garbage.py).
started=$SECONDS
/usr/bin/python3 "$HERE/test/topic_garbage.py" --kb "$T/knowledge.db" --out "${TOPIC_OUT:-/tmp/xpersif_topic_garbage.md}" || code=1
echo "topic garbage: $((SECONDS - started)) s; table in ${TOPIC_OUT:-/tmp/xpersif_topic_garbage.md}"
kill -0 "$LAUNCH_PID" 2>/dev/null || fail "roslaunch ended during the battery"
grep -n "process has died\|terminate called\|Segmentation" "$T/launch.log" && fail "a process died during the battery"
exit "$code"
