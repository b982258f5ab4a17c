#!/usr/bin/python3
"""Checks a study's report against its knowledge bases (test/study.sh).

    study_check.py STUDY_DIR XPERSIF_STUDY_CURVE

Every figure of the report is recomputed here from the SQLite knowledge bases (and, for the learning curves, by
running xpersif_study_curve again into a temporary directory) and compared.
"""
import collections
import csv
import json
import glob
import math
import os
import sqlite3
import subprocess
import sys
import tempfile

study, curve_tool = sys.argv[1], sys.argv[2]
report = os.path.join(study, "report")
problems = []


def check(condition, sentence):
    if not condition:
        problems.append(sentence)
    return condition


def rows(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def close(a, b, tol=1e-6):
    return abs(float(a) - float(b)) <= tol * max(1.0, abs(float(a)), abs(float(b)))


for name in ["measures.csv", "cell_measures.csv", "object_curves.csv", "report.md", "learning_curves.csv", "learning_curves.png", "reach.csv", "tests.csv", "object_share.csv",
             "object_share.png", "cells.csv", "goals.csv"]:
    check(os.path.getsize(os.path.join(report, name)) > 0, "report/%s is missing or empty" % name)
check(os.path.exists(os.path.join(study, "evaluation_set.csv")), "evaluation_set.csv is missing")
with open(os.path.join(study, "study.json")) as f:
    definition = json.load(f)
designs, seeds, budget = definition["designs"], definition["seeds"], definition["budget"]
eval_objects = set(definition["evaluation"]["objects"])

# The evaluation set: the learnable objects only, as stored.
con = sqlite3.connect(os.path.join(study, "evaluation", "knowledge.db"))
(run_id,) = con.execute("SELECT id FROM runs WHERE name = 'evaluation'").fetchone()
ev = con.execute("SELECT seq, object FROM experiments WHERE run_id = ? AND status = 'done' ORDER BY seq", (run_id,)).fetchall()
check(len(ev) >= 1, "the evaluation set is empty")
check({o for _, o in ev} <= eval_objects, "the evaluation set pushes %s, outside %s" % ({o for _, o in ev}, eval_objects))
# The objects take turns (study.py's EVALUATION_DESIGN), so that each has as many pushes; a turn passes to the next
# object only when no push of the turn's object is feasible from where it stands.
attempted = collections.Counter(o for (o,) in con.execute("SELECT object FROM experiments WHERE run_id = ?", (run_id,)))
turns = [attempted[o] for o in eval_objects]
check(max(turns) - min(turns) <= 2, "the evaluation set's objects did not take turns: %s" % dict(attempted))
stored = rows(os.path.join(study, "evaluation_set.csv"))
check([int(r["seq"]) for r in stored] == [s for s, _ in ev], "evaluation_set.csv is not the evaluation run's pushes")
all_objects = [o for (o,) in con.execute("SELECT DISTINCT object FROM experiments")]
con.close()

cells = {(r["design"], int(r["seed"])): r for r in rows(os.path.join(report, "cells.csv"))}
check(set(cells) == {(d, s) for d in designs for s in seeds}, "cells.csv has %s" % sorted(cells))
curves = {}
object_curves = {}
pushed_objects = {}
shares_kb = {}
goals_kb = []
for (design, seed), cell in cells.items():
    d = os.path.join(study, "cells", "%s-seed%03d" % (design, seed))
    con = sqlite3.connect(os.path.join(d, "knowledge.db"))
    runs = con.execute("SELECT id, seed, design FROM runs WHERE name = ?", (design,)).fetchall()
    # The null arm is random design on the seed + 1000003; the oracle random design on the moving objects alone.
    run_design, run_seed = ("random", seed + 1000003) if design == "random_null" else (
        ("random", seed) if design == "oracle" else (design, seed))
    check(len(runs) == 1 and runs[0][1] == run_seed and runs[0][2] == run_design,
          "%s-%d: the knowledge base's runs are %s" % (design, seed, runs))
    run = runs[0][0]
    ex = con.execute("SELECT seq, object, status, design FROM experiments WHERE run_id = ? AND seq <= ? ORDER BY seq",
                     (run, budget)).fetchall()
    goals = con.execute("SELECT object, reached, final_error, pushes_used FROM goals WHERE run_id = ? ORDER BY id",
                        (run,)).fetchall()
    (parameters,) = con.execute("SELECT parameters FROM runs WHERE id = ?", (run,)).fetchone()
    con.close()
    want_goals = definition.get("goals", 0)
    check(len(goals) == want_goals, "%s-%d: %d goals in the KB, the study asked %d" % (design, seed, len(goals), want_goals))
    tolerance = json.loads(parameters).get("goal_tolerance")
    for g in goals:
        check(bool(g[1]) == (g[2] < tolerance), "%s-%d: goal %s reached=%s with final error %s and tolerance %s"
              % (design, seed, g[0], g[1], g[2], tolerance))
        goals_kb.append((design, seed, g[0], int(g[1]), g[2], g[3]))
    check(len(ex) == budget == int(cell["designed"]), "%s-%d: %d designed in the KB, %s in cells.csv" % (design, seed, len(ex), cell["designed"]))
    check(all(e[3] == run_design for e in ex), "%s-%d: experiments designed by %s" % (design, seed, {e[3] for e in ex}))
    check(sum(e[2] != "done" for e in ex) == int(cell["failed"]), "%s-%d: failed count differs" % (design, seed))
    for o in set(all_objects) | {k[2:] for k in cell if k.startswith("n_")}:
        check(sum(e[1] == o for e in ex) == int(cell.get("n_" + o, 0) or 0), "%s-%d: count of %s differs" % (design, seed, o))
    shares_kb[(design, seed)] = ex
    # The curve again, from the knowledge bases.
    with tempfile.TemporaryDirectory() as t:
        subprocess.run([curve_tool, "--evaluation-database", os.path.join(study, "evaluation", "knowledge.db"),
                        "--database", os.path.join(d, "knowledge.db"), "--run", design, "--out", t, "--every", "1"],
                       check=True, capture_output=True)
        again = [(int(r["experiments"]), float(r["error"])) for r in rows(os.path.join(t, "curve.csv"))]
        again_objects = rows(os.path.join(t, "curve_objects.csv"))
    check(again_objects == rows(os.path.join(d, "curve_objects.csv")),
          "%s-%d: the per-object curve recomputed from the KB differs from curve_objects.csv" % (design, seed))
    object_curves[(design, seed)] = {}
    for r in again_objects:
        object_curves[(design, seed)].setdefault(r["object"], {})[int(r["experiments"])] = float(r["error"])
    pushed_objects[(design, seed)] = {e[1] for e in ex}
    stored_curve = [(int(r["experiments"]), float(r["error"])) for r in rows(os.path.join(d, "curve.csv"))]
    check(again == stored_curve, "%s-%d: the curve recomputed from the KB differs from curve.csv" % (design, seed))
    check(again[-1][0] == sum(e[2] == "done" for e in ex) == int(cell["learned"]),
          "%s-%d: the curve does not end at the successful experiments" % (design, seed))
    check(close(again[-1][1], cell["final_error"]), "%s-%d: final error differs" % (design, seed))
    check(again[0][1] > again[-1][1], "%s-%d: the error did not fall (%s -> %s)" % (design, seed, again[0][1], again[-1][1]))
    curves[(design, seed)] = dict(again)

# Learning curves: mean over seeds at every k.
for r in rows(os.path.join(report, "learning_curves.csv")):
    values = [c[int(r["experiments"])] for (dd, _), c in curves.items() if dd == r["design"] and int(r["experiments"]) in c]
    check(len(values) == int(r["seeds"]) and close(sum(values) / len(values), r["mean"]),
          "learning_curves.csv %s k=%s: mean differs" % (r["design"], r["experiments"]))
    check(float(r["ci_low"]) <= float(r["mean"]) <= float(r["ci_high"]), "learning_curves.csv: the band does not hold the mean")

# Reach: the first k at which a design is at or below random's final error of the same seed.
for r in rows(os.path.join(report, "reach.csv")):
    seed = int(r["seed"])
    rc = curves[("random", seed)]
    target = rc[max(rc)]
    check(close(r["random_final_error"], target), "reach.csv seed %d: random's final error differs" % seed)
    c = curves[(r["design"], seed)]
    k = next((kk for kk in sorted(c) if c[kk] <= target), None)
    check((r["experiments_to_reach"] == "" and k is None) or (k is not None and int(r["experiments_to_reach"]) == k),
          "reach.csv %s seed %d: %s, the KB says %s" % (r["design"], seed, r["experiments_to_reach"], k))

# Shares per object over time.
for r in rows(os.path.join(report, "object_share.csv")):
    values = []
    for (dd, _), ex in shares_kb.items():
        if dd != r["design"]:
            continue
        inside = [e for e in ex if int(r["from"]) <= e[0] <= int(r["to"])]
        if inside:
            values.append(sum(e[1] == r["object"] for e in inside) / len(inside))
    check(values and close(sum(values) / len(values), r["share"]),
          "object_share.csv %s %s %s-%s differs" % (r["design"], r["object"], r["from"], r["to"]))

# Goals: goals.csv is every cell's goals as stored, and report.md counts them.
stored_goals = [(r["design"], int(r["seed"]), r["object"], int(r["reached"]), float(r["final_error"]), int(r["pushes"]))
                for r in rows(os.path.join(report, "goals.csv"))]
check(sorted(stored_goals) == sorted(goals_kb), "goals.csv differs from the knowledge bases' goals")

# The primary measure, recomputed here on its own: which objects move (median travel >= 10 % of the median push
# distance in the evaluation set), their equal-weight mean error at every k, the trapezoid mean of its log.
con = sqlite3.connect(os.path.join(study, "evaluation", "knowledge.db"))
ev_moves = con.execute("SELECT object, distance, dx, dy, dyaw FROM experiments WHERE run_id = ? AND status = 'done'",
                       (run_id,)).fetchall()
con.close()


def med(v):
    v = sorted(v)
    return v[len(v) // 2] if len(v) % 2 else (v[len(v) // 2 - 1] + v[len(v) // 2]) / 2


moving = sorted(o for o in eval_objects if any(r[0] == o for r in ev_moves) and
                med([math.hypot(r[2], r[3]) + 0.02 * abs(r[4]) for r in ev_moves if r[0] == o]) >=
                0.1 * med([abs(r[1]) for r in ev_moves if r[0] == o]))
check(moving, "no evaluation object moved; the study's world should have some")
stored_areas = {(r["design"], int(r["seed"])): r for r in rows(os.path.join(report, "cell_measures.csv"))}
check(set(stored_areas) == set(object_curves), "cell_measures.csv has cells %s" % sorted(stored_areas))
area = {}
for key, oc in object_curves.items():
    ks = sorted(set.intersection(*(set(oc[o]) for o in moving)))
    points = [(k, math.log(sum(oc[o][k] for o in moving) / len(moving))) for k in ks]
    area[key] = sum((k1 - k0) * (v0 + v1) / 2 for (k0, v0), (k1, v1) in zip(points, points[1:])) / (ks[-1] - ks[0])
    check(key in stored_areas and close(stored_areas[key]["log_area"], area[key]),
          "cell_measures.csv %s: log area %s, recomputed %s" % (key, stored_areas.get(key, {}).get("log_area"), area[key]))
    if key[0] == "oracle":
        check(pushed_objects[key] <= set(moving), "the oracle %s pushed %s, beyond the moving objects %s"
              % (key, sorted(pushed_objects[key]), moving))
measures = rows(os.path.join(report, "measures.csv"))
for design in designs:
    if design == "random":
        continue
    row = next((r for r in measures if r["design"] == design and r["measure"] == "area"), None)
    if not check(row is not None, "measures.csv has no area ratio for %s" % design):
        continue
    mine = [area[k] for k in area if k[0] == design]
    base = [area[k] for k in area if k[0] == "random"]
    want = math.exp(sum(mine) / len(mine) - sum(base) / len(base))
    check(close(row["ratio_to_random"], want), "measures.csv %s: area ratio %s, recomputed %s" % (design, row["ratio_to_random"], want))
    check(float(row["ci_low"]) <= float(row["ratio_to_random"]) <= float(row["ci_high"]),
          "measures.csv %s: the interval does not hold the ratio" % design)

# Competence at one-push goals: the choosers that do not learn recomputed here from the evaluation set's outcomes alone
# (picking at random; picking the best), and competence.csv's cells from each cell's curve_goals.csv at the budget.
def dist(a, b):
    turn = math.remainder(a[2] - b[2], 2 * math.pi)
    return math.hypot(a[0] - b[0], a[1] - b[1]) + 0.02 * abs(turn)


goal_rows = {os.path.basename(d): rows(os.path.join(d, "curve_goals.csv"))
             for d in glob.glob(os.path.join(study, "cells", "*"))}  # each cell's file, read once
for o in moving:
    outs = [(r[2], r[3], r[4]) for r in ev_moves if r[0] == o]
    if len(outs) < 2:
        continue
    want_random = sum(sum(dist(outs[i], t) for i in range(len(outs)) if i != j) / (len(outs) - 1)
                      for j, t in enumerate(outs)) / len(outs)
    want_best = sum(min(dist(outs[i], t) for i in range(len(outs)) if i != j) for j, t in enumerate(outs)) / len(outs)
    for cell_name, cell_rows in goal_rows.items():
        r = next((r for r in cell_rows if r["object"] == o), None)
        if r:
            check(close(r["random_choice"], want_random, 1e-5) and close(r["best_choice"], want_best, 1e-5),
                  "%s/curve_goals.csv %s: random and best choice %s %s, recomputed %s %s" % (
                      cell_name, o, r["random_choice"], r["best_choice"], want_random, want_best))
competence = {(r["design"], int(r["seed"])): r for r in rows(os.path.join(report, "competence.csv"))}
check(set(competence) == set(object_curves), "competence.csv has cells %s" % sorted(competence))
for (design, seed), r in competence.items():
    goal = {}
    for g in goal_rows["%s-seed%03d" % (design, seed)]:
        goal.setdefault(g["object"], {})[int(g["experiments"])] = float(g["goal_error"])
    last = max(set.intersection(*(set(goal[o]) for o in moving)))
    want = sum(goal[o][last] for o in moving) / len(moving)
    check(close(r["goal_error_all"], want), "competence.csv %s seed %d: %s at the budget, recomputed %s"
          % (design, seed, r["goal_error_all"], want))

text = open(os.path.join(report, "report.md")).read()
check("## Competence: one-push goals" in text, "report.md has no competence section")
if "random_null" in designs:
    check("**The null**" in text, "report.md does not show the null arm")
check("no difference from random can be claimed" in text or "than random (area ratio" in text,
      "report.md has no plain sentence on the designs")
for design in designs:
    reached = [g for g in goals_kb if g[0] == design]
    if reached:
        line = "| %s | %d | %d (" % (design, len(reached), sum(g[3] for g in reached))
        check(line in text, "report.md's goal line for %s does not say %s" % (design, line))
for design in designs:
    check(design in text, "report.md does not mention %s" % design)
check("Wilcoxon" in text and "bootstrap" in text, "report.md lacks the test or the interval")

if problems:
    print("\n".join("FAIL: " + p for p in problems))
    sys.exit(1)
print("ok: the report agrees with %d knowledge bases (%d cells, evaluation set of %d pushes on %s)" % (
    len(cells) + 1, len(cells), len(ev), ", ".join(sorted(eval_objects))))
