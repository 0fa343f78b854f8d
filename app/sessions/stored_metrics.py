"""The measures of many stored sessions at once, read straight from the store's rows.

`session_metrics` over `SessionStore.events` builds every event whole: its
action parsed, its evidence read from JSON. The measures need a few columns
(`app.sessions.metrics.EventTimes`), so a study's 10,000 sessions are read
here in one query over the events of all of them: the action's name is cut from
its stored text by SQLite, and the truth's label (the only part of the evidence
the measures read, for a camera's or a voice's answer) taken from the evidence's
JSON by SQLite too; evidence stored in the first JSON form is read as `Evidence`
reads it. The numbers are those of `session_metrics`.
"""

from __future__ import annotations

import json
from collections.abc import Sequence

from app.execution.evidence import EVIDENCE_VERSION, Evidence
from app.sessions.metrics import EventTimes, SessionMetrics, measure
from app.sessions.store import EVENT_TIMES, SessionRecord, SessionStore

# The sources whose answers are judged against the truth (`metrics._agreement`).
JUDGED_SOURCES = ("camera", "voice")


def stored_metrics(store: SessionStore, sessions: Sequence[SessionRecord]) -> list[SessionMetrics]:
    """The measures of each of `sessions` (of `store`), in their order."""
    events = _events(store, [s.id for s in sessions])
    return [measure(events.get(s.id, ()), s.clock) for s in sessions]


def _query(store: SessionStore) -> str:
    """The events of the sessions whose ids are a JSON list, in order: the
    `EventTimes` columns with the truth's label, the evidence of the first JSON form
    (to read in Python) and the session's id last."""
    columns = {row[1] for row in store.db.execute("pragma table_info(events)")}
    # A store opened read-only may be older than the events' times: those read as null.
    times = ", ".join(f"e.{c}" if c in columns else "null" for c in EVENT_TIMES)
    judged = ", ".join(f"'{s}'" for s in JUDGED_SOURCES)
    current = f"json_extract(v.detail, '$.version') is {EVIDENCE_VERSION}"  # null: first form
    return (
        "select e.kind, substr(e.action, 1, instr(e.action || '(', '(') - 1), e.node, "
        f"e.outcome, e.source, {times}, "
        f"case when e.source in ({judged}) and {current} "
        "then json_extract(v.detail, '$.truth.label') end, "
        f"case when e.source in ({judged}) and not {current} then v.detail end, "
        "e.session_id from events e left join evidence v "
        "on v.session_id = e.session_id and v.seq = e.seq "
        "where e.session_id in (select value from json_each(?)) order by e.session_id, e.seq"
    )


def _events(store: SessionStore, ids: list[int]) -> dict[int, list[EventTimes]]:
    """What the measures read of each event of the sessions `ids`, in order."""
    events: dict[int, list[EventTimes]] = {}
    cursor = store.db.execute(_query(store), [json.dumps(ids)])
    for kind, action, node, outcome, source, start, end, wait, truth, old, session_id in cursor:
        if old is not None:
            truth = _truth_label(old)
        row = EventTimes(kind, action, node, outcome, source, start, end, wait, truth)
        events.setdefault(session_id, []).append(row)
    return events


def _truth_label(detail: str) -> str | None:
    """The truth's label in a stored evidence's JSON, read as `Evidence` reads it."""
    truth = Evidence.from_json(json.loads(detail or "{}")).truth
    return None if truth is None else truth.label
