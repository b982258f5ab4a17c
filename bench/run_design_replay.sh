#!/usr/bin/env bash
# A design's campaign replayed offline on a study's pushes, for many seeds (bench/loop.md, "Learning progress
# offline, 20 seeds"): design_replay on the pushes of the study's random cells, against random design.
#   bash bench/run_design_replay.sh STUDY_DIR [design_replay options: --budget N --seeds S --per-object 1 ...]
set -euo pipefail
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
study=${1:?usage: run_design_replay.sh STUDY_DIR [design_replay options]}
shift
[[ -d "$study/cells" && -f "$study/evaluation/knowledge.db" && -f "$study/study.json" ]] ||
  { echo "$study is not a study directory" >&2; exit 2; }
cmake --build "$repo/build" --target design_replay >/dev/null
pools=()
for cell in "$study"/cells/random-seed*; do pools+=(--pool "$cell/knowledge.db"); done
[ ${#pools[@]} -gt 0 ] || { echo "$study has no random cells to pool" >&2; exit 2; }
world=$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["world"])' "$study/study.json")
learner=$(python3 -c 'import json,sys; p=json.load(open(sys.argv[1])).get("parameters",{}).get("machine_learning",{})
print("per_object" if p.get("learner_type")=="per_object_forest" else "shared")' "$study/study.json")
"$repo/build/devel/lib/xpersif/design_replay" --world "$world" --evaluation-database "$study/evaluation/knowledge.db" \
  "${pools[@]}" --learner "$learner" "$@"
