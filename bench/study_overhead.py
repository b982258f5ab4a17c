#!/usr/bin/python3
"""Where a study's cells spend the time that is not experiments: bring-up (the cell's launch to the start of its
first experiment) and tear-down (its last experiment stored to roslaunch's exit), from file times and the knowledge
bases' `created` stamps. bench/loop_speed.md, 2026-11-29.

usage: study_overhead.py STUDY_DIR     (the --out of scripts/study.sh)"""
import datetime
import os
import sqlite3
import sys


def stamp(text):
    return datetime.datetime.strptime(text, "%Y-%m-%dT%H:%M:%S.%fZ").replace(tzinfo=datetime.timezone.utc).timestamp()


def main(study):
    total = overhead = 0.0
    for name in sorted(os.listdir(os.path.join(study, "cells"))):
        cell = os.path.join(study, "cells", name)
        if not os.path.exists(os.path.join(cell, "status")):
            continue  # not finished
        start = os.stat(os.path.join(cell, "experiment.yaml")).st_mtime  # written just before its launch
        end = os.stat(os.path.join(cell, "launch.log")).st_mtime
        db = sqlite3.connect("file:%s?mode=ro" % os.path.join(cell, "knowledge.db"), uri=True)
        first, last, n = db.execute("SELECT min(created), max(created), count(*) FROM experiments").fetchone()
        first, last = stamp(first), stamp(last)
        per = (last - first) / max(n - 1, 1)
        bring_up = first - start - per  # `created` is when an experiment was stored, one experiment after it began
        tear_down = end - last
        total += end - start
        overhead += bring_up + tear_down
        print("%-30s cell %6.1f s  bring-up %4.1f s  tear-down %4.1f s  per experiment %.2f s (%d)"
              % (name, end - start, bring_up, tear_down, per, n))
    if total:
        print("all cells: %.0f s, of which bring-up and tear-down %.0f s (%.1f %%)" % (total, overhead, 100 * overhead / total))


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
