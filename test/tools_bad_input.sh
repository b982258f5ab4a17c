#!/usr/bin/env bash
# Every tool, every kind of bad argument (issue 19, item 3): xpersif, xpersif_report, xpersif_export,
# xpersif_train_offline, xpersif_recover_bag, xpersif_experiment and scripts/run.sh are given a bad number, an
# unknown option, a missing value, a missing file, a file of random bytes, a truncated file, a directory where a
# file belongs, a file or directory without permission (run as the user nobody: root may read and write
# anything), a world whose arena size is a word, a URDF with a negative inertia. Each case must end with the
# documented exit code (doc/exit-codes.md: 1 failed, 2 usage, 3 bad input file, 4 output not writable), a
# sentence on stderr naming what was wrong, and never an abort: no "terminate called", no core dump, no signal.
# The table of cases and outcomes goes to $OUT (default /tmp/xpersif_tools_bad_input.md).
#   bash test/tools_bad_input.sh BUILD_DIR
set -uo pipefail
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
BUILD=${1:-$HERE/build}
BIN=$BUILD/devel/lib/xpersif
OUT=${OUT:-/tmp/xpersif_tools_bad_input.md}
set +u
# shellcheck disable=SC1091
source "$BUILD/devel/setup.bash"
set -u
export PATH="/usr/bin:$PATH" ROS_IP=127.0.0.1
# No master listens here: a tool that needs one must say so, not hang.
port=$(/usr/bin/python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
export ROS_MASTER_URI=http://127.0.0.1:$port
T=$(mktemp -d /tmp/xpersif_tools_bad.XXXXXX)
chmod 755 "$T"
trap 'chmod -R u+rwX "$T" 2>/dev/null; rm -rf "$T"' EXIT

# ---- the bad inputs (seeded: the same bytes every run) ----
/usr/bin/python3 - "$T" <<'EOF'
import os, random, sqlite3, sys
t = sys.argv[1]
rng = random.Random(19)
def write(name, data):
    with open(os.path.join(t, name), "wb") as f:
        f.write(data)
noise = bytes(rng.getrandbits(8) for _ in range(8192))
for name in ("random.db", "random.bag", "random.yaml", "random.bag.active", "random.urdf"):
    write(name, noise)
write("empty.bag", b"")
# A real SQLite file, truncated mid-way.
db = sqlite3.connect(os.path.join(t, "full.db"))
db.execute("CREATE TABLE t (x TEXT)")
db.executemany("INSERT INTO t VALUES (?)", [("row %d " % i * 20,) for i in range(3000)])
db.commit()
db.close()
data = open(os.path.join(t, "full.db"), "rb").read()
write("truncated.db", data[: len(data) // 3])
# A real bag, truncated mid-way.
import rosbag, rospy
from std_msgs.msg import String
with rosbag.Bag(os.path.join(t, "full.bag"), "w") as bag:
    for i in range(2000):
        bag.write("/chatter", String(data="message %d" % i * 10), rospy.Time(1 + i * 0.01))
data = open(os.path.join(t, "full.bag"), "rb").read()
write("truncated.bag", data[: len(data) // 2])
EOF
mkdir -p "$T/nobags" "$T/locked" "$T/readonly"
cp "$T/full.bag" "$T/locked/secret.bag"
cp "$T/full.db" "$T/locked/secret.db"
chmod 000 "$T/locked/secret.bag" "$T/locked/secret.db"
cp "$T/random.bag.active" "$T/readonly/x.bag.active"
chmod 555 "$T/readonly"
echo "not a directory" >"$T/file.txt"
# A world whose arena size is a word, and a robot with a negative inertia.
sed 's/^\(  size: \).*/\1[wide, 0.6]/' "$HERE/worlds/default.yaml" >"$T/word_arena.yaml"
grep -q "size: \[wide" "$T/word_arena.yaml" || { echo "FAIL: could not write the word-arena world" >&2; exit 1; }
/usr/bin/python3 - "$HERE" "$T" <<'EOF'
import re, sys
here, t = sys.argv[1], sys.argv[2]
world = open(here + "/worlds/default.yaml").read()
urdf_name = re.search(r"urdf:\s*(\S+)", world).group(1)
urdf = open(here + "/worlds/" + urdf_name).read()
bad, n = re.subn(r'ixx="[^"]*"', 'ixx="-0.001"', urdf, count=1)
assert n == 1
open(t + "/negative_inertia.urdf", "w").write(bad)
open(t + "/negative_inertia.yaml", "w").write(re.sub(r"urdf:\s*\S+", "urdf: negative_inertia.urdf", world, count=1))
EOF
# An experiment file whose world is the word-arena one.
sed "s#^world: .*#world: $T/word_arena.yaml#" "$HERE/experiments/short.yaml" >"$T/word_arena_experiment.yaml"
# Worlds the cameras cannot perceive (issue 36): an object the colour of the floor; an overhead camera too coarse
# for its arena. Both from worlds/ordinary.yaml, its robot's URDF by absolute path.
sed -e "s#urdf: \.\./urdf/#urdf: $HERE/urdf/#" -e 's/color: \[0.08, 0.08, 0.08, 1.0\]/color: [0.9, 0.9, 0.88, 1.0]/' \
  "$HERE/worlds/ordinary.yaml" >"$T/floor_coloured.yaml"
grep -q "black_block.*color: \[0.9, 0.9, 0.88" "$T/floor_coloured.yaml" || { echo "FAIL: could not write the floor-coloured world" >&2; exit 1; }
sed -e "s#urdf: \.\./urdf/#urdf: $HERE/urdf/#" -e 's/fx: 650.0, fy: 650.0/fx: 400.0, fy: 400.0/' \
  "$HERE/worlds/ordinary.yaml" >"$T/coarse_camera.yaml"
grep -q "fx: 400.0" "$T/coarse_camera.yaml" || { echo "FAIL: could not write the coarse-camera world" >&2; exit 1; }
sed "s#^world: .*#world: $T/floor_coloured.yaml#" "$HERE/experiments/short.yaml" >"$T/floor_coloured_experiment.yaml"
# The same world with its robot named as generated worlds name it (package://xpersif/...): run.sh's early check
# must resolve it as the run will, whatever the caller's ROS_PACKAGE_PATH.
sed "s#urdf: $HERE/urdf/#urdf: package://xpersif/urdf/#" "$T/floor_coloured.yaml" >"$T/floor_coloured_by_package.yaml"
grep -q "urdf: package://xpersif/urdf/" "$T/floor_coloured_by_package.yaml" || { echo "FAIL: could not write the world naming its robot by package" >&2; exit 1; }

as_nobody=()
[[ $(id -u) -ne 0 ]] || as_nobody=(setpriv --reuid=65534 --regid=65534 --clear-groups)

# ---- the cases ----
total=0 passed=0
failures=()
printf '| tool | case | expected | exit | stderr (first line) |\n|---|---|---|---|---|\n' >"$OUT"
# case NAME EXPECTED_CODE WORDS_IN_STDERR -- COMMAND...
case_() {
  local name=$1 expected=$2 words=$3
  shift 4
  local err="$T/stderr" code=0
  timeout -k 5 60 "$@" >"$T/stdout" 2>"$err" </dev/null || code=$?
  local first
  first=$(grep -v '^usage:\|^  \|^exit:\|^reindexes\|^writes' "$err" | head -1 | tr '|' '/' | cut -c1-160)
  total=$((total + 1))
  local why=""
  [[ "$code" == "$expected" ]] || why="exit $code, not $expected"
  [[ -n "$first" || "$expected" == 0 ]] || why="$why; no sentence on stderr"
  [[ -z "$words" ]] || grep -qF -- "$words" "$err" || why="$why; stderr lacks '$words'"
  ! grep -q "terminate called\|core dumped\|Aborted\|Segmentation\|Traceback" "$err" || why="$why; it crashed"
  ((code < 124)) || why="$why; killed by a signal or the timeout"
  local tool
  tool=$(basename "$P")
  if [[ -z "$why" ]]; then
    passed=$((passed + 1))
    printf '| %s | %s | %s | %s | %s |\n' "$tool" "$name" "$expected" "$code" "$first" >>"$OUT"
  else
    failures+=("$tool: $name: $why: $(head -3 "$err" | tr '\n' ' ')")
    printf '| %s | %s | %s | **%s** | %s (%s) |\n' "$tool" "$name" "$expected" "$code" "$first" "$why" >>"$OUT"
  fi
}

# xpersif_train_offline
P=$BIN/xpersif_train_offline
case_ "a bad number: --seed abc" 2 "--seed: 'abc' is not a whole number" -- "$P" --seed abc "$T/full.bag"
case_ "a negative number: --seed -1" 2 "--seed: '-1' is not a whole number" -- "$P" --seed -1 "$T/full.bag"
case_ "a number too big: --run 1e99" 2 "--run: '1e99' is not a whole number" -- "$P" --run 1e99 "$T/full.bag"
case_ "a missing value: --seed" 2 "--seed: 1 required" -- "$P" "$T/full.bag" --seed
case_ "an unknown option" 2 "not expected: --sead" -- "$P" --sead 3 "$T/full.bag"
case_ "no input" 2 "BAG_OR_RUN_DIR is required" -- "$P"
case_ "a missing bag" 3 "does not exist" -- "$P" "$T/missing.bag"
case_ "a bag of random bytes" 3 "random.bag" -- "$P" "$T/random.bag"
case_ "a truncated bag" 3 "truncated.bag" -- "$P" "$T/truncated.bag"
case_ "an empty bag" 3 "empty.bag" -- "$P" "$T/empty.bag"
case_ "a directory without bags" 3 "holds no .bag file" -- "$P" "$T/nobags"
case_ "an unreadable bag (nobody)" 3 "cannot be read" -- "${as_nobody[@]}" "$P" "$T/locked/secret.bag"
case_ "-o into a directory without permission (nobody)" 4 "cannot be written" -- "${as_nobody[@]}" "$P" -o "$T/readonly/m.yaml" "$T/full.bag"
case_ "-o under a file" 4 "is not a directory" -- "$P" -o "$T/file.txt/m.yaml" "$T/full.bag"

# xpersif_export
P=$BIN/xpersif_export
case_ "a bad number: --pose-period abc" 2 "--pose-period: 'abc' is not a finite number" -- "$P" --pose-period abc "$T/full.bag"
case_ "a non-finite number: --pose-period nan" 2 "--pose-period: 'nan' is not a finite number" -- "$P" --pose-period nan "$T/full.bag"
case_ "a missing value: -o" 2 "--out: 1 required" -- "$P" "$T/full.bag" -o
case_ "an unknown option" 2 "not expected: --bogus" -- "$P" --bogus "$T/full.bag"
case_ "a bad regular expression" 2 "is not a regular expression" -- "$P" --frames "(" "$T/full.bag"
case_ "no input" 2 "BAG_OR_RUN_DIR is required" -- "$P"
case_ "a missing bag" 3 "does not exist" -- "$P" -o "$T/out" "$T/missing.bag"
case_ "a bag of random bytes" 3 "random.bag" -- "$P" -o "$T/out" "$T/random.bag"
case_ "a truncated bag" 3 "truncated.bag" -- "$P" -o "$T/out" "$T/truncated.bag"
case_ "an unindexed bag (.active)" 3 "xpersif_recover_bag" -- "$P" -o "$T/out" "$T/random.bag.active"
case_ "an unreadable bag (nobody)" 3 "cannot be read" -- "${as_nobody[@]}" "$P" -o "$T/readonly" "$T/locked/secret.bag"
case_ "-o a directory without permission (nobody)" 4 "cannot be written" -- "${as_nobody[@]}" "$P" -o "$T/readonly" "$T/full.bag"
case_ "-o a file" 4 "is not a directory" -- "$P" -o "$T/file.txt" "$T/full.bag"

# xpersif_recover_bag
P=$BIN/xpersif_recover_bag
case_ "no argument" 2 "BAG is required" -- "$P"
case_ "an unknown option" 2 "not expected: --force" -- "$P" --force "$T/random.bag.active"
case_ "a missing bag" 3 "does not exist" -- "$P" "$T/missing.bag.active"
case_ "a bag of random bytes" 3 "random.bag.active" -- "$P" "$T/random.bag.active"
case_ "a directory" 3 "is a directory" -- "$P" "$T/nobags"
case_ "an unreadable bag (nobody)" 3 "cannot be read" -- "${as_nobody[@]}" "$P" "$T/locked/secret.bag"
case_ "in a directory without permission (nobody)" 4 "cannot be written" -- "${as_nobody[@]}" "$P" "$T/readonly/x.bag.active"

# xpersif_report
P=$BIN/xpersif_report
case_ "no argument" 2 "--database is required" -- "$P"
case_ "a missing value: --out" 2 "--out: 1 required" -- "$P" --database "$T/full.db" --out
case_ "an unknown option" 2 "not expected: --bogus" -- "$P" --bogus x
case_ "a missing knowledge base" 3 "does not exist" -- "$P" --database "$T/missing.db" --out "$T/out"
case_ "a knowledge base of random bytes" 3 "random.db" -- "$P" --database "$T/random.db" --out "$T/out"
case_ "a truncated knowledge base" 3 "truncated.db" -- "$P" --database "$T/truncated.db" --out "$T/out"
case_ "a directory as knowledge base" 3 "is a directory" -- "$P" --database "$T/nobags" --out "$T/out"
case_ "an unreadable knowledge base (nobody)" 3 "cannot be read" -- "${as_nobody[@]}" "$P" --database "$T/locked/secret.db" --out "$T/out"
case_ "--out a directory without permission (nobody)" 4 "cannot be written" -- "${as_nobody[@]}" "$P" --database "$T/full.db" --out "$T/readonly/r"
printf 'objects: [\n' >"$T/broken_world.yaml"
case_ "a missing world file: --world" 3 "does not exist" -- "$P" --database "$T/full.db" --out "$T/out" --world "$T/missing.yaml"
case_ "a malformed world file: --world" 3 "not valid YAML" -- "$P" --database "$T/full.db" --out "$T/out" --world "$T/broken_world.yaml"
[[ -e "$T/missing.db" ]] && failures+=("xpersif_report: created the missing knowledge base")

# xpersif (the console)
P=$BIN/xpersif
case_ "a bad number: run --seed abc" 2 "--seed: 'abc' is not a whole number" -- "$P" run demo --seed abc
case_ "a negative number: run --experiments -3" 2 "--experiments: '-3' is not a whole number" -- "$P" run demo --experiments -3
case_ "a missing value: run --goals" 2 "--goals: 1 required" -- "$P" run demo --goals
case_ "an unknown option: run --bogus" 2 "not expected: --bogus" -- "$P" run demo --bogus
case_ "no name: run" 2 "NAME is required" -- "$P" run
case_ "a non-finite offset: next" 2 "next needs OBJECT SIDE OFFSET DISTANCE" -- "$P" next red_cube -x nan 0.05
case_ "a bad number: --timeout abc" 2 "--timeout: 'abc' is not a finite number" -- "$P" status --timeout abc
case_ "an unknown command" 2 "not expected: bogus" -- "$P" bogus
case_ "a missing plan file" 2 "cannot read the plan file" -- "$P" run demo --plan "$T/missing.plan"
case_ "a plan file of random bytes" 2 "expected OBJECT SIDE OFFSET DISTANCE" -- "$P" run demo --plan "$T/random.bag"
case_ "no master: status" 1 "no ROS master" -- "$P" status
case_ "check-world: a missing world" 3 "missing.yaml" -- "$P" check-world "$T/missing.yaml"
case_ "check-world: a world of random bytes" 3 "random.yaml" -- "$P" check-world "$T/random.yaml"
case_ "check-world: the arena's size a word" 3 "word_arena.yaml: arena.size[0] is 'wide'" -- "$P" check-world "$T/word_arena.yaml"
case_ "check-world: a URDF with a negative inertia" 3 "not positive definite" -- "$P" check-world "$T/negative_inertia.yaml"
case_ "check-world: an object the colour of the floor" 3 "cannot find object 'black_block' at the start" -- "$P" check-world "$T/floor_coloured.yaml"
case_ "check-world: a camera too coarse for its arena" 3 "is too coarse for this arena" -- "$P" check-world "$T/coarse_camera.yaml"
case_ "rerun: not a run directory" 2 "holds no experiment.yaml" -- "$P" rerun "$T/nobags"

# xpersif_experiment
P=$BIN/xpersif_experiment
case_ "check: a good file with --components and overrides (as experiment.launch runs it)" 0 "" -- "$P" check \
  "$HERE/experiments/short.yaml" --components "$HERE/config/loop.yaml,$HERE/config/embodiment.yaml" seed=3 \
  parameters.machine_learning.learner_type=gaussian_process
case_ "check: no file" 2 "FILE is required" -- "$P" check
case_ "check: a missing file" 2 "missing.yaml" -- "$P" check "$T/missing.yaml"
case_ "check: random bytes" 2 "random.yaml" -- "$P" check "$T/random.yaml"
case_ "check: a bad number (seed=abc)" 2 "seed" -- "$P" check "$HERE/experiments/short.yaml" seed=abc
case_ "check: a world whose arena size is a word" 2 "word_arena.yaml: arena.size[0] is 'wide'" -- "$P" check "$T/word_arena_experiment.yaml"
case_ "check: a world the cameras cannot perceive" 2 "it looks like the floor" -- "$P" check "$T/floor_coloured_experiment.yaml"
case_ "as a node: an unexpected argument" 2 "not expected: --seed 3" -- "$P" --seed 3
case_ "as a node: no master" 1 "no ROS master" -- "$P"

# scripts/run.sh (what it refuses before it builds or starts anything)
P=$HERE/scripts/run.sh
case_ "an unknown option: --seed abc" 2 "unknown option --seed" -- bash "$P" --seed abc
case_ "a missing value: --set" 2 "--set needs KEY=VALUE" -- bash "$P" --set
case_ "a malformed --set" 2 "expected KEY=VALUE" -- bash "$P" --set seed
case_ "a bad number: --set seed=abc" 2 "seed" -- bash "$P" "$HERE/experiments/short.yaml" --set seed=abc
case_ "a missing experiment file" 2 "no such experiment file" -- bash "$P" "$T/missing.yaml"
case_ "an experiment file of random bytes" 2 "random.yaml" -- bash "$P" "$T/random.yaml"
case_ "a directory as experiment file" 2 "not a readable experiment file" -- bash "$P" "$T/nobags"
case_ "a world the cameras cannot perceive" 2 "it looks like the floor" -- bash "$P" "$HERE/experiments/short.yaml" --set world=$T/floor_coloured.yaml
case_ "the same, its robot named by package://, the caller's ROS_PACKAGE_PATH unset" 2 "it looks like the floor" -- env -u ROS_PACKAGE_PATH bash "$P" "$HERE/experiments/short.yaml" --set world=$T/floor_coloured_by_package.yaml
case_ "--run-dir under a file" 4 "cannot be created or written" -- bash "$P" --run-dir "$T/file.txt/run"

cat "$OUT"
echo "$passed of $total cases as documented"
if ((${#failures[@]})); then
  printf 'FAIL: %s\n' "${failures[@]}" >&2
  exit 1
fi
