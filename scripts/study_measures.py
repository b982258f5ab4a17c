"""A study's measures that can tell designs apart (issue 38), from the cells' per-object learning curves alone.

The primary measure of a cell is the area under its log-error curve: the mean over the budget of log E(k), where
E(k) is the prediction error after k experiments averaged with equal weight over the learnable objects that move
(so the object with the most evaluation pushes, or one that never moves and is trivially predicted, does not
decide it). A design's ratio to random is exp(mean area of the design - mean area of random): the ratio of the two
curves' geometric-mean errors over the budget; 0.90 is an error 10 % lower on average. Its 95 % interval comes from
a bootstrap over seeds: unpaired (each arm's seeds resampled on their own) and paired by seed (the differences
resampled). The same for the error at fixed shares of the budget.

The null is a second random arm on other seeds ("random_null"): its ratio to random must come out 1.00 within its
interval; its spread gives the smallest effect the study can detect (80 % power, 5 % two-sided). The oracle is a
random design told which objects are unlearnable or trivial (it pushes only the learnable objects that move): a
design's fraction of the oracle's gain is (area of random - area of the design) / (area of random - area of the
oracle).

Pure Python, no ROS: scripts/study.py writes the report with it; test/study_measures_test.py tests it.
"""

import math
import random

TURN_ARM = 0.02  # m: a turn counts as the travel of a point this far from the centre (core::surprise)
MOVES_SHARE = 0.1  # an object moves when its median travel is at least this share of its median push distance
Z_95, Z_80 = 1.959964, 0.841621
NULL = "random_null"
ORACLE = "oracle"
BASE = "random"


def travel(dx, dy, dyaw):
    return math.hypot(dx, dy) + TURN_ARM * abs(dyaw)


def median(values):
    s = sorted(values)
    n = len(s)
    if not n:
        return float("nan")
    return s[n // 2] if n % 2 else 0.5 * (s[n // 2 - 1] + s[n // 2])


def moving_objects(evaluation_rows, objects):
    """The objects of the evaluation set that move when pushed, and each object's median travel as a share of its
    median push distance. evaluation_rows: dicts with object, distance, dx, dy, dyaw."""
    shares = {}
    for o in objects:
        rows = [r for r in evaluation_rows if r["object"] == o]
        if not rows:
            continue
        pushed = median([abs(float(r["distance"])) for r in rows])
        moved = median([travel(float(r["dx"]), float(r["dy"]), float(r["dyaw"])) for r in rows])
        shares[o] = moved / pushed if pushed > 0 else 0.0
    return [o for o in objects if shares.get(o, 0.0) >= MOVES_SHARE], shares


def balanced_curve(object_curves, objects):
    """[(k, E(k))]: the error averaged with equal weight over `objects`, at the checkpoints every one of them has.
    object_curves: {object: {k: error}}."""
    present = [o for o in objects if o in object_curves]
    if not present:
        return []
    ks = sorted(set.intersection(*(set(object_curves[o]) for o in present)))
    return [(k, sum(object_curves[o][k] for o in present) / len(present)) for k in ks]


def log_area(curve):
    """The mean of log E over [first k, last k] by the trapezoid rule (a single point: its log)."""
    pts = [(k, math.log(max(e, 1e-12))) for k, e in curve]
    if len(pts) == 1:
        return pts[0][1]
    span = pts[-1][0] - pts[0][0]
    if span <= 0:
        return sum(v for _, v in pts) / len(pts)
    return sum((k1 - k0) * (v0 + v1) / 2 for (k0, v0), (k1, v1) in zip(pts, pts[1:])) / span


def error_at(curve, k):
    """E at the first checkpoint at or after k (the last one if none)."""
    for kk, e in curve:
        if kk >= k:
            return e
    return curve[-1][1]


def mean(values):
    return sum(values) / len(values)


def _percentiles(samples):
    s = sorted(samples)
    return s[int(0.025 * (len(s) - 1))], s[int(math.ceil(0.975 * (len(s) - 1)))]


def ratio(design_logs, base_logs, rng, rounds=2000):
    """Unpaired: exp(mean(design) - mean(base)) and its 95 % bootstrap interval; values are logs (one per seed)."""
    point = math.exp(mean(design_logs) - mean(base_logs))
    boots = [math.exp(mean([rng.choice(design_logs) for _ in design_logs]) - mean([rng.choice(base_logs) for _ in base_logs]))
             for _ in range(rounds)]
    lo, hi = _percentiles(boots)
    return point, lo, hi


def paired_ratio(design_by_seed, base_by_seed, rng, rounds=2000):
    """Paired by seed: exp(mean of the differences) and its 95 % bootstrap interval, or None with fewer than 2 pairs."""
    seeds = sorted(set(design_by_seed) & set(base_by_seed))
    if len(seeds) < 2:
        return None
    diffs = [design_by_seed[s] - base_by_seed[s] for s in seeds]
    boots = [math.exp(mean([rng.choice(diffs) for _ in diffs])) for _ in range(rounds)]
    lo, hi = _percentiles(boots)
    return math.exp(mean(diffs)), lo, hi


def correlation(xs, ys):
    n = len(xs)
    if n < 3:
        return float("nan")
    mx, my = mean(xs), mean(ys)
    sxy = sum((x - mx) * (y - my) for x, y in zip(xs, ys))
    sx = math.sqrt(sum((x - mx) ** 2 for x in xs))
    sy = math.sqrt(sum((y - my) ** 2 for y in ys))
    return sxy / (sx * sy) if sx > 0 and sy > 0 else float("nan")


def detectable_effect(base_logs, other_logs=None):
    """The smallest drop of the ratio (1 - ratio) that this many seeds detect with 80 % power at 5 % two-sided: from
    the spread of the two arms' areas (the null arm's when given, random's twice otherwise)."""
    def var(v):
        m = mean(v)
        return sum((x - m) ** 2 for x in v) / (len(v) - 1) if len(v) > 1 else float("nan")
    other = other_logs if other_logs else base_logs
    se = math.sqrt(var(base_logs) / len(base_logs) + var(other) / len(other))
    return 1.0 - math.exp(-(Z_95 + Z_80) * se)


def oracle_fraction(design_logs, base_logs, oracle_logs, rng, rounds=2000):
    """(random - design) / (random - oracle) in log area, with its 95 % bootstrap interval; None when the oracle
    gains nothing over random (nothing to share)."""
    def frac(d, b, o):
        gain = mean(b) - mean(o)
        return (mean(b) - mean(d)) / gain if abs(gain) > 1e-12 else float("nan")
    point = frac(design_logs, base_logs, oracle_logs)
    if math.isnan(point):
        return None
    boots = []
    for _ in range(rounds):
        f = frac([rng.choice(design_logs) for _ in design_logs], [rng.choice(base_logs) for _ in base_logs],
                 [rng.choice(oracle_logs) for _ in oracle_logs])
        if not math.isnan(f):
            boots.append(f)
    lo, hi = _percentiles(boots) if boots else (float("nan"), float("nan"))
    return point, lo, hi


MIN_SEEDS = 5  # below this a bootstrap over seeds has too few distinct resamples to give an interval


def verdict(design, r, lo, hi, seeds=MIN_SEEDS):
    """The plain sentence for one design's area ratio to random."""
    if seeds < MIN_SEEDS:
        return ("%s: no difference from random can be claimed: %d seeds are too few for an interval (area ratio %.3f; "
                "at least %d seeds per arm)" % (design, seeds, r, MIN_SEEDS))
    if lo <= 1.0 <= hi:
        return ("%s: no difference from random can be claimed (area ratio %.3f, 95 %% CI %.3f-%.3f includes 1)"
                % (design, r, lo, hi))
    better = hi < 1.0
    return "%s: %s than random (area ratio %.3f, 95 %% CI %.3f-%.3f)" % (
        design, "lower error" if better else "higher error", r, lo, hi)


def measures(cells, objects, budget, seed=0):
    """Everything the report shows. cells: {(design, seed): {object: {k: error}}}; objects: the learnable objects
    that move. Returns a dict: per-cell areas and budget errors, and per design the ratios to random."""
    rng = random.Random(seed)
    fractions = (("quarter", max(1, int(math.ceil(budget / 4.0)))), ("half", max(1, int(math.ceil(budget / 2.0)))),
                 ("all", budget))
    per_cell = {}
    for key, object_curves in cells.items():
        curve = balanced_curve(object_curves, objects)
        if not curve:
            continue
        per_cell[key] = {"area": log_area(curve), "curve": curve,
                         **{"error_" + name: error_at(curve, k) for name, k in fractions}}
    designs = sorted({d for d, _ in per_cell}, key=lambda d: (d != BASE, d != NULL, d == ORACLE, d))
    by_design = {d: {s: v for (dd, s), v in per_cell.items() if dd == d} for d in designs}
    out = {"cells": per_cell, "designs": designs, "fractions": fractions, "rows": [], "verdicts": []}
    base = by_design.get(BASE)
    if not base:
        return out
    base_area = [v["area"] for v in base.values()]
    null_area = [v["area"] for v in by_design.get(NULL, {}).values()] or None
    oracle_area = [v["area"] for v in by_design.get(ORACLE, {}).values()] or None
    out["detectable"] = detectable_effect(base_area, null_area) if len(base_area) > 1 else float("nan")
    for d in designs:
        if d == BASE:
            continue
        cells_d = by_design[d]
        row = {"design": d, "seeds": len(cells_d)}
        for name in ["area"] + ["error_" + n for n, _ in fractions]:
            logs_d = [v[name] if name == "area" else math.log(v[name]) for v in cells_d.values()]
            logs_b = [v[name] if name == "area" else math.log(v[name]) for v in base.values()]
            row[name] = ratio(logs_d, logs_b, rng)
            if name == "area":
                row["paired"] = paired_ratio({s: v["area"] for s, v in cells_d.items()},
                                             {s: v["area"] for s, v in base.items()}, rng)
                common = sorted(set(cells_d) & set(base))
                row["pairing_r"] = correlation([cells_d[s]["area"] for s in common], [base[s]["area"] for s in common])
        if oracle_area and d != ORACLE:
            row["oracle_fraction"] = oracle_fraction([v["area"] for v in cells_d.values()], base_area, oracle_area, rng)
        out["rows"].append(row)
        out["verdicts"].append(verdict(d, *row["area"], seeds=min(len(cells_d), len(base))))
    null_row = next((r for r in out["rows"] if r["design"] == NULL), None)
    if null_row:
        r, lo, hi = null_row["area"]
        out["null_ok"] = lo <= 1.0 <= hi
        out["null_seeds"] = min(null_row["seeds"], len(base))
    # A fraction of a gain the oracle does not show (its area ratio's interval reaches 1: in a world where every object
    # is learnable, the oracle is random design) is a ratio of two noises: thousands of per cent, either sign.
    oracle_row = next((r for r in out["rows"] if r["design"] == ORACLE), None)
    if oracle_row and oracle_row["area"]:
        out["oracle_gains"] = oracle_row["area"][2] < 1.0
        if not out["oracle_gains"]:
            for row in out["rows"]:
                row.pop("oracle_fraction", None)
    return out


def competence(goal_cells, references, objects, budget, seed=0):
    """Competence at one-push goals (core::oneShotGoalErrors): per cell, the goal error after a quarter, half and all
    of the budget, averaged with equal weight over `objects`; per design its mean and its ratio to random with a 95 %
    bootstrap interval; and the two choosers that do not learn, averaged the same way: picking a push at random (what
    a model that knows nothing gets) and picking the best (the floor the evaluation pushes allow).
    goal_cells: {(design, seed): {object: {k: goal error}}}; references: {object: (random choice, best choice)}."""
    rng = random.Random(seed)
    fractions = (("quarter", max(1, int(math.ceil(budget / 4.0)))), ("half", max(1, int(math.ceil(budget / 2.0)))),
                 ("all", budget))
    present = [o for o in objects if o in references]
    out = {"fractions": fractions, "cells": {}, "rows": [], "means": {},
           "random_choice": mean([references[o][0] for o in present]) if present else float("nan"),
           "best_choice": mean([references[o][1] for o in present]) if present else float("nan")}
    for key, curves in goal_cells.items():
        curve = balanced_curve(curves, objects)
        if curve:
            out["cells"][key] = {name: error_at(curve, k) for name, k in fractions}
    designs = sorted({d for d, _ in out["cells"]}, key=lambda d: (d != BASE, d != NULL, d == ORACLE, d))
    by_design = {d: [v for (dd, _), v in out["cells"].items() if dd == d] for d in designs}
    for d in designs:
        out["means"][d] = {name: mean([v[name] for v in by_design[d]]) for name, _ in fractions}
    base = by_design.get(BASE)
    for d in designs:
        if d == BASE or not base:
            continue
        row = {"design": d, "seeds": len(by_design[d])}
        for name, _ in fractions:
            row[name] = ratio([math.log(max(v[name], 1e-12)) for v in by_design[d]],
                              [math.log(max(v[name], 1e-12)) for v in base], rng)
        out["rows"].append(row)
    return out
