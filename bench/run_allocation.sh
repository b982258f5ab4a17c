#!/usr/bin/env bash
# What a perfect choice of objects would gain on a study's world (bench/loop.md, "What a perfect allocator would
# gain"): allocation_bench on the pushes of the study's random cells, with the shared forest and with one forest per
# object (learner_type random_forest and per_object_forest).
#   bash bench/run_allocation.sh STUDY_DIR [REPEATS (20)]
set -euo pipefail
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
study=${1:?usage: run_allocation.sh STUDY_DIR [REPEATS]}
repeats=${2:-20}
[[ -d "$study/cells" && -f "$study/evaluation/knowledge.db" ]] || { echo "$study is not a study directory" >&2; exit 2; }
cmake --build "$repo/build" --target allocation_bench >/dev/null
pools=()
for cell in "$study"/cells/random-seed*; do pools+=(--pool "$cell/knowledge.db"); done
[ ${#pools[@]} -gt 0 ] || { echo "$study has no random cells to pool" >&2; exit 2; }
budget=$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["budget"])' "$study/study.json" 2>/dev/null || echo 100)
for learner in shared per_object; do
  "$repo/build/devel/lib/xpersif/allocation_bench" --evaluation-database "$study/evaluation/knowledge.db" "${pools[@]}" \
    --budget "$budget" --repeats "$repeats" --every 10 --learner "$learner"
  echo
done
