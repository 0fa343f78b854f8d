"""A study's figure: per metric, each condition's sessions, mean and 95 % interval.

Each panel is one metric, one line per condition: every session a dot (spread
up and down a little so equal values stay apart), the mean a black tick and
its 95 % interval (Student's t, `app.sessions.studies.summarise`) a whisker.
A metric has a range (a share of the task time lies in [0, 1], a time is not
negative): a whisker is clipped to it, where the t-interval of few sessions or
of values piled at one end would cross it; `summary.csv` keeps the interval as
computed. Each condition says how many sessions it has.
"""

from __future__ import annotations

import math
import random
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, BinaryIO

if TYPE_CHECKING:
    from matplotlib.axes import Axes

Row = dict[str, float | int | str | None]
# What a study's figure shows: the task time and Hoffman's fluency metrics, each as
# a share of the task time (so tasks of different lengths compare).
FIGURE_METRICS = ("task_s", "human_idle_share", "robot_idle_share", "concurrent_share",
                  "functional_delay_share")  # fmt: skip
# Each metric's title in words, with its unit; a metric not named here shows its key.
TITLES = {
    "task_s": "Task time (s)",
    "human_idle_share": "Human idle time (share of task)",
    "robot_idle_share": "Robot idle time (share of task)",
    "concurrent_share": "Concurrent activity (share of task)",
    "functional_delay_share": "Functional delay (share of task)",
    "human_idle_s": "Human idle time (s)",
    "robot_idle_s": "Robot idle time (s)",
    "concurrent_s": "Concurrent activity (s)",
    "functional_delay_s": "Functional delay (s)",
}
_DOTS = "#3b7bb0"
_JITTER = 0.18  # how far a dot strays above or below its condition's line


def figure_metrics(keys: Sequence[str]) -> list[str]:
    """The figure's metrics among `keys`; the first few of them if none is known."""
    return [k for k in FIGURE_METRICS if k in keys] or list(keys[:6])


def metric_range(key: str) -> tuple[float, float | None]:
    """What the metric's values can be: a share in [0, 1], a time or a count from 0."""
    return (0.0, 1.0) if key.endswith("_share") else (0.0, None)


def plot_summary(
    conditions: Sequence[str],
    summary: Sequence[Row],
    keys: Sequence[str],
    target: Path | BinaryIO,
    sessions: Sequence[int] = (),
    *,
    rows: Sequence[Row] = (),
    columns: int = 3,
    dpi: int = 100,
) -> None:
    """One panel per shown metric, up to `columns` a line, as a PNG to `target`: the
    sessions' values (`rows`, each with its "condition"), each condition's mean and
    95 % interval (`summary`, rows of `app.sessions.studies.SUMMARY_KEYS`). The
    PNG's `Sessions` text names the sessions it summarises, so it can be checked."""
    import matplotlib

    matplotlib.use("Agg")  # before pyplot: files only, never a window
    import matplotlib.pyplot as plt

    shown = [k for k in figure_metrics(keys) if any(r["metric"] == k for r in summary)]
    columns = min(columns, max(1, len(shown)))
    lines = -(-max(1, len(shown)) // columns)
    fig, axes = plt.subplots(
        lines, columns, squeeze=False,
        figsize=(3 + 3.6 * columns, 0.9 + (0.45 * len(conditions) + 1.0) * lines),
    )  # fmt: skip
    counts = _sessions_per_condition(conditions, summary, rows)
    names, shared = short_names(conditions)
    labels = [f"{names[c]}\nn = {counts[c]}" for c in conditions]
    for i, (ax, key) in enumerate(zip(axes.flat, shown, strict=False)):
        _panel(ax, key, conditions, summary, rows, counts)
        ax.set_yticks(range(len(conditions)), labels if i % columns == 0 else [])
    for ax in list(axes.flat)[len(shown) :]:
        ax.axis("off")
    single = " (none for a single session)" if min(counts.values(), default=0) < 2 else ""
    fig.suptitle((f"Conditions {shared} (each line names the *). " if shared else "")
                 + "Each dot is a session; black: the condition's mean and its 95 % interval"
                 + single, fontsize=10)  # fmt: skip
    fig.tight_layout()
    ids = ",".join(str(i) for i in sorted(sessions))
    fig.savefig(target, format="png", dpi=dpi,
                metadata={"Title": "tandem study", "Sessions": ids})  # fmt: skip
    plt.close(fig)


def _panel(
    ax: Axes,
    key: str,
    conditions: Sequence[str],
    summary: Sequence[Row],
    rows: Sequence[Row],
    counts: dict[str, int],
) -> None:
    """The metric's dots, means and whiskers, one line per condition (the first on top)."""
    from matplotlib.ticker import MaxNLocator, PercentFormatter

    low_end, high_end = metric_range(key)
    by_condition = {r["condition"]: r for r in summary if r["metric"] == key}
    reach = 0.0  # the largest value or whisker drawn
    for y, condition in enumerate(conditions):
        values = [float(v) for r in rows if r.get("condition") == condition
                  and isinstance(v := r.get(key), int | float)]  # fmt: skip
        reach = max([reach, *values])
        spread = random.Random(f"{key} {y}")  # the same dots every time it is drawn
        ax.scatter(values, [y + spread.uniform(-_JITTER, _JITTER) for _ in values],
                   s=16, color=_DOTS, alpha=0.55, linewidths=0, zorder=2)  # fmt: skip
        line = by_condition.get(condition, {})
        if not isinstance(mean := line.get("mean"), int | float):
            continue
        low, high = whisker(key, line)
        reach = max(reach, high)
        ax.errorbar([mean], [y], xerr=[[mean - low], [high - mean]], fmt="|", color="black",
                    markersize=14, capsize=4, elinewidth=1.2, zorder=3)  # fmt: skip
        n = line.get("n")
        if isinstance(n, int) and n != counts[condition]:
            ax.annotate(f"n = {n}", (high, y), xytext=(4, 4), textcoords="offset points",
                        fontsize=7)  # fmt: skip
    ax.set_ylim(len(conditions) - 0.5, -0.5)  # the first condition on top
    ax.set_title(TITLES.get(key, key), fontsize=10)
    ax.grid(axis="x", alpha=0.3)
    if high_end == 1.0:
        # Up to the next tenth above what is drawn: small shares are not squeezed
        # against 0 %, and the axis never goes past 100 %.
        top = min(1.0, math.ceil(reach * 10 + 1e-9) / 10 or 0.1)
        ax.set_xlim(-0.03 * top, top * 1.03)
        ax.xaxis.set_major_locator(MaxNLocator(nbins=5, steps=[1, 2, 5, 10]))
        ax.xaxis.set_major_formatter(PercentFormatter(1.0, decimals=0))
    else:
        ax.set_xlim(low_end, max(reach * 1.05, low_end + 1e-6))


def whisker(key: str, line: Mapping[str, object]) -> tuple[float, float]:
    """The 95 % interval of a summary row (`app.sessions.studies.SUMMARY_KEYS`) as
    drawn: clipped to the metric's range; the mean alone without an interval (one
    session)."""
    low_end, high_end = metric_range(key)
    mean = _number(line.get("mean"), 0.0)
    low = max(low_end, _number(line.get("ci95_low"), mean))
    high = _number(line.get("ci95_high"), mean)
    return low, high if high_end is None else min(high_end, high)


def short_names(conditions: Sequence[str]) -> tuple[dict[str, str], str]:
    """Each condition named by the factors that vary between them, and the name with
    "*" for those (empty when nothing is shared)."""
    parts = [c.split("/") for c in conditions]
    if len(conditions) < 2 or len({len(p) for p in parts}) != 1:
        return {c: c for c in conditions}, ""
    varying = [i for i in range(len(parts[0])) if len({p[i] for p in parts}) > 1]
    if len(varying) == len(parts[0]):
        return {c: c for c in conditions}, ""
    shared = "/".join("*" if i in varying else part for i, part in enumerate(parts[0]))
    names = {c: "/".join(p[i] for i in varying) for c, p in zip(conditions, parts, strict=True)}
    return names, shared


def _sessions_per_condition(
    conditions: Sequence[str], summary: Sequence[Row], rows: Sequence[Row]
) -> dict[str, int]:
    """Each condition's sessions: its rows, else the largest n of its summary."""
    if rows:
        return {c: sum(1 for r in rows if r.get("condition") == c) for c in conditions}
    return {
        c: max((n for r in summary if r["condition"] == c and isinstance(n := r["n"], int)),
               default=0)
        for c in conditions
    }  # fmt: skip


def _number(value: object, default: float) -> float:
    return float(value) if isinstance(value, int | float) else default
