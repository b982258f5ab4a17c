#!/usr/bin/python3
"""Compare two knowledge bases field by field: every stored field of every experiment, the goals, the
notions, XPERSim's world states at the start of every step and FEATURESELECTION's choice (the facts
features_chosen and feature_scores of every run), except times (wall-clock creation times; simulated start/finish times and feature-vector stamps,
which include the idle time of a lockstep clock). Exit 0 when equal, 1 with the differences listed.

usage: compare_kb.py A.db B.db [--keep-times]
exit: 0 equal; 1 they differ; 2 usage; 3 a file is missing or not a knowledge base"""
import json
import os
import sqlite3
import sys

TIME_COLUMNS = {"created", "started", "finished", "stamp", "updated", "time", "wall_time"}


def rows(path, table, keep_times):
    db = sqlite3.connect(f"file:{path}?mode=ro", uri=True)
    order = "run_id, step" if table == "world_states" else "id"  # a step taken again replaces its state
    cur = db.execute(f"SELECT * FROM {table} ORDER BY {order}")
    names = [d[0] for d in cur.description]
    out = []
    for row in cur:
        record = {}
        for name, value in zip(names, row):
            if name == "id" or (not keep_times and name in TIME_COLUMNS):
                continue
            if name.endswith("_json") and value:
                value = json.loads(value)
                if not keep_times:
                    value.pop("stamp", None)
            record[name] = value
        out.append(record)
    return out


def tables(path):
    db = sqlite3.connect(f"file:{path}?mode=ro", uri=True)
    return {r[0] for r in db.execute("SELECT name FROM sqlite_master WHERE type='table'")}


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    keep_times = "--keep-times" in sys.argv
    if "-h" in sys.argv[1:] or "--help" in sys.argv[1:]:
        print(__doc__)
        return 0
    unknown = [a for a in sys.argv[1:] if a.startswith("-") and a != "--keep-times"]
    if unknown or len(args) != 2:
        print(f"compare_kb: unknown option {unknown[0]}" if unknown else "compare_kb: give two knowledge bases",
              file=sys.stderr)
        print(__doc__, file=sys.stderr)
        return 2
    a, b = args
    for path in (a, b):
        if not os.path.isfile(path):
            print(f"compare_kb: {path} is not a knowledge base file (it does not exist)", file=sys.stderr)
            return 3
        try:
            tables(path)
        except sqlite3.DatabaseError as e:
            print(f"compare_kb: {path} is not a readable knowledge base: {e}", file=sys.stderr)
            return 3
    differences = 0
    compared = 0
    for table in sorted(tables(a) & tables(b) & {"experiments", "goals", "notions", "world_states"}):
        ra, rb = rows(a, table, keep_times), rows(b, table, keep_times)
        if len(ra) != len(rb):
            print(f"{table}: {len(ra)} rows in {a}, {len(rb)} in {b}")
            differences += 1
        for i, (x, y) in enumerate(zip(ra, rb)):
            compared += 1
            for key in sorted(set(x) | set(y)):
                if x.get(key) != y.get(key):
                    differences += 1
                    print(f"{table} row {i + 1} field {key}: {str(x.get(key))[:200]} != {str(y.get(key))[:200]}")
    # FEATURESELECTION's choice, as the run's facts (the other facts hold poses and calls of their moment).
    if "facts" in tables(a) & tables(b):
        query = ("SELECT run_id, literal FROM facts WHERE predicate IN ('features_chosen', 'feature_scores') "
                 "ORDER BY run_id, predicate, subject")
        fa = sqlite3.connect(f"file:{a}?mode=ro", uri=True).execute(query).fetchall()
        fb = sqlite3.connect(f"file:{b}?mode=ro", uri=True).execute(query).fetchall()
        compared += len(fa)
        if fa != fb:
            differences += 1
            print(f"feature choices: {fa} in {a}, {fb} in {b}")
    print(f"compared {compared} rows: {differences} differences")
    return 1 if differences else 0


if __name__ == "__main__":
    sys.exit(main())
