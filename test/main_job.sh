# Sourced by the tests that start the main job on a private master (web_browser.sh, web_foxglove.sh,
# rviz_main_screenshot.sh): stopping what they started, gently first.

# stop PID: SIGINT (roslaunch's way to end), then harder if it does not go; waits for it.
stop() {
  for signal in INT INT TERM KILL; do
    kill -"$signal" "$1" 2>/dev/null || break
    for _ in $(seq 1 50); do
      kill -0 "$1" 2>/dev/null || break 2
      sleep 0.2
    done
  done
  wait "$1" 2>/dev/null || true
}

# wait_for_web_bridge MAIN_LOG: the main job's LOOPMODEL up, then the bridge's port in $web_port; fails with the log.
wait_for_web_bridge() {
  if ! xpersif wait --timeout 180 /xpersif/loop_model >"$1.wait" 2>&1; then
    cat "$1.wait"; tail -30 "$1"
    echo "FAIL: the main job did not come up"; return 1
  fi
  web_port=""
  for _ in $(seq 1 60); do
    web_port=$(rosparam get /xpersif/web_bridge/bound_port 2>/dev/null || true)
    [[ "$web_port" =~ ^[0-9]+$ && "$web_port" != 0 ]] && return 0
    sleep 1
  done
  tail -30 "$1"; echo "FAIL: the web bridge never listened"; return 1
}
