#!/usr/bin/python3
"""Which allocation paid in a finished study: pushes per object against the final held-out error, paired by seed.

    /usr/bin/python3 bench/study_shares.py OUT [--design learning_progress]

Reads OUT/report/cells.csv (scripts/study.py writes it) and prints, per seed, the design's and random's pushes per
object and final errors, then for each object the Spearman correlation over seeds between the design's extra
pushes of that object (design minus random) and its final error's difference from random's. A negative
correlation: seeds where the design pushed that object more are the seeds where it beat random.
"""
import argparse
import csv
import os
import sys

from scipy import stats


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("study", help="the study's --out directory")
    parser.add_argument("--design", default="learning_progress", help="the design compared with random")
    args = parser.parse_args()
    path = os.path.join(args.study, "report", "cells.csv")
    if not os.path.exists(path):
        sys.exit(f"study_shares: {path} does not exist; run the study (or its --report-only) first")
    rows = list(csv.DictReader(open(path)))
    objects = [key[2:] for key in rows[0] if key.startswith("n_")]
    cells = {(row["design"], int(row["seed"])): row for row in rows}
    seeds = sorted(seed for design, seed in cells if design == args.design and ("random", seed) in cells)
    if len(seeds) < 3:
        sys.exit(f"study_shares: {len(seeds)} seeds have both random and {args.design}; at least 3 are needed")

    def share(row, obj):
        return int(row["n_" + obj]) / max(1, sum(int(row["n_" + o]) for o in objects))

    print(f"pushes per object ({', '.join(objects)}); final error (m)")
    print(f"| seed | random | {args.design} | difference (m) |")
    print("|---|---|---|---|")
    differences = []
    for seed in seeds:
        rnd, des = cells[("random", seed)], cells[(args.design, seed)]
        difference = float(des["final_error"]) - float(rnd["final_error"])
        differences.append(difference)
        counts = lambda row: " ".join(row["n_" + o] for o in objects)
        print(f"| {seed} | {counts(rnd)}; {float(rnd['final_error']):.4f} | {counts(des)}; "
              f"{float(des['final_error']):.4f} | {difference:+.4f} |")
    print()
    print(f"| object | mean share, random | mean share, {args.design} | Spearman rho (extra share, error difference) | p |")
    print("|---|---|---|---|---|")
    for obj in objects:
        extra = [share(cells[(args.design, s)], obj) - share(cells[("random", s)], obj) for s in seeds]
        rho, p = stats.spearmanr(extra, differences)
        mean = lambda design: sum(share(cells[(design, s)], obj) for s in seeds) / len(seeds)
        print(f"| {obj} | {100 * mean('random'):.0f} % | {100 * mean(args.design):.0f} % | {rho:+.2f} | {p:.3f} |")
    print(f"\n{len(seeds)} seeds; {sum(d < 0 for d in differences)} with a lower final error than random's")


if __name__ == "__main__":
    main()
