"""A study's results in the review: its per-condition table and its figure.

`study_results(store, name)` reads a study back from the store's
`study_sessions` table as `tandem study` summarises it: the counted session of
each (condition, participant) (the latest at a final result), its metrics, and
per condition their means (app.sessions.studies). `study_markdown` is the
table, conditions as rows, named by the factors that vary between them (the
others said once above). `StudyView` is the review's "Study" dropdown, the
table and the figure (the same matplotlib figure as `tandem study`'s, one panel
a line to fit the tab), each one element whose contents are replaced.
"""

from __future__ import annotations

import io
import sqlite3
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import viser
from PIL import Image

from app.dashboard import widgets
from app.sessions.database import StoreError
from app.sessions.metrics import SessionMetrics, session_metrics
from app.sessions.store import SessionStore
from app.sessions.studies import (
    FIGURE_METRICS,
    Row,
    condition_summary,
    finished,
    plot_summary,
    study_names,
    study_sessions,
)

NO_STUDY = "(no studies)"
CHOOSE = "(choose a study)"
FIGURE_DPI = 70  # one panel a line at 6.5 in: about the tab's 470 px
# The table's columns: the metric, its heading, and whether it is a share.
COLUMNS = (("task_s", "task s", False), ("human_idle_share", "human idle", True),
           ("robot_idle_share", "robot idle", True), ("concurrent_share", "concurrent", True),
           ("functional_delay_share", "delay", True))  # fmt: skip


@dataclass(frozen=True)
class StudyResults:
    """A study as the store holds it: its conditions (short names, in the order
    first run), the counted sessions per condition, and the summary rows."""

    name: str
    conditions: tuple[str, ...]
    common: str  # the factors every condition shares, "*" where they vary
    counted: dict[str, int]
    stale: int  # tagged sessions not counted (interrupted, or run again)
    summary: list[Row]
    sessions: tuple[int, ...]
    rows: tuple[Row, ...] = ()  # each counted session's metrics: the figure's dots


def short_names(conditions: Sequence[str]) -> tuple[dict[str, str], str]:
    """Each condition named by the factors that vary, and the shared ones ("*" for
    the varying)."""
    parts = [c.split("/") for c in conditions]
    if len(conditions) < 2 or len({len(p) for p in parts}) != 1:
        return {c: c for c in conditions}, ""
    varying = [i for i in range(len(parts[0])) if len({p[i] for p in parts}) > 1]
    common = "/".join("*" if i in varying else part for i, part in enumerate(parts[0]))
    return {c: "/".join(p[i] for i in varying) for c, p in zip(conditions, parts, strict=True)}, (
        common
    )


def _measured(store: SessionStore, session_id: int) -> SessionMetrics:
    return session_metrics(store.events(session_id), store.get(session_id).clock)


def study_results(store: SessionStore, name: str) -> StudyResults:
    """The study `name`'s counted sessions and their summary per condition."""
    tagged = study_sessions(store.db, name)
    full = list(dict.fromkeys(s.condition for s in tagged))
    short, common = short_names(full)
    counted = finished(tagged)
    rows: list[Row] = [
        {"condition": short[s.condition], **_measured(store, s.session_id).row()}
        for s in counted.values()
    ]
    conditions = tuple(short[c] for c in full)
    per_condition = {c: sum(1 for r in rows if r["condition"] == c) for c in conditions}
    return StudyResults(
        name, conditions, common, per_condition, len(tagged) - len(counted),
        condition_summary(conditions, rows, FIGURE_METRICS),
        tuple(sorted(s.session_id for s in counted.values())), tuple(rows),
    )  # fmt: skip


def _cell(value: object, share: bool) -> str:
    if not isinstance(value, int | float):
        return "–"
    return f"{value:.0%}" if share else f"{value:.1f}"


def study_markdown(results: StudyResults) -> str:
    """The per-condition table: sessions counted and the metrics' means."""
    means = {(r["condition"], r["metric"]): r["mean"] for r in results.summary}
    total = sum(results.counted.values())
    head = (f"**Study {results.name}**: {total} sessions in {len(results.conditions)} "
            f"conditions" + (f" ({results.common})" if results.common else ""))  # fmt: skip
    if results.stale:
        head += f"; {results.stale} interrupted or run again, not counted"
    lines = [
        head + ". Means per condition:",
        "",
        "| condition | n | " + " | ".join(words for _, words, _ in COLUMNS) + " |",
        "|---|---|" + "---|" * len(COLUMNS),
    ]
    for c in results.conditions:
        cells = " | ".join(_cell(means.get((c, key)), share) for key, _, share in COLUMNS)
        lines.append(f"| {c} | {results.counted.get(c, 0)} | {cells} |")
    return "\n".join(lines)


def figure(results: StudyResults) -> np.ndarray:
    """The study's figure, one panel a line, as RGB pixels."""
    png = io.BytesIO()
    plot_summary(results.conditions, results.summary, FIGURE_METRICS, png, results.sessions,
                 rows=results.rows, columns=1, dpi=FIGURE_DPI)  # fmt: skip
    png.seek(0)
    with Image.open(png) as image:
        return np.asarray(image.convert("RGB"))


class StudyView:
    """The review's "Study" dropdown, its table and its figure."""

    def __init__(self, gui: viser.GuiApi, store: SessionStore) -> None:
        self.store = store
        self.shown: StudyResults | None = None
        self.pick: viser.GuiDropdownHandle[str] = gui.add_dropdown("Study", [NO_STUDY])
        self.pick.on_update(lambda e: self.show(str(self.pick.value)) if e.client else None)
        self.table = gui.add_markdown("")
        self.figure: viser.GuiImageHandle = gui.add_image(
            np.zeros((8, 8, 3), np.uint8), format="png", visible=False
        )
        self.refresh()

    def refresh(self) -> None:
        """The studies in the store (a study may have run since)."""
        try:
            names = study_names(self.store.db)
        except (StoreError, sqlite3.DatabaseError) as err:
            self.table.content = f"**Error:** {err}"
            return
        options = [CHOOSE, *names] if names else [NO_STUDY]
        if list(self.pick.options) != options:
            self.pick.options = options
        if self.shown is None or self.shown.name not in names:
            widgets.show(self.pick, options[0])

    def show(self, name: str) -> None:
        if self.pick.value != name and name in self.pick.options:
            widgets.show(self.pick, name)  # shown from here (not the page): the page follows
        if name in (NO_STUDY, CHOOSE):
            self.shown = None
            self.table.content = ""
            self.figure.visible = False
            return
        try:
            results = study_results(self.store, name)
        except (StoreError, sqlite3.DatabaseError) as err:
            self.table.content = f"**Error:** {err}"
            return
        self.shown = results
        self.table.content = study_markdown(results)
        self.figure.image = figure(results)
        self.figure.visible = True
