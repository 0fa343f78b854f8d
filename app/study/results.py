"""A study's results: `sessions.csv` (one row per counted session: its tags and
metrics), `summary.csv` (per condition and metric: n, mean, sd, 95 % interval)
and `summary.png`."""

from __future__ import annotations

import csv
from collections.abc import Sequence
from pathlib import Path

from app.execution.events import ExecutionEvent
from app.sessions.store import SessionStore
from app.sessions.studies import (
    Job,
    Study,
    StudySession,
    condition_summary,
    finished,
    jobs,
    study_sessions,
)
from app.sessions.study_figure import plot_summary

Row = dict[str, float | int | str | None]
TAG_COLUMNS = ("study", "condition", "scenario", "safety", "verbosity", "behaviour",
               "channel", "participant", "seed", "session_id", "result")  # fmt: skip
SUMMARY_COLUMNS = ("condition", "metric", "n", "mean", "sd", "ci95_low", "ci95_high")


def write_results(study: Study, store: SessionStore, out: Path) -> list[Row]:
    """sessions.csv, summary.csv and summary.png of the study's counted sessions."""
    counted = finished(study_sessions(store.db, study.name))
    rows: list[Row] = []
    keys: tuple[str, ...] = ()
    for job in jobs(study):
        session = counted.get((job.condition.name, job.participant))
        if session is None:
            continue
        keys, metrics = session_metrics(store.events(session.session_id), session.clock)
        rows.append({**_tags(job, session), **metrics})
    out.mkdir(parents=True, exist_ok=True)
    _write_csv(out / "sessions.csv", [*TAG_COLUMNS, *keys], rows)
    summary = condition_summary([c.name for c in study.conditions], rows, keys)
    _write_csv(out / "summary.csv", SUMMARY_COLUMNS, summary)
    ids = [int(i) for r in rows if isinstance(i := r["session_id"], int)]
    plot_summary([c.name for c in study.conditions], summary, keys, out / "summary.png", ids,
                 rows=rows)  # fmt: skip
    return rows


def _tags(job: Job, session: StudySession) -> Row:
    c = job.condition
    return {
        "study": job.study, "condition": c.name, "scenario": c.scenario_name,
        "safety": c.safety, "verbosity": c.verbosity, "behaviour": c.behaviour,
        "channel": c.channel, "participant": job.participant, "seed": job.seed,
        "session_id": session.session_id, "result": session.result,
    }  # fmt: skip


def session_metrics(
    events: Sequence[ExecutionEvent], clock: str | None
) -> tuple[tuple[str, ...], Row]:
    """The session's metrics (app.sessions.metrics) and their column names."""
    from app.sessions.metrics import METRIC_KEYS
    from app.sessions.metrics import session_metrics as measure

    return METRIC_KEYS, measure(events, clock=clock).row()


def _write_csv(path: Path, columns: Sequence[str], rows: Sequence[Row]) -> None:
    with path.open("w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=list(columns), extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
