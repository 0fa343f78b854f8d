"""An execution's events as they are recorded: numbered, timed, told to listeners.

Events come from the walk and, in their own threads, from sources that keep the
dialogue's turns (`note`) or the human's actions they observe (`observe_human`);
one lock keeps them in order. An event without times of its own is timed now on
the execution's clock.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterable
from dataclasses import replace

from app.execution.events import HUMAN, AnswerSource, DialogueKind, ExecutionEvent
from app.execution.evidence import Evidence
from app.execution.timing import Timeline

Listener = Callable[[ExecutionEvent], None]


class EventLog:
    """The events of one execution on `timeline`'s clock, told to `listeners` in order;
    `where` says the node an event without one is kept at (the node being run)."""

    def __init__(
        self, timeline: Timeline, listeners: Iterable[Listener], where: Callable[[], str]
    ) -> None:
        self.timeline = timeline
        self.listeners = list(listeners)
        self.events: list[ExecutionEvent] = []
        self.where = where
        self._lock = threading.RLock()

    def record(self, event: ExecutionEvent) -> ExecutionEvent:
        """`event`, numbered and timed (now, when it has no times of its own), kept and
        told to the listeners in order."""
        with self._lock:
            now = self.timeline.now()
            start = now if event.start is None else event.start
            end = now if event.end is None else event.end
            event = replace(event, seq=len(self.events), time=end, start=start, end=end)
            self.events.append(event)
            for listener in self.listeners:
                listener(event)
        return event

    def note(
        self,
        kind: DialogueKind,
        text: str,
        source: AnswerSource | None = None,
        evidence: Evidence | None = None,
        node_id: str | None = None,
    ) -> ExecutionEvent:
        """Keeps a turn of the dialogue at `node_id` (by default `where`)."""
        node = node_id if node_id is not None else self.where()
        event = ExecutionEvent(0, 0.0, node, None, kind, source=source, text=text)
        return self.record(replace(event, evidence=evidence))

    def observe_human(
        self,
        start: float,
        end: float,
        text: str,
        source: AnswerSource,
        evidence: Evidence | None = None,
        node_id: str | None = None,
    ) -> ExecutionEvent:
        """Keeps a human action that `source` observed (or an operator reported) from
        `start` to `end` (epoch seconds, on the wall clock), at `node_id` (by default
        `where`)."""
        node = node_id if node_id is not None else self.where()
        event = ExecutionEvent(
            0, end, node, None, HUMAN, source=source, text=text, start=start, end=end
        )
        return self.record(replace(event, evidence=evidence))
