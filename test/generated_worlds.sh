#!/usr/bin/env bash
# Generated worlds run the loop (issue 38, item 3): `xpersif generate-world` for two seeds nobody tuned anything to
# (4 and 6 objects), each checked by `xpersif check-world` and then run by loop_world.test: the grid design over
# every object, the immovable ones named in a notion (test_loop_world reads them from the file's masses). The second
# world's cameras are renamed (ceiling_cam, onboard): OBSERVATION and PERCEPTION take them by their mounts; it runs
# from another directory than the one it was written to (a robot named by package://).
# The unit test WorldGenerator.* checks 160 seeds without ROS (parse, perception at the start).
# usage: generated_worlds.sh BUILD_DIR
set -eo pipefail
BUILD=$(cd "$1" && pwd)
# shellcheck disable=SC1091
source "$BUILD/devel/setup.bash"
set -u
export PATH="$BUILD/devel/lib/xpersif:$PATH" ROS_IP=127.0.0.1
T=$(mktemp -d /tmp/xpersif-generated-XXXXXX)
trap 'rm -rf "$T"' EXIT
for seed_and_count in "4101 4" "4102 6"; do
  read -r seed count <<<"$seed_and_count"
  world="$T/generated_$seed.yaml"
  xpersif generate-world --seed "$seed" --objects "$count" --out "$world"
  # The second world names its cameras as a lab might: the components find them by their mounts. It is also moved to
  # another directory first: its robot is named package://xpersif/..., so it loads wherever it is copied.
  if [[ $count == 6 ]]; then
    grep -q "urdf: package://xpersif/urdf/" "$world" || { grep urdf "$world"; echo "FAIL: the robot is not named by package"; exit 1; }
    mkdir "$T/moved" && mv "$world" "$T/moved/" && world="$T/moved/generated_$seed.yaml"
    sed -i 's/{name: overhead,/{name: ceiling_cam,/; s/{name: robot_camera,/{name: onboard,/' "$world"
    grep -q "name: ceiling_cam" "$world" && grep -q "name: onboard" "$world" || { echo "FAIL: cameras not renamed"; exit 1; }
  fi
  xpersif check-world "$world" >"$T/check_$seed.log" || { cat "$T/check_$seed.log"; echo "FAIL: check-world refused $world"; exit 1; }
  grep "#" "$world" | grep -v "^#" | sed 's/.*name: \([a-z_0-9]*\).*# \(.*\)/  \1: \2/'
  if ! rostest xpersif loop_world.test world:="$world" >"$T/loop_$seed.log" 2>&1 ||
     ! grep -qF "ExperimentsOnEveryObjectAndTheImmovableNamed][passed]" "$T/loop_$seed.log"; then
    grep -aE "Failure|FAILED|Expected|Which is|error|RESULT" "$T/loop_$seed.log" | tail -30 || true
    echo "FAIL: the loop on the world of seed $seed"
    exit 1
  fi
  echo "ok: the loop ran on the world of seed $seed ($count objects)"
done
echo PASS
