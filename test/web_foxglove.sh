#!/usr/bin/env bash
# Foxglove's own client against WEBBRIDGE (issue 40): xpersif.launch web:=true headless on a private master, a short
# run in the background, and web/test/foxglove_check.mjs (@foxglove/ws-protocol's FoxgloveClient, messages decoded
# by @foxglove/rosmsg-serialization from the advertised definitions) on the bridge's port with the subprotocol
# foxglove.websocket.v1: the channels, /tf against XPERSim's ground truth, the overhead camera's JPEGs, the loop's
# progress, and clients that try to publish are closed. Logs in ${FOXGLOVE_TEST_DIR:-/tmp/xpersif_web_foxglove}.
set -euo pipefail
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
if [[ ! -d "$repo/web/node_modules/@foxglove/ws-protocol" || ! -d "$repo/web/node_modules/ws" ]]; then
  echo "FAIL: web/node_modules is missing: run 'npm ci' in web/ (bash scripts/setup.sh does it)"
  exit 1
fi
XPERSIF_NEW_MASTER=1 source "$repo/scripts/env.sh"
work=$(mktemp -d)
keep=${FOXGLOVE_TEST_DIR:-/tmp/xpersif_web_foxglove}
mkdir -p "$keep"
export ROS_LOG_DIR=$work/ros_log
source "$repo/test/main_job.sh"  # stop PID
cleanup() {
  [[ -n "${run:-}" ]] && stop "$run"
  [[ -n "${main:-}" ]] && stop "$main"
  cp "$work"/*.log "$keep/" 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT
port=${ROS_MASTER_URI##*:}

roslaunch -p "$port" xpersif xpersif.launch database:="$work/knowledge.db" run_dir:="$work/run" \
  web:=true web_port:=0 >"$work/main.log" 2>&1 &
main=$!
wait_for_web_bridge "$work/main.log" || exit 1
echo "the bridge listens on ws://127.0.0.1:$web_port"
xpersif run foxglove --experiments 3 --goals 0 --design random >"$work/run.log" 2>&1 &
run=$!
# The raw overhead image's size, as ROS gives it: the JPEG must keep it.
camera=/xpersif/observation/image_raw
width=$(timeout 60 rostopic echo -n 1 "$camera/width" | head -1)
height=$(timeout 60 rostopic echo -n 1 "$camera/height" | head -1)
echo "$camera: ${width}x${height}"
status=0
(cd "$repo/web" && node test/foxglove_check.mjs "ws://127.0.0.1:$web_port" /xpersif "$camera" "${width}x${height}") ||
  status=1
((status == 0)) && echo "passed" || echo "FAIL: see $keep"
exit $status
