"""The sweep's figure: planning time and tree size against each varied setting.

One row of two panels per varied setting (seconds, nodes of the unfolded tree);
one line per scenario and combination of the other settings, so a line shows
what that one setting changes. Drawn with matplotlib's Agg backend: no display.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from planner.sweep import Variation


def plot_sweep(rows: Sequence[dict[str, Any]], variations: Sequence[Variation], out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")  # before pyplot: files only, never a window
    import matplotlib.pyplot as plt

    names = [v.name for v in variations]
    fig, axes = plt.subplots(
        len(variations), 2, figsize=(13, 3.2 * len(variations)), squeeze=False
    )
    for row_axes, variation in zip(axes, variations, strict=True):
        others = [n for n in names if n != variation.name]
        lines: dict[str, dict[Any, dict[str, Any]]] = {}
        for row in rows:
            label = ", ".join([row["scenario"], *(f"{n}={row[n]}" for n in others)])
            lines.setdefault(label, {})[row[variation.name]] = row
        xs = list(range(len(variation.values)))
        for column, (key, title) in enumerate((("plan_s", "plan s"), ("N", "tree nodes N"))):
            ax = row_axes[column]
            for label, by_value in lines.items():
                ys = [_number(by_value.get(v, {}).get(key)) for v in variation.values]
                ax.plot(xs, ys, marker="o", label=label)
            ax.set_xticks(xs, [str(v) for v in variation.values])
            ax.set_xlabel(variation.name)
            ax.set_ylabel(title)
            ax.grid(alpha=0.3)
        # Beside the panels, not on them: with a dozen lines no corner is empty.
        row_axes[1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0))
    fig.tight_layout()
    fig.savefig(out, dpi=100)
    plt.close(fig)


def _number(value: object) -> float:
    # A variant without a plan has no size or time: a gap in its line.
    return float(value) if isinstance(value, int | float) else float("nan")
