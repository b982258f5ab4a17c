#!/usr/bin/env python3
"""Markdown tables from a run_tf_fanout.sh result directory (one sub-directory per run)."""
import glob
import json
import os
import statistics
import sys

PAPER = {1: 4.6, 3: 8.2, 5: 15.6, 10: 34.2}  # Table I means, ms between frames


def load(out):
    runs = {}
    for meta_path in glob.glob(os.path.join(out, "*", "meta.json")):
        d = os.path.dirname(meta_path)
        meta = json.load(open(meta_path))
        clients = []
        texts = [open(p).read() for p in sorted(glob.glob(os.path.join(d, "client_*.json")))]
        if os.path.exists(os.path.join(d, "clients.jsonl")):
            texts.append(open(os.path.join(d, "clients.jsonl")).read())
        for line in "\n".join(texts).splitlines():
            if line.strip().startswith("{"):
                try:
                    clients.append(json.loads(line))
                except ValueError:
                    pass
        runs[(meta["publisher"], meta["transforms"], meta["clients"])] = (meta, clients)
    return runs


def agg(meta, clients):
    """Per run: mean inter-frame ms (mean over clients), p99 (max over clients), rel. latency p50 (median
    over clients) and p99 (max over clients), frames lost (sum), achieved rate (mean)."""
    ok = [c for c in clients if c.get("received", 0) > 1]
    if not ok:
        return None
    f = lambda k: [c[k] for c in ok if c.get(k) is not None]
    return {
        "reports": "%d/%d" % (len(ok), meta["clients"]),
        "inter_mean": statistics.mean(f("inter_mean_ms")),
        "inter_p50": statistics.median(f("inter_p50_ms")),
        "inter_p99": max(f("inter_p99_ms")),
        "inter_max": max(f("inter_max_ms")),
        "rel_p50": statistics.median(f("lat_rel_p50_ms")),
        "rel_p99": max(f("lat_rel_p99_ms")),
        "abs_p50": statistics.median(f("lat_abs_p50_ms")),
        "abs_p99": max(f("lat_abs_p99_ms")),
        "lost": sum(f("lost")),
        "expected": sum(f("expected")),
        "rate": statistics.mean(f("rate_hz")),
        "cpu": meta.get("publisher_cpu_pct"),
        "load": meta.get("loadavg", ""),
    }


def fmt(x, digits=2):
    return "–" if x is None else ("%.*f" % (digits, x))


def cell(a, key, digits=2):
    return "–" if a is None else fmt(a[key], digits)


def lost(a):
    if a is None:
        return "–"
    return "%d / %d" % (a["lost"], a["expected"])


def main(out):
    runs = load(out)
    lines = []
    machine = os.path.join(out, "machine.txt")
    if os.path.exists(machine):
        lines += ["```"] + open(machine).read().strip().splitlines() + ["```", ""]

    clients = sorted({c for (p, n, c) in runs if n == 15})
    lines += ["### Fan-out: 15 transforms per frame, 1 kHz, N client processes", "",
              "Inter-frame: wall-clock time between two received frames at a client (mean: mean over clients; "
              "p50: median client; p99: worst client). Latency rel.: receipt − stamp − min over the run (p50: median client; p99: worst "
              "client). Lost: frames missing in the sequence / frames expected, summed over clients.", "",
              "| clients | paper mean | raw mean | raw p50 / p99 | raw lat. rel. p50 / p99 | raw lat. abs. p50 / p99 | raw lost "
              "| xpersim mean | xpersim p50 / p99 | xpersim lat. rel. p50 / p99 | xpersim lost | xpersim rate Hz |",
              "| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for c in clients:
        r = agg(*runs[("raw", 15, c)]) if ("raw", 15, c) in runs else None
        x = agg(*runs[("xpersim", 15, c)]) if ("xpersim", 15, c) in runs else None
        lines.append("| %d | %s | %s | %s / %s | %s / %s | %s / %s | %s | %s | %s / %s | %s / %s | %s | %s |" % (
            c, fmt(PAPER.get(c), 1) if c in PAPER else "–", cell(r, "inter_mean", 3), cell(r, "inter_p50"),
            cell(r, "inter_p99"), cell(r, "rel_p50"), cell(r, "rel_p99"), cell(r, "abs_p50"), cell(r, "abs_p99"),
            lost(r), cell(x, "inter_mean", 3), cell(x, "inter_p50"), cell(x, "inter_p99"), cell(x, "rel_p50"),
            cell(x, "rel_p99"), lost(x),
            cell(x, "rate", 0)))
    lines.append("")

    sizes = sorted({n for (p, n, c) in runs if c != 15 or True} - set())
    size_clients = sorted({c for (p, n, c) in runs if n != 15})
    sc = size_clients[0] if size_clients else 10
    sizes = sorted({n for (p, n, c) in runs if c == sc}) if size_clients else []
    if sizes:
      lines += ["### Scene size: %d clients, transforms per frame = dynamic nodes" % sc, "",
                "| nodes | raw mean | raw p99 | raw lat. rel. p50 / p99 | raw lost | raw rate Hz | raw CPU % "
                "| xpersim mean | xpersim p99 | xpersim lat. rel. p50 / p99 | xpersim lost | xpersim rate Hz | xpersim CPU % |",
                "| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
      for n in sizes:
          r = agg(*runs[("raw", n, sc)]) if ("raw", n, sc) in runs else None
          x = agg(*runs[("xpersim", n, sc)]) if ("xpersim", n, sc) in runs else None
          lines.append("| %d | %s | %s | %s / %s | %s | %s | %s | %s | %s | %s / %s | %s | %s | %s |" % (
              n, cell(r, "inter_mean", 3), cell(r, "inter_p99"), cell(r, "rel_p50"), cell(r, "rel_p99"), lost(r),
              cell(r, "rate", 0), "–" if r is None else r["cpu"], cell(x, "inter_mean", 3), cell(x, "inter_p99"),
              cell(x, "rel_p50"), cell(x, "rel_p99"), lost(x), cell(x, "rate", 0), "–" if x is None else x["cpu"]))
      lines.append("")

    lines += ["### Every run", "",
              "| run | client reports | rate Hz | inter mean / p99 / max ms | lat. rel. p50 / p99 ms | lat. abs. p50 / p99 ms "
              "| lost / expected | publisher CPU % | load avg |",
              "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- |"]
    for key in sorted(runs, key=lambda k: (k[1] != 15, k[0], k[1], k[2])):
        a = agg(*runs[key])
        name = "%s, %d transforms, %d clients" % key
        if a is None:
            lines.append("| %s | 0 | – | – | – | – | – | – | – |" % name)
            continue
        abs_ = "(sim stamps)" if key[0] == "xpersim" else "%s / %s" % (fmt(a["abs_p50"]), fmt(a["abs_p99"]))
        lines.append("| %s | %s | %s | %s / %s / %s | %s / %s | %s | %s | %s | %s |" % (
            name, a["reports"], fmt(a["rate"], 0), fmt(a["inter_mean"], 3), fmt(a["inter_p99"]), fmt(a["inter_max"]),
            fmt(a["rel_p50"]), fmt(a["rel_p99"]), abs_, lost(a), a["cpu"], a["load"]))
    print("\n".join(lines))


if __name__ == "__main__":
    main(sys.argv[1])
