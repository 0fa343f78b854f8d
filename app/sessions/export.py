"""A session as the export writes it (`tandem sessions export`, the review's download).

`tandem-session/2`: the session's record, its events (the action as text, the
evidence in its versioned JSON form with whether a picture is stored) and its
plan. `exported_event` reads an event back. `events_csv` writes the events as a
table, one row per event (`CSV_COLUMNS`); the MCAP export is in `mcap_export`.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Iterable, Mapping
from typing import Any

from app.execution.events import ExecutionEvent
from app.execution.evidence import Evidence
from planner.vocabulary import parse_action

# /2: events' evidence is the versioned JSON of app.execution.evidence (with "jpeg":
# whether a picture is stored); /1 had the flat mapping under "detail".
EXPORT_FORMAT = "tandem-session/2"
# The CSV export's columns: the event's own fields, its time in epoch seconds.
CSV_COLUMNS = (
    "seq", "time", "start", "end", "wait_start", "node", "kind", "action", "outcome",
    "source", "confidence", "text",
)  # fmt: skip


def event_row(event: ExecutionEvent) -> dict[str, Any]:
    """An event's own fields as stored and exported: the action as its text."""
    return {
        "seq": event.seq,
        "time": event.time,
        "node": event.node,
        "action": None if event.action is None else str(event.action),
        "kind": event.kind,
        "outcome": event.outcome,
        "source": event.source,
        "confidence": event.confidence,
        "text": event.text,
    }


def export_event(event: ExecutionEvent) -> dict[str, Any]:
    """An event as the export writes it: its row, and the evidence in its versioned JSON
    form with whether a picture is stored."""
    evidence = event.evidence
    return {
        **event_row(event),
        "start": event.start,  # when the step began and ended (None: untimed)
        "end": event.end,
        "wait_start": event.wait_start,  # when the robot began waiting for the human
        "evidence": (
            None if evidence is None else {**evidence.to_json(), "jpeg": evidence.jpeg is not None}
        ),
    }


def row_event(row: Mapping[str, Any], evidence: Evidence | None = None) -> ExecutionEvent:
    """The event of a row with `event_row`'s fields and its times (`start`, `end`,
    `wait_start`; absent: untimed), as exported and as the store reads it back."""
    return ExecutionEvent(
        seq=row["seq"],
        time=row["time"],
        node=row["node"],
        action=None if row["action"] is None else parse_action(row["action"]),
        kind=row["kind"],
        outcome=row["outcome"],
        source=row["source"],
        confidence=row["confidence"],
        text=row["text"],
        evidence=evidence,
        start=row.get("start"),
        end=row.get("end"),
        wait_start=row.get("wait_start"),
    )


def exported_event(row: Mapping[str, Any]) -> ExecutionEvent:
    """The event of an exported row (its evidence without the picture)."""
    evidence = row.get("evidence")
    return row_event(row, None if evidence is None else Evidence.from_json(evidence))


def events_csv(events: Iterable[ExecutionEvent]) -> str:
    """The events as CSV with a header row: one row per event, `CSV_COLUMNS`; an empty
    cell for a field with no value, times with all their digits (`repr` of the float)."""
    out = io.StringIO()
    writer = csv.DictWriter(out, CSV_COLUMNS, lineterminator="\n")
    writer.writeheader()
    for event in events:
        row = {
            **event_row(event), "start": event.start, "end": event.end,
            "wait_start": event.wait_start,
        }  # fmt: skip
        writer.writerow({column: _cell(row[column]) for column in CSV_COLUMNS})
    return out.getvalue()


def _cell(value: object) -> object:
    return repr(value) if isinstance(value, float) else value
