#!/usr/bin/env bash
# The lockstep protocol's floor on this machine: XPERSim alone (launch/xpersim.launch, lockstep, the default
# world) and one do-nothing actor in its own process (bench/lockstep_floor.cpp), N ticks.
#   bash bench/run_lockstep_floor.sh [TICKS (2000)]     (after `cmake --build build --target lockstep_floor`)
set -euo pipefail
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
ticks=${1:-2000}
XPERSIF_NEW_MASTER=1 source "$repo/scripts/env.sh"
set -u
roslaunch -p "${ROS_MASTER_URI##*:}" xpersif xpersim.launch clock_mode:=lockstep >/tmp/xpersif_lockstep_floor.log 2>&1 &
launch=$!
trap 'kill -INT $launch 2>/dev/null; wait $launch 2>/dev/null' EXIT
until rosservice list 2>/dev/null | grep -q /xpersim/lockstep; do sleep 0.5; done
sleep 2
"$repo/build/devel/lib/xpersif/lockstep_floor" "$ticks" __name:=lockstep_floor _xpersim:=/xpersim
