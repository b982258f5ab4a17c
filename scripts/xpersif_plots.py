"""Figures shared by the main job's report (xpersif_report, through plot_learning_curve.py) and the study report
(study.py): one look for one kind of figure — the same axes, units, legend and a fixed colour per design."""

# A design keeps its colour in every figure (matplotlib's tab10), whatever order the designs are listed in.
DESIGN_COLOURS = {
    "random": "tab:blue",
    "curiosity": "tab:orange",
    "learning_progress": "tab:green",
    "grid": "tab:red",
    "error_max": "tab:purple",
}
_SPARE = ["tab:brown", "tab:pink", "tab:gray", "tab:olive", "tab:cyan"]


def design_colour(design, designs):
    """The colour of design; designs without a colour of their own take the spare ones in the order listed."""
    if design in DESIGN_COLOURS:
        return DESIGN_COLOURS[design]
    others = [d for d in designs if d not in DESIGN_COLOURS]
    return _SPARE[others.index(design) % len(_SPARE)] if design in others else _SPARE[0]


def pyplot():
    """matplotlib's pyplot without a display, or None (with a sentence on stderr) when it is missing."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        import sys
        print("matplotlib is missing (Debian's python3-matplotlib): no figure is drawn, the CSV files are written",
              file=sys.stderr)
        return None
    return plt


def learning_curve_axes(ax, xlabel):
    """The learning curves' axes: experiments learned from against the held-out RMS error in metres."""
    from matplotlib.ticker import MaxNLocator
    ax.set_xlabel(xlabel)
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))  # experiments are counted
    ax.set_ylabel("RMS prediction error on the evaluation set (m)")
    ax.set_ylim(bottom=0)
    ax.grid(True, alpha=0.3)
    ax.legend()
