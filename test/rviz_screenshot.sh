#!/usr/bin/env bash
# What a person sees: XPERSim with rviz under Xvfb (software GL), a screenshot, and a check of it (top-down view,
# x right, y up). `rviz_screenshot.sh` (the default world): the red, green and blue cubes drawn where they are
# relative to each other, red (0.05, 0.15) and green (0.05, -0.15) left of blue (0.25, 0), red above green.
# `rviz_screenshot.sh fiducial` (worlds/ordinary.yaml): the robot's ArUco fiducial drawn on it, a white plate
# holding black cells, left of the arena's centre where the robot starts (-0.5, 0).
set -euo pipefail
mode=${1:-cubes}
case "$mode" in
  cubes) world_arg=() ;;
  fiducial) world_arg=(world:="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)/worlds/ordinary.yaml") ;;
  *) echo "rviz_screenshot.sh: unknown check '$mode' (cubes or fiducial)" >&2; exit 2 ;;
esac
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
XPERSIF_NEW_MASTER=1 source "$repo/scripts/env.sh"
work=$(mktemp -d)
source "$repo/test/xvfb.sh"
start_xvfb "$work" 1280x900x24
cleanup() {
  kill -INT "${launch:-0}" 2>/dev/null || true
  wait "${launch:-0}" 2>/dev/null || true
  kill "$xvfb" 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT
export DISPLAY=$display LIBGL_ALWAYS_SOFTWARE=1
has_window() { xwininfo -root -tree 2>/dev/null | grep -i rviz >/dev/null; }
start_view() {
  roslaunch -p "${ROS_MASTER_URI##*:}" xpersif xpersim.launch rviz:=true rviz_config:="$repo/test/rviz_topdown.rviz" \
    "${world_arg[@]}" >>"$work/launch.log" 2>&1 &
  launch=$!
  # Software GL is slow to start: wait until rviz has a window, then a little for markers and the robot.
  for _ in $(seq 1 90); do
    has_window && return 0
    sleep 1
  done
}
start_view
# rviz under software GL has once died within seconds of starting (as rviz_main_screenshot.sh saw): once, start
# it again; a second time is a failure, with the launch's own words.
if ! has_window; then
  echo "rviz showed no window on $display within 90 s; starting it once more"
  kill -INT "$launch" 2>/dev/null || true
  wait "$launch" 2>/dev/null || true
  start_view
fi
if ! has_window; then
  echo "FAIL: rviz showed no window on $display, twice; the launch's last lines:"
  tail -n 30 "$work/launch.log"
  exit 1
fi
sleep 12
/usr/bin/import -window root "$work/shot.png"
cp "$work/shot.png" "${RVIZ_SCREENSHOT:-/tmp/xpersif_rviz_screenshot_$mode.png}"
/usr/bin/python3 - "$work/shot.png" "$mode" <<'PY'
import subprocess, sys
png, mode = sys.argv[1], sys.argv[2]
size = subprocess.check_output(["/usr/bin/identify", "-format", "%w %h", png]).decode().split()
w, h = int(size[0]), int(size[1])
raw = subprocess.check_output(["/usr/bin/convert", png, "-depth", "8", "rgb:-"])
def centroid(test):
    xs = ys = n = 0
    for y in range(0, h, 2):
        row = y * w * 3
        for x in range(0, w, 2):
            r, g, b = raw[row + 3 * x], raw[row + 3 * x + 1], raw[row + 3 * x + 2]
            if test(r, g, b):
                xs += x; ys += y; n += 1
    return (xs / n, ys / n, n) if n else None
if mode == "fiducial":
    # The 3D view is right of the display panel (x > 350, 62 < y < 780); the plate is the only pure white there.
    xs, ys = [], []
    for y in range(62, min(h, 780)):
        row = y * w * 3
        for x in range(350, w):
            if min(raw[row + 3 * x:row + 3 * x + 3]) >= 250:
                xs.append(x); ys.append(y)
    if not xs:
        print("FAIL: no white fiducial plate in the screenshot")
        sys.exit(1)
    x0, x1, y0, y1 = min(xs), max(xs), min(ys), max(ys)
    dark = sum(1 for y in range(y0, y1 + 1) for x in range(x0, x1 + 1) if max(raw[y * w * 3 + 3 * x:y * w * 3 + 3 * x + 3]) < 40)
    share = dark / float((x1 - x0 + 1) * (y1 - y0 + 1))
    view_centre = (350 + w) / 2.0
    print("rviz screenshot %dx%d: plate %d..%d x %d..%d, %.2f of it black cells" % (w, h, x0, x1, y0, y1, share))
    ok = 10 < x1 - x0 < 120 and 10 < y1 - y0 < 120 and 0.25 < share < 0.75 and (x0 + x1) / 2.0 < view_centre
    if not ok:
        print("FAIL: the robot's fiducial is missing, misshapen or misplaced in the screenshot")
        sys.exit(1)
    print("1 passed, 0 failed")
    sys.exit(0)
red = centroid(lambda r, g, b: r > 150 and g < 80 and b < 80)
green = centroid(lambda r, g, b: g > 120 and r < 80 and b < 90)
blue = centroid(lambda r, g, b: b > 150 and r < 80 and g < 100)
print("rviz screenshot %dx%d: red %s green %s blue %s" % (w, h, red, green, blue))
ok = red and green and blue and red[2] > 20 and green[2] > 20 and blue[2] > 20
ok = ok and red[0] < blue[0] and green[0] < blue[0] and red[1] < green[1]
if not ok:
    print("FAIL: the cubes are missing or misplaced in the screenshot")
    sys.exit(1)
print("1 passed, 0 failed")
PY
