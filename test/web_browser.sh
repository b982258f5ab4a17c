#!/usr/bin/env bash
# The browser viewer as a person sees it (issue 18): xpersif.launch web:=true headless on a private master, a short
# run in the background; once the run is at experiment 2 XPERSim is paused (test/view_check.py shot) and Debian's
# chromium (headless, driven by playwright-core) and then Debian's firefox-esr (under Xvfb, driven by
# puppeteer-core over WebDriver BiDi) open the page the bridge serves (web/test/browser_check.mjs). The page's view through the scene's overhead camera must show the robot and every object in its own
# colour where ground truth says (projected through that camera, as for telesim_view), and the progress panel the
# loop's current experiment number. Objects, colours and cameras come from the scene, so any world works:
# test/web_browser.sh [WORLD_FILE]. The images are kept in ${WEB_SCREENSHOT_DIR:-/tmp/xpersif_web_screenshot}.
set -euo pipefail
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
world=$(realpath "${1:-$repo/worlds/default.yaml}")
if [[ ! -d "$repo/web/node_modules/three" || ! -d "$repo/web/node_modules/playwright-core" ||
      ! -d "$repo/web/node_modules/puppeteer-core" ]]; then
  echo "FAIL: web/node_modules is missing: run 'npm ci' in web/ (bash scripts/setup.sh does it)"
  exit 1
fi
XPERSIF_NEW_MASTER=1 source "$repo/scripts/env.sh"
work=$(mktemp -d)
keep=${WEB_SCREENSHOT_DIR:-/tmp/xpersif_web_screenshot}
mkdir -p "$keep" "$work/page"
export ROS_LOG_DIR=$work/ros_log
source "$repo/test/main_job.sh"  # stop PID
cleanup() {
  [[ -n "${run:-}" ]] && stop "$run"
  [[ -n "${main:-}" ]] && stop "$main"
  rm -rf "$work"
}
trap cleanup EXIT
port=${ROS_MASTER_URI##*:}

roslaunch -p "$port" xpersif xpersif.launch world:="$world" database:="$work/knowledge.db" run_dir:="$work/run" \
  web:=true web_port:=0 >"$work/main.log" 2>&1 &
main=$!
wait_for_web_bridge "$work/main.log" || exit 1
url="http://127.0.0.1:$web_port/"
echo "the bridge serves $url"
camera=$(/usr/bin/python3 "$repo/test/view_check.py" camera)

# XPERSim is paused once the run's experiment 2 is under way; the page is opened then.
XPERSIF_SHOT_EXPERIMENT=2 /usr/bin/python3 "$repo/test/view_check.py" shot "$work/truth.json" - &
shot=$!
sleep 3
xpersif run webshot --experiments 3 --goals 0 --design random >"$work/run.log" 2>&1 &
run=$!
wait "$shot"
sim_time=$(/usr/bin/python3 -c 'import json, sys; print(json.load(open(sys.argv[1]))["time"])' "$work/truth.json")
status=0 checked=0
# One browser: its page, the view through the overhead camera against ground truth, and the progress panel.
check_browser() {  # NAME: chromium | firefox
  local name=$1 out="$work/page_$1"
  mkdir -p "$out"
  checked=$((checked + 1))
  if ! (cd "$repo/web" && BROWSER=$name node test/browser_check.mjs "$url" "$camera" "$sim_time" "$out"); then
    status=1; return
  fi
  mkdir -p "$keep/$name"
  cp "$out/"*.png "$out/page.json" "$keep/$name/" 2>/dev/null || true
  /usr/bin/python3 "$repo/test/view_check.py" telesim "$work/truth.json" "$out/$camera.png" "$camera" "web ($name)" ||
    { status=1; return; }
  # The progress panel shows the loop's experiment number at the time of the shot.
  /usr/bin/python3 - "$work/truth.json" "$out/page.json" "$name" <<'EOF2' || status=1
import json, sys
truth, page = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
want, got = truth["experiment"], page["experiment"]
print("%s: progress panel: experiment %r; LOOPMODEL's progress: experiment %r" % (sys.argv[3], got, want))
if want is None or str(want) != got:
    sys.exit("FAIL: %s: the progress panel does not show the current experiment number" % sys.argv[3])
EOF2
}
check_browser chromium
# Firefox (Debian's firefox-esr) in a window on a virtual display: headless Firefox has no WebGL.
if [[ -x /usr/bin/firefox-esr ]]; then
  source "$repo/test/xvfb.sh"
  start_xvfb "$work" 1400x900x24
  DISPLAY=$display check_browser firefox
  kill "$xvfb" 2>/dev/null || true
else
  echo "FAIL: /usr/bin/firefox-esr is missing (scripts/debian-packages.txt installs it)"; status=1
fi
rosservice call /xpersif/xpersim/resume >/dev/null
cp "$work/truth.json" "$keep/truth.json"

for _ in $(seq 1 90); do kill -0 "$run" 2>/dev/null || break; sleep 1; done
# The run outlives the pause: LOOPMODEL's wait for a new frame counts only time in which the clock moves.
echo "the run, paused while the browsers looked: $(tail -1 "$work/run.log")"
passed=$((2 * checked))
if grep -q "SUCCEEDED" "$work/run.log"; then
  passed=$((passed + 1))
else
  echo "FAIL: the run did not outlive XPERSim's pause"; status=1
fi
((status == 0)) && echo "$passed passed, 0 failed" || echo "FAIL: see $keep"
exit $status
