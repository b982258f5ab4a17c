#!/usr/bin/env bash
# A tiny study through scripts/study.py (issues 16, 38): 2 seeds x 4 arms (random, its null random_null,
# learning_progress, the oracle) x 10 experiments and a goal each, on the default experiment's world, with a held-out
# evaluation set of 8 pushes, two cells at once, each on a master of its own; then
#  - test/study_check.py: the report's files exist and its figures agree with the knowledge bases (evaluation set
#    only on the learnable objects, per-cell counts, curves and per-object curves recomputed, the null's seeds, the
#    oracle's objects, the primary measure recomputed on its own, reach, shares per object, goals);
#  - the same command again resumes: every cell is skipped and the report is the same;
#  - the same command with one more design extends it: only the new cells run.
#   bash test/study.sh BUILD_DIR        KEEP=1 keeps the study's directory
set -eo pipefail
HERE=$(cd "$(dirname "$0")/.." && pwd)
BUILD=$(cd "${1:-$HERE/build}" && pwd)
export PATH=/usr/bin:$PATH
set +u
# shellcheck disable=SC1091
source "$BUILD/devel/setup.bash"
set -u
export PATH="$BUILD/devel/lib/xpersif:$PATH" ROS_IP=127.0.0.1
T=$(mktemp -d /tmp/xpersif-study-XXXXXX)
cleanup() { [ -n "${KEEP:-}" ] && echo "kept $T" || rm -rf "$T"; }
trap cleanup EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

args=(--seeds 2 --designs random,random_null,learning_progress,oracle --budget 10 --goals 1 --evaluation-size 8 --every 1 --jobs 2
      --out "$T/study")
started=$SECONDS
/usr/bin/python3 "$HERE/scripts/study.py" "${args[@]}" 2>"$T/first.log" || { cat "$T/first.log"; fail "the study failed"; }
echo "ok: the tiny study ran in $((SECONDS - started)) s"
grep -q "study \[" "$T/first.log" || { cat "$T/first.log"; fail "no progress line"; }
grep -q "left" "$T/first.log" || fail "the progress line gives no time left"
/usr/bin/python3 "$HERE/test/study_check.py" "$T/study" "$BUILD/devel/lib/xpersif/xpersif_study_curve" || fail "the report disagrees with the knowledge bases"
cp "$T/study/report/cells.csv" "$T/cells_first.csv"

started=$SECONDS
/usr/bin/python3 "$HERE/scripts/study.py" "${args[@]}" 2>"$T/second.log" || { cat "$T/second.log"; fail "resuming failed"; }
grep -q "9 of 9 cells already finished" "$T/second.log" || { cat "$T/second.log"; fail "resuming did not skip the finished cells"; }
cmp -s "$T/cells_first.csv" "$T/study/report/cells.csv" || fail "the resumed study's report differs"
echo "ok: the same command again skipped every cell ($((SECONDS - started)) s) and wrote the same figures"

# More designs with the same arguments extend the study: the finished cells are kept, only round robin's two run,
# and the report covers all of them.
extended=(--seeds 2 --designs random,random_null,learning_progress,oracle,round_robin --budget 10 --goals 1
          --evaluation-size 8 --every 1 --jobs 2 --out "$T/study")
/usr/bin/python3 "$HERE/scripts/study.py" "${extended[@]}" 2>"$T/extended.log" || { cat "$T/extended.log"; fail "extending failed"; }
grep -q "extending .* with designs round_robin" "$T/extended.log" || { cat "$T/extended.log"; fail "no sentence for the extension"; }
grep -q "9 of 11 cells already finished" "$T/extended.log" || { cat "$T/extended.log"; fail "extending ran finished cells again"; }
grep -q "^round_robin," "$T/study/report/cells.csv" || fail "the extended report has no round_robin row"
/usr/bin/python3 "$HERE/test/study_check.py" "$T/study" "$BUILD/devel/lib/xpersif/xpersif_study_curve" || fail "the extended report disagrees with the knowledge bases"
echo "ok: two more cells extended the study and its report ($(head -1 "$T/extended.log"))"

# Another study in the same directory is refused with a sentence.
if /usr/bin/python3 "$HERE/scripts/study.py" --seeds 3 --designs random --budget 10 --out "$T/study" 2>"$T/third.log"; then
  fail "another study was accepted in the same directory"
fi
grep -q "holds another study" "$T/third.log" || { cat "$T/third.log"; fail "no sentence for another study"; }
echo "ok: another study in the same directory refused: $(head -1 "$T/third.log")"

# A world whose robot cannot be read is refused before any cell starts, with the sentence that says why.
sed 's#^\( *urdf: \).*#\1no_such_robot.urdf#' "$HERE/worlds/default.yaml" > "$T/broken_world.yaml"
if /usr/bin/python3 "$HERE/scripts/study.py" --seeds 1 --designs random --budget 2 --world "$T/broken_world.yaml" \
    --out "$T/broken" 2>"$T/broken.log"; then
  fail "a study on a world without its robot's URDF succeeded"
fi
grep -q "cannot be used: .*no_such_robot.urdf" "$T/broken.log" || { cat "$T/broken.log"; fail "no sentence naming the URDF"; }
[ ! -d "$T/broken/cells" ] || fail "cells were started on a world that cannot be used"
echo "ok: a world without its robot refused at once: $(head -1 "$T/broken.log")"
echo "PASS"
