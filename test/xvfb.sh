# Sourced by the screenshot tests: start_xvfb WORK_DIR WxHxD starts Xvfb on a display number it chooses itself
# (-displayfd: never one another test holds) and returns once it accepts clients, setting $display and $xvfb.
# A client started before Xvfb is ready cannot open the display, and rviz then never shows a window.
start_xvfb() {
  local work=$1 screen=$2 number=""
  Xvfb -displayfd 3 -screen 0 "$screen" 3>"$work/xvfb.display" >"$work/xvfb.log" 2>&1 &
  xvfb=$!
  for _ in $(seq 1 100); do
    number=$(head -n 1 "$work/xvfb.display" 2>/dev/null || true)
    [[ -n "$number" ]] && break
    kill -0 "$xvfb" 2>/dev/null || break
    sleep 0.1
  done
  if [[ -z "$number" ]]; then
    echo "FAIL: Xvfb did not start; its log:" >&2
    tail -n 20 "$work/xvfb.log" >&2 || true
    return 1
  fi
  display=":$number"
}
