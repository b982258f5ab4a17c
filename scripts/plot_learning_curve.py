#!/usr/bin/python3
"""The main job's learning curve (learning_curve.csv, written by xpersif_report) drawn as learning_curve.png,
with the study report's look (xpersif_plots.py).

usage: plot_learning_curve.py CSV PNG
exit: 0 drawn, 1 matplotlib is missing, 2 usage, 3 the CSV is missing or not a learning curve, 4 PNG not written
"""
import csv
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import xpersif_plots  # noqa: E402


def read_curves(path):
    """{design: ([k], [error])} from the CSV's columns 'experiments', DESIGN...; empty cells are skipped."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    if not rows or not rows[0] or rows[0][0] != "experiments" or len(rows[0]) < 2:
        raise ValueError("%s is not a learning curve (its first column must be 'experiments', then one per design)"
                         % path)
    designs = rows[0][1:]
    curves = {d: ([], []) for d in designs}
    for number, row in enumerate(rows[1:], 2):
        try:
            k = int(row[0])
            for design, cell in zip(designs, row[1:]):
                if cell.strip():
                    value = float(cell)
                    if math.isfinite(value):
                        curves[design][0].append(k)
                        curves[design][1].append(value)
        except (ValueError, IndexError):
            raise ValueError("%s line %d is not a row of numbers: %s" % (path, number, ",".join(row)))
    return designs, curves


def main(argv):
    if len(argv) != 2 or argv[0] in ("-h", "--help"):
        print(__doc__.strip(), file=sys.stdout if argv[:1] in (["-h"], ["--help"]) else sys.stderr)
        return 0 if argv[:1] in (["-h"], ["--help"]) else 2
    source, target = argv
    try:
        designs, curves = read_curves(source)
    except (OSError, ValueError) as e:
        print("plot_learning_curve: %s" % e, file=sys.stderr)
        return 3
    plt = xpersif_plots.pyplot()
    if plt is None:
        return 1
    fig, ax = plt.subplots(figsize=(8, 5))
    for design in designs:
        k, error = curves[design]
        ax.plot(k, error, label=design, color=xpersif_plots.design_colour(design, designs), marker=".")
    ax.set_title("Learning curves: each design's model judged on the evaluation pushes")
    xpersif_plots.learning_curve_axes(ax, "experiments learned from")
    fig.tight_layout()
    try:
        fig.savefig(target, dpi=100)
    except OSError as e:
        print("plot_learning_curve: %s cannot be written: %s" % (target, e), file=sys.stderr)
        return 4
    finally:
        plt.close(fig)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
