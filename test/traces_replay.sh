#!/usr/bin/env bash
# Replay (issue 6, item 4): `rosbag play --clock` of a recorded run drives the perception and learning
# components to the same feature vectors and predictions as the live run.
#  1. live: launch/xpersif.launch record:=true record_images:=true (the whole loop, recorded with rosbag into
#     a run directory) and a short run of EXPERIMENTS random experiments (`xpersif run`); stopped with SIGINT;
#  2. replay: a fresh master on simulated time where only a FEATUREEXTRACTION (camera overhead, fed the
#     recorded /xpersif/observation/image_raw and the latched /xpersif/xpersim/scene) and a MACHINELEARNING
#     (~restore false, fed the recorded /xpersif/knowledge_base/experiments) run, under names of their own so
#     their outputs do not collide with the recorded ones; `rosbag play --clock` plays the recorded inputs
#     (/tf, /tf_static, the scene, the overhead images, the experiment records) and a second recorder keeps
#     what the two components publish;
#  3. test_replay (test/integration/test_replay.cpp) compares: feature vectors matched by image stamp
#     (objects, poses, blobs to 1e-9), learned models matched by run and sample count (byte-identical,
#     identical predictions), and the live predictions of the records reproduced by the replayed models.
#   bash test/traces_replay.sh BUILD_DIR     (env PORT, default 11541; EXPERIMENTS, default 5; RATE, play
#                                             rate, default 2; KEEP=1 keeps the temporary directory)
set -eo pipefail
HERE=$(cd "$(dirname "$0")/.." && pwd)
BUILD=$(cd "${1:-$HERE/build}" && pwd)
PORT=${PORT:-11541}
EXPERIMENTS=${EXPERIMENTS:-5}
RATE=${RATE:-2}
export PATH=/usr/bin:$PATH
set +u
# shellcheck disable=SC1091
source "$BUILD/devel/setup.bash"
set -u
BIN=$BUILD/devel/lib/xpersif
export PATH=$BIN:$PATH
T=$(mktemp -d /tmp/xpersif-replay-XXXXXX)
export ROS_IP=127.0.0.1 ROS_HOSTNAME=127.0.0.1 ROS_MASTER_URI=http://127.0.0.1:$PORT ROS_LOG_DIR=$T/ros_log
PIDS=()
cleanup() {
  for p in "${PIDS[@]}"; do kill -INT "$p" 2>/dev/null || true; done
  for p in "${PIDS[@]}"; do for _ in $(seq 50); do kill -0 "$p" 2>/dev/null || break; sleep 0.2; done; done
  for p in "${PIDS[@]}"; do kill -KILL "$p" 2>/dev/null || true; done
  [ -n "${KEEP:-}" ] && echo "kept $T" || rm -rf "$T"
}
trap cleanup EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
ok() { echo "ok: $*"; }
wait_gone() { for _ in $(seq "${2:-150}"); do kill -0 "$1" 2>/dev/null || return 0; sleep 0.2; done; return 1; }
if (exec 3<>/dev/tcp/127.0.0.1/$PORT) 2>/dev/null; then fail "port $PORT is in use; set PORT"; fi

# 1. The live run, recorded.
LIVE=$T/live
roslaunch -p "$PORT" xpersif xpersif.launch database:="$T/knowledge.db" run_dir:="$LIVE" record:=true \
  record_images:=true snapshot:=false >"$T/live.launch.log" 2>&1 &
LAUNCH=$!
PIDS+=("$LAUNCH")
xpersif wait --timeout 240 /xpersif/loop_model >"$T/wait.log" 2>&1 ||
  fail "the loop did not come up: $(tail -5 "$T/wait.log"); see $T/live.launch.log"
xpersif run replay --design random --experiments "$EXPERIMENTS" --goals 0 --seed 3 >"$T/run.log" 2>&1 ||
  fail "the live run failed: $(tail -5 "$T/run.log")"
grep -q SUCCEEDED "$T/run.log" || fail "the live run did not succeed: $(tail -5 "$T/run.log")"
sleep 2  # the last record, model and features reach the recorder
kill -INT "$LAUNCH"
wait_gone "$LAUNCH" || fail "roslaunch did not stop on SIGINT"
ls "$LIVE"/*.active >/dev/null 2>&1 && fail "a live bag is still .active"
ls "$LIVE"/xpersif_*.bag >/dev/null 2>&1 || fail "no live bag in $LIVE: $(ls "$LIVE")"
ok "live run of $EXPERIMENTS experiments recorded: $(ls "$LIVE"/xpersif_*.bag | wc -l) bag(s), $(du -sh "$LIVE" | cut -f1)"

# 2. The replay: a fresh master, two components, the recorded inputs.
roscore -p "$PORT" >"$T/roscore.log" 2>&1 &
PIDS+=($!)
for _ in $(seq 100); do rosparam get /rosdistro >/dev/null 2>&1 && break; sleep 0.2; done
rosparam set /use_sim_time true
rosrun nodelet nodelet standalone xpersif/FeatureExtractionNodelet __name:=replay_extraction __ns:=/xpersif \
  _autostart:=true _camera:=overhead _image_topic:=/xpersif/observation/image_raw \
  _scene_topic:=/xpersif/xpersim/scene >"$T/extraction.log" 2>&1 &
PIDS+=($!)
rosrun nodelet nodelet standalone xpersif/MachineLearningNodelet __name:=replay_learning __ns:=/xpersif \
  _autostart:=true _restore:=false _world:="$HERE/worlds/default.yaml" >"$T/learning.log" 2>&1 &
PIDS+=($!)
xpersif wait --timeout 120 /xpersif/replay_extraction /xpersif/replay_learning >"$T/wait2.log" 2>&1 ||
  fail "the replay components did not come up: $(tail -5 "$T/wait2.log")"
/usr/lib/rosbag/record -O "$T/replay.bag" /xpersif/replay_extraction/features /xpersif/replay_learning/model \
  >"$T/replay.record.log" 2>&1 &
REC=$!
PIDS+=("$REC")
for _ in $(seq 100); do
  n=$(rostopic info /xpersif/replay_extraction/features 2>/dev/null | grep -c "record_" || true)
  m=$(rostopic info /xpersif/replay_learning/model 2>/dev/null | grep -c "record_" || true)
  [ "$n" -ge 1 ] && [ "$m" -ge 1 ] && break
  sleep 0.2
done
# Only the inputs: /clock comes from --clock (the recorded /clock would be a second clock), the outputs of
# the live components are what the replay is compared with.
rosbag play --clock -r "$RATE" "$LIVE"/xpersif_*.bag --topics /tf /tf_static /xpersif/xpersim/scene \
  /xpersif/observation/image_raw /xpersif/knowledge_base/experiments >"$T/play.log" 2>&1 ||
  fail "rosbag play failed: $(tail -5 "$T/play.log")"
sleep 3  # the last image and record are processed and recorded
kill -INT "$REC"
wait_gone "$REC" || fail "the replay recorder did not stop"
[ -f "$T/replay.bag" ] || fail "no replay bag: $(cat "$T/replay.record.log")"
ok "replayed at rate $RATE: $(rosbag info -y -k messages "$T/replay.bag") messages recorded from the replay"

# 3. Compare.
XPERSIF_REPLAY_LIVE=$LIVE XPERSIF_REPLAY_BAG=$T/replay.bag "$BIN/test_replay" || fail "replay differs from the live run"
echo "PASS"
