#!/usr/bin/env bash
# A study's learning curves again, from its knowledge bases, with MACHINELEARNING's shared learner and with one
# learner per object (xpersif_study_curve --learner), and per learner: random's and each design's final error per
# seed and where the design reaches random's final error (bench/loop.md, "A world where random wastes 60 %").
#   bash bench/run_study_learner_scope.sh STUDY_DIR [OUT_DIR (STUDY_DIR/learner_scope)]
set -euo pipefail
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
study=${1:?usage: run_study_learner_scope.sh STUDY_DIR [OUT_DIR]}
out=${2:-$study/learner_scope}
[[ -d "$study/cells" && -f "$study/evaluation/knowledge.db" ]] || { echo "$study is not a study directory" >&2; exit 2; }
curve_tool="$repo/build/devel/lib/xpersif/xpersif_study_curve"
for cell in "$study"/cells/*; do
  name=$(basename "$cell")
  for learner in shared per_object; do
    mkdir -p "$out/$learner/$name"
    "$curve_tool" --evaluation-database "$study/evaluation/knowledge.db" --database "$cell/knowledge.db" \
      --run "${name%-seed*}" --out "$out/$learner/$name" --every 2 --learner "$learner" >/dev/null
  done
done
python3 - "$out" <<'PY'
import csv, glob, os, sys
out = sys.argv[1]
def curve(path):
    return [(int(r["experiments"]), float(r["error"])) for r in csv.DictReader(open(os.path.join(path, "curve.csv")))]
for learner in ("shared", "per_object"):
    cells = {os.path.basename(p): curve(p) for p in sorted(glob.glob(os.path.join(out, learner, "*")))}
    seeds = sorted(c.split("-seed")[1] for c in cells if c.startswith("random-"))
    designs = sorted({c.split("-seed")[0] for c in cells} - {"random"})
    finals = [cells["random-seed" + s][-1][1] for s in seeds]
    print("%s: random final error %s (mean %.4f)" % (learner, " ".join("%.4f" % f for f in finals), sum(finals) / len(finals)))
    for d in designs:
        line, reach = [], []
        for s, target in zip(seeds, finals):
            c = cells.get("%s-seed%s" % (d, s))
            if not c:
                continue
            line.append(c[-1][1])
            k = next((k for k, e in c if e <= target), None)
            reach.append("never" if k is None else "%.0f %%" % (100.0 * k / cells["random-seed" + s][-1][0]))
        print("  %s: final error %s (mean %.4f); reaches random's final error at %s" %
              (d, " ".join("%.4f" % f for f in line), sum(line) / len(line), ", ".join(reach)))
PY
