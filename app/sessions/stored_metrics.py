"""The measures of many stored sessions at once, read straight from the store's rows.

`session_metrics` over `SessionStore.events` builds every event whole: its
action parsed, its evidence read from JSON. The measures need a few columns
(`app.sessions.metrics.EventTimes`), so a study's 10,000 sessions are read
here in one query over the events of all of them, the action's name taken from
its stored text, and the evidence's JSON read only where the truth matters (a
camera's or a voice's answer). The numbers are those of `session_metrics`.
"""

from __future__ import annotations

import json
from collections.abc import Iterator, Sequence

from app.execution.evidence import Evidence
from app.sessions.metrics import EventTimes, SessionMetrics, measure
from app.sessions.store import EVENT_TIMES, SessionRecord, SessionStore

# The sources whose answers are judged against the truth (`metrics._agreement`).
JUDGED_SOURCES = ("camera", "voice")


def stored_metrics(store: SessionStore, sessions: Sequence[SessionRecord]) -> list[SessionMetrics]:
    """The measures of each of `sessions` (of `store`), in their order."""
    events: dict[int, list[EventTimes]] = {s.id: [] for s in sessions}
    for session_id, row in _rows(store, list(events)):
        events[session_id].append(row)
    return [measure(events[s.id], s.clock) for s in sessions]


def _rows(store: SessionStore, ids: list[int]) -> Iterator[tuple[int, EventTimes]]:
    """Each event of the sessions `ids` with what the measures read of it, in order."""
    columns = {row[1] for row in store.db.execute("pragma table_info(events)")}
    # A store opened read-only may be older than the events' times: those read as null.
    times = ", ".join(f"e.{c}" if c in columns else "null" for c in EVENT_TIMES)
    judged = ", ".join(f"'{s}'" for s in JUDGED_SOURCES)
    sql = (
        f"select e.session_id, e.kind, e.action, e.node, e.outcome, e.source, {times}, "
        f"case when e.source in ({judged}) then v.detail end from events e "
        "left join evidence v on v.session_id = e.session_id and v.seq = e.seq "
        "where e.session_id in (select value from json_each(?)) order by e.session_id, e.seq"
    )
    cursor = store.db.execute(sql, [json.dumps(ids)])
    for session_id, kind, action, node, outcome, source, start, end, wait, detail in cursor:
        name = None if action is None else action.split("(", 1)[0]
        truth = None if detail is None else _truth_label(detail)
        yield session_id, EventTimes(kind, name, node, outcome, source, start, end, wait, truth)


def _truth_label(detail: str) -> str | None:
    """The truth's label in a stored evidence's JSON, read as `Evidence` reads it."""
    truth = Evidence.from_json(json.loads(detail or "{}")).truth
    return None if truth is None else truth.label
