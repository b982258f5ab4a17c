#!/usr/bin/python3
"""What one study cell costs (issue 39; doc/slurm.md, bench/slurm.md): the cell run exactly as a study runs it
(study.start: roslaunch on a master of its own), its memory sampled every 0.2 s as the sum of the resident sets of
roslaunch and every process under it (the master, the managers, the nodes), and of their proportional sets (PSS:
shared pages counted once), and its CPU time from the kernel's accounting of
the processes it waited for.

    bench/cell_cost.py EXPERIMENT_FILE RUN_DIR      (after `source scripts/env.sh`; e.g. an OUT/experiments/*.yaml)
exit: 0 measured; 1 the cell failed; 2 usage
"""
import os
import resource
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "scripts"))
import study  # noqa: E402

PAGE = os.sysconf("SC_PAGE_SIZE")


def tree_rss(root):
    """(sum of the resident sets of the process and its descendants, the largest one), bytes. roslaunch starts each
    node in a session of its own, so the tree, not the session, is the cell."""
    parent, rss = {}, {}
    for pid in os.listdir("/proc"):
        if not pid.isdigit():
            continue
        try:
            with open("/proc/%s/stat" % pid) as f:
                fields = f.read().rsplit(")", 1)[1].split()
            parent[int(pid)] = int(fields[1])  # field 4 of stat: the parent
            rss[int(pid)] = int(fields[21]) * PAGE  # field 24: resident pages
        except (OSError, IndexError, ValueError):
            continue
    cell, grew = {root}, True
    while grew:
        more = {p for p, pp in parent.items() if pp in cell and p not in cell}
        cell |= more
        grew = bool(more)
    sizes = [rss.get(p, 0) for p in cell]
    return sum(sizes), max(sizes), sum(pss(p) for p in cell)


def pss(pid):
    """The process's proportional set size (shared pages divided among their users), bytes; 0 when it is gone."""
    try:
        with open("/proc/%d/smaps_rollup" % pid) as f:
            for line in f:
                if line.startswith("Pss:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError):
        pass
    return 0


def main(argv):
    if len(argv) != 2:
        print(__doc__.strip().splitlines()[-2].strip(), file=sys.stderr)
        return 2
    cell = study.Cell("cost", "cost", 0, 0, os.path.abspath(argv[0]), os.path.abspath(argv[1]))
    study.start(cell)
    peak, largest, peak_pss = 0, 0, 0
    while cell.process.poll() is None:
        total, big, proportional = tree_rss(cell.process.pid)
        peak, largest, peak_pss = max(peak, total), max(largest, big), max(peak_pss, proportional)
        time.sleep(0.2)
    wall = time.time() - cell.started
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = usage.ru_utime + usage.ru_stime
    print("cell %s: %s, wall %.1f s, CPU %.1f s (user %.1f, system %.1f): %.2f cores on average; peak memory %.0f MiB "
          "proportional (PSS), %.0f MiB resident (RSS summed over its processes), largest process %.0f MiB" % (
              os.path.basename(argv[0]), "finished" if cell.finished() else "FAILED", wall, cpu, usage.ru_utime,
              usage.ru_stime, cpu / wall, peak_pss / 2**20, peak / 2**20, largest / 2**20))
    return 0 if cell.finished() else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
