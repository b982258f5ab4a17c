#!/usr/bin/env bash
# Experiment files through roslaunch (issue 15), as a person runs them:
#  1. a malformed experiment file: `roslaunch xpersif experiment.launch` stops before anything starts, with a
#     non-zero status and the sentence naming the file and the key; no run directory, no node;
#  2. experiments/short.yaml: exit status 0, the outcome "0 ..." in the status file, report.md, the
#     experiments stored (every phase a run with its budget), the provenance in the run directory and in each
#     run's parameters in the knowledge base;
#  2b. the same run directory again: refused by the runner, code 2 in the status file;
#  3. `xpersif rerun` of that run directory: exit status 0, the same experiment as run (but the run
#     directory), the same runs and designed experiments per run; the knowledge bases compared with
#     scripts/compare_kb.py, equal field by field (the lockstep loop is deterministic, issue 13).
#   bash test/experiment_launch.sh BUILD_DIR        KEEP=1 keeps the temporary directory
set -eo pipefail
HERE=$(cd "$(dirname "$0")/.." && pwd)
BUILD=$(cd "${1:-$HERE/build}" && pwd)
export PATH=/usr/bin:$PATH
set +u
# shellcheck disable=SC1091
source "$BUILD/devel/setup.bash"
set -u
export PATH="$BUILD/devel/lib/xpersif:$PATH"
T=$(mktemp -d /tmp/xpersif-experiment-launch-XXXXXX)
export ROS_IP=127.0.0.1 ROS_HOSTNAME=127.0.0.1
LAUNCH_PID=
cleanup() {
  if [ -n "$LAUNCH_PID" ]; then kill -INT "$LAUNCH_PID" 2>/dev/null || true; fi
  [ -n "${KEEP:-}" ] || rm -rf "$T"
}
trap cleanup EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
ok() { echo "ok: $*"; }
new_master() {  # a free port for a master of our own; roslaunch starts it and stops it at the end
  PORT=$(/usr/bin/python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
  export ROS_MASTER_URI=http://127.0.0.1:$PORT
}
sql() { /usr/bin/python3 -c 'import sqlite3, sys; print("\n".join("|".join(map(str, r)) for r in sqlite3.connect(sys.argv[1]).execute(sys.argv[2])))' "$@"; }

# ---- 1. a malformed file stops roslaunch before anything starts ----
cat >"$T/bad.yaml" <<EOF
world: $HERE/worlds/default.yaml
phases:
  - {kind: experimentation, name: random, design: random, experiments: 2, budget: 3}
EOF
new_master
code=0
roslaunch -p "$PORT" xpersif experiment.launch experiment:="$T/bad.yaml" run_dir:="$T/bad_run" \
  status_file:="$T/bad.status" >"$T/bad.log" 2>&1 || code=$?
[ "$code" -ne 0 ] || fail "roslaunch exited 0 on a malformed experiment file"
grep -q "$T/bad.yaml: unknown key 'phases\[0\].budget'" "$T/bad.log" || { cat "$T/bad.log"; fail "no sentence naming the file and the key"; }
[ ! -e "$T/bad_run" ] || fail "a run directory was made for a malformed file"
[ ! -e "$T/bad.status" ] || fail "the runner started for a malformed file"
grep -q "process\[" "$T/bad.log" && { cat "$T/bad.log"; fail "a process was started for a malformed file"; }
ok "malformed file: roslaunch exit $code before any process, '$(grep -o "unknown key[^;]*" "$T/bad.log" | head -1)'"

# ---- 2. the short experiment from start to end ----
run() {  # EXPERIMENT RUN_DIR -> roslaunch's exit status in $code, output in RUN_DIR.log
  new_master
  code=0
  local started=$SECONDS
  roslaunch -p "$PORT" xpersif experiment.launch experiment:="$1" run_dir:="$2" status_file:="$2.status" \
    >"$2.log" 2>&1 &
  LAUNCH_PID=$!
  wait "$LAUNCH_PID" || code=$?
  LAUNCH_PID=
  echo "   (${1##*/}: $((SECONDS - started)) s)"
}
A=$T/a
run "$HERE/experiments/short.yaml" "$A"
[ "$code" -eq 0 ] || { tail -40 "$A.log"; fail "roslaunch exited $code"; }
[ -s "$A.status" ] || { tail -40 "$A.log"; fail "no status file"; }
read -r status sentence <"$A.status"
[ "$status" = 0 ] || { tail -40 "$A.log"; cat "$A/launch.log" | tail -20; fail "the experiment failed: $sentence"; }
cmp -s "$A.status" "$A/status" || fail "RUN_DIR/status differs from status_file"
grep -q "phase 2/4 random" "$A.log" || fail "no progress on the console"
grep -q "experiment 3 of 3" "$A.log" || fail "no 'experiment k of n' on the console"
# Every process leaves on roslaunch's SIGINT at the end. A manager held until the SIGTERM 15 s later (LOOPMODEL's
# supervisor asking components again from its destructor while its process shut down) cost 15 s in a third of runs.
! grep -q "escalating to SIGTERM" "$A.log" ||
  fail "a process outlived roslaunch's SIGINT: $(grep -a 'escalating to SIGTERM' "$A.log" | head -2 | tr '\n' ' ')"
for f in report.md learning_curve.csv knowledge.db experiment.yaml world.yaml khepera.urdf parameters.yaml \
  provenance.yaml launch.log; do
  [ -s "$A/$f" ] || fail "$f missing from the run directory"
done
runs=$(sql "$A/knowledge.db" "SELECT name || ':' || status || ':' || json_extract(parameters, '$.experiments') || ':' || json_extract(parameters, '$.goals') FROM runs ORDER BY id" | tr '\n' ' ')
[ "$runs" = "evaluation:finished:3:0 random:finished:3:0 curiosity:finished:3:0 goals:finished:0:1 " ] ||
  fail "runs in the knowledge base: $runs"
# Each run's designed experiments (seq up to its budget; goal-directed pushes follow them), done or failed.
designed() {
  sql "$1" "SELECT group_concat(n, ' ') FROM (SELECT count(e.id) AS n FROM runs r LEFT JOIN experiments e ON e.run_id = r.id AND e.seq <= json_extract(r.parameters, '$.experiments') GROUP BY r.id ORDER BY r.id)"
}
[ "$(designed "$A/knowledge.db")" = "3 3 3 0" ] || fail "designed experiments per run: $(designed "$A/knowledge.db"), 3 3 3 0 expected"
experiments=$(sql "$A/knowledge.db" "SELECT count(*) FROM experiments")
goals=$(sql "$A/knowledge.db" "SELECT count(*) FROM goals")
[ "$goals" -eq 1 ] || fail "$goals goals stored, 1 expected"
version=$(sql "$A/knowledge.db" "SELECT DISTINCT json_extract(parameters, '$.provenance.code_version') FROM runs")
expected_version=$(git -C "$HERE" describe --always --dirty --tags 2>/dev/null || echo "package")
case "$version" in "$expected_version"*) ;; *) fail "code version '$version' in the runs, '$expected_version' expected" ;; esac
stored=$(sql "$A/knowledge.db" "SELECT DISTINCT json_extract(parameters, '$.provenance.experiment.world') || ' ' || json_extract(parameters, '$.provenance.experiment.run_dir') FROM runs")
[ "$stored" = "$A/world.yaml $A" ] || fail "the runs' provenance names '$stored'"
grep -q "^code_version: \"$version\"" "$A/provenance.yaml" || fail "provenance.yaml lacks the code version"
# The report's measures (doc/studies.md): with an object that moved, the primary measure and competence, a row per design.
if ! grep -q "^No learnable object of the evaluation set moves" "$A/report.md"; then
  for section in "## Which design did better" "## Competence: one-push goals"; do
    sed -n "/^$section/,/^## [^CW]/p" "$A/report.md" | grep -q "^| curiosity | " || fail "report.md: no '$section' row for curiosity"
  done
fi
ok "short experiment: exit 0, report, runs $runs, $experiments experiments, code version $version"
# The same knowledge base reported against its world with every object redrawn before every push: nothing is
# learnable, and the report says so object by object, not "nothing moved", and gives no "reaches it" figure.
/usr/bin/python3 - "$A/world.yaml" "$T/all_redrawn.yaml" <<'PY' || fail "could not write the all-redrawn world"
import os, sys, yaml
world = yaml.safe_load(open(sys.argv[1]))
for o in world["objects"]:
    o["friction_redraw"] = [0.1, 2.5]
    if isinstance(o.get("friction"), list):  # a redrawn friction is one number
        o["friction"] = o["friction"][0]
urdf = world["robot"]["urdf"]
if not urdf.startswith(("/", "package://")):
    world["robot"]["urdf"] = os.path.join(os.path.dirname(sys.argv[1]), urdf)
yaml.safe_dump(world, open(sys.argv[2], "w"))
PY
mkdir -p "$T/redrawn_report"
xpersif_report --database "$A/knowledge.db" --out "$T/redrawn_report" --world "$T/all_redrawn.yaml" >/dev/null 2>&1 ||
  fail "xpersif_report on the all-redrawn world failed"
grep -q "^No learnable object of the evaluation set moves when pushed.*; the world redraws .* before every push" \
  "$T/redrawn_report/report.md" || fail "the report does not name the redrawn objects as its cause: $(sed -n '/^## Which/,+3p' "$T/redrawn_report/report.md")"
! grep -q "reaches it" "$T/redrawn_report/report.md" || fail "the report gives a 'reaches it' figure with nothing learnable"
ok "reported against an all-redrawn world: $(grep '^No learnable object' "$T/redrawn_report/report.md" | cut -c1-140)"

# ---- 2b. a failure after roslaunch read the file is in the status file (roslaunch itself exits 0) ----
new_master
code=0
roslaunch -p "$PORT" xpersif experiment.launch experiment:="$HERE/experiments/short.yaml" run_dir:="$A" \
  status_file:="$T/again.status" >"$T/again.log" 2>&1 || code=$?
read -r status sentence <"$T/again.status" || { tail -20 "$T/again.log"; fail "no status file for a refused run directory (roslaunch exit $code)"; }
[ "$status" = 2 ] || fail "a run directory that already holds a knowledge base: status $status ($sentence)"
case "$sentence" in *"already holds a knowledge base"*) ;; *) fail "the sentence: $sentence" ;; esac
cmp -s "$A.status" "$A/status" || fail "the refused run overwrote the first run's status"
ok "a used run directory: roslaunch exit $code, status file '$status $sentence'"

# ---- 3. xpersif rerun repeats it from the run directory ----
new_master
B=$T/b
started=$SECONDS
code=0
xpersif rerun "$A" --run-dir "$B" >"$B.log" 2>&1 || code=$?
echo "   (rerun: $((SECONDS - started)) s)"
[ "$code" -eq 0 ] || { tail -40 "$B.log"; fail "xpersif rerun exited $code"; }
# The experiment as run is the same but for the run directory.
diff <(sed "s|$A|RUN|g" "$A/experiment.yaml") <(sed "s|$B|RUN|g" "$B/experiment.yaml") >"$T/experiment.diff" ||
  { cat "$T/experiment.diff"; fail "the rerun ran another experiment"; }
cmp -s <(grep -v '^#' "$A/world.yaml") <(grep -v '^#' "$B/world.yaml") || fail "the rerun's world differs"
cmp -s "$A/khepera.urdf" "$B/khepera.urdf" || fail "the rerun's robot differs"
runs_b=$(sql "$B/knowledge.db" "SELECT name || ':' || status || ':' || json_extract(parameters, '$.experiments') || ':' || json_extract(parameters, '$.goals') FROM runs ORDER BY id" | tr '\n' ' ')
[ "$runs_b" = "$runs" ] || fail "the rerun's runs: $runs_b; the original's: $runs"
[ "$(designed "$B/knowledge.db")" = "3 3 3 0" ] || fail "the rerun's designed experiments per run: $(designed "$B/knowledge.db")"
/usr/bin/python3 "$HERE/scripts/compare_kb.py" "$A/knowledge.db" "$B/knowledge.db" >"$T/compare.txt" 2>&1 ||
  { head -30 "$T/compare.txt"; fail "the rerun's knowledge base differs from the original's"; }
ok "rerun: exit 0, the same experiment; knowledge bases equal, field by field (scripts/compare_kb.py)"
