"""Two sessions of one plan side by side: where their paths parted.

`divergence(first, second)` (pure) finds the first step along the plan (not
the human's own actions nor the dialogue's turns) whose node or outcome
differs; `divergence_words` says it ("Diverged at step 10: `n22`
sense(humanHolding): **yes** (#1) vs **no** (#2)"), its step counted as the
first session's timeline counts (every event). `comparable` lists the other
sessions of the same plan: the same stored plan, or a plan of the same
scenario file (a scenario planned again gives the same nodes; only its
planning times differ, and so its hash).

`CompareView` is the review's "Compare with" dropdown and the sentence; the
second session's lanes (`below`) are drawn under the first's, in the same
element, each on its own time scale (a long session would squash a short one
on a shared scale), each zoomed and panned on its own, the divergence (when
the paths differ) marked on both by a dashed line.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import viser

from app.dashboard.review_timeline import lanes_html
from app.dashboard.timeline_svg import Window, duration, is_timed
from app.dashboard.widgets import show
from app.execution.events import ExecutionEvent, is_step
from app.sessions.database import StoreError
from app.sessions.store import SessionRecord, SessionStore, UnknownSession

NO_COMPARISON = "(none)"
OFFERED = 50  # sessions offered, newest first: the scenario filter reaches the others


@dataclass(frozen=True)
class Divergence:
    """Where two sessions' paths parted: the step (1-based, along the plan) and
    each session's event there (None: that session had ended)."""

    step: int
    first: int | None  # index into the first session's events
    second: int | None  # index into the second's


def _steps(events: Sequence[ExecutionEvent]) -> list[int]:
    return [k for k, e in enumerate(events) if is_step(e)]


def divergence(
    first: Sequence[ExecutionEvent], second: Sequence[ExecutionEvent]
) -> Divergence | None:
    """The first plan step whose node or outcome differs; None when both went the
    same way to the same end."""
    a, b = _steps(first), _steps(second)
    for n, (i, j) in enumerate(zip(a, b, strict=False)):
        if (first[i].node, first[i].outcome) != (second[j].node, second[j].outcome):
            return Divergence(n + 1, i, j)
    if len(a) == len(b):
        return None
    n = min(len(a), len(b))
    return Divergence(n + 1, a[n] if n < len(a) else None, b[n] if n < len(b) else None)


def _step_words(event: ExecutionEvent) -> str:
    what = f"{event.action}" if event.action is not None else event.kind
    return f"`{event.node}` {what}" + (f": **{event.outcome}**" if event.outcome else "")


def divergence_words(
    first: Sequence[ExecutionEvent],
    second: Sequence[ExecutionEvent],
    names: tuple[str, str],
) -> str:
    """One line saying where the sessions `names` ("#1", "#2") parted, in the first
    session's timeline steps."""
    found = divergence(first, second)
    if found is None:
        return f"{names[0]} and {names[1]} took the same path."
    i, j = found.first, found.second
    at = f"step {i + 1}" if i is not None else f"step {len(first) + 1} (after {names[0]} ended)"
    if i is not None and j is not None and j != i:
        at += f" (step {j + 1} of {names[1]})"
    if i is None or j is None:
        went = second[j] if j is not None else first[i] if i is not None else None
        ended = names[0] if i is None else names[1]
        other = names[1] if i is None else names[0]
        more = f"{other} went on: {_step_words(went)}" if went is not None else ""
        return f"Diverged at {at}: {ended} had ended; {more}."
    a, b = first[i], second[j]
    if a.node == b.node:
        what = f"{a.action}" if a.action is not None else a.kind
        return (f"Diverged at {at}: `{a.node}` {what}: **{a.outcome}** ({names[0]}) "
                f"vs **{b.outcome}** ({names[1]}).")  # fmt: skip
    return f"Diverged at {at}: {_step_words(a)} ({names[0]}) vs {_step_words(b)} ({names[1]})."


def comparable(sessions: Sequence[SessionRecord], session: SessionRecord) -> list[SessionRecord]:
    """The other sessions of `session`'s plan, newest first: the same stored plan, or
    the same scenario file planned again."""
    return [
        s
        for s in reversed(sessions)
        if s.id != session.id
        and (s.plan_hash == session.plan_hash
             or (session.scenario_sha256 is not None
                 and s.scenario_sha256 == session.scenario_sha256))  # fmt: skip
    ][:OFFERED]


def compare_label(s: SessionRecord) -> str:
    note = f" ({s.note})" if s.note else ""
    return f"#{s.id} {s.result or 'running'}{note}"[:60]


class CompareView:
    """The "Compare with" dropdown, where the two sessions parted, and the second
    session's lanes (`below`); `redraw()` draws the first session's picture again
    with them (it marks the divergence too)."""

    def __init__(self, gui: viser.GuiApi, store: SessionStore, redraw: Callable[[], None]) -> None:
        self.store = store
        self.redraw = redraw
        self.first: SessionRecord | None = None
        self.first_events: Sequence[ExecutionEvent] = ()
        self.other: SessionRecord | None = None
        self.marked: int | None = None  # the divergence, in the first session
        self.other_events: Sequence[ExecutionEvent] = ()
        self.other_marked: int | None = None  # the divergence, in the second
        self.caption = ""
        self._ids: dict[str, int] = {}
        self.pick: viser.GuiDropdownHandle[str] = gui.add_dropdown("Compare with", [NO_COMPARISON])
        self.pick.on_update(lambda e: self._picked(e.client is not None))
        self.words = gui.add_markdown("")

    def offer(self, session: SessionRecord, events: Sequence[ExecutionEvent]) -> None:
        """The first session opened: the sessions it can be compared with."""
        self.first, self.first_events = session, events
        try:
            others = comparable(self.store.list_sessions(scenario=session.scenario), session)
        except StoreError as err:
            others = []
            self.words.content = f"**Error:** {err}"
        self._ids = {compare_label(s): s.id for s in others}
        self.pick.options = [NO_COMPARISON, *self._ids]
        show(self.pick, NO_COMPARISON)
        self.clear()

    def label_of(self, session_id: int) -> str | None:
        """The label under which the picker lists `session_id` (None: not listed)."""
        return next((label for label, i in self._ids.items() if i == session_id), None)

    def clear(self) -> None:
        self.other, self.marked, self.other_marked = None, None, None
        self.other_events, self.caption = (), ""
        self.words.content = "" if self._ids else "*No other session of this plan.*"

    def below(self, window: Window | None = None) -> str:
        """The second session's lanes, showing `window` of its time, as HTML."""
        if self.other is None:
            return ""
        return self.caption + lanes_html(self.other_events, None, self.other_marked,
                                         clickable=False, window=window, name="second")  # fmt: skip

    def total(self) -> float:
        """How long the second session took (its lanes' whole time)."""
        return duration(self.other_events)

    def _picked(self, by_user: bool) -> None:
        # Only a choice in the page compares: `offer` resets the value itself.
        if by_user:
            self.compare(str(self.pick.value))
            self.redraw()

    def compare(self, label: str) -> None:
        session_id = self._ids.get(label)
        if session_id is None or self.first is None:
            self.clear()
            return
        try:
            other, events = self.store.get(session_id), self.store.events(session_id)
        except (UnknownSession, StoreError) as err:
            self.clear()
            self.words.content = f"**Error:** {err}"
            return
        first = self.first_events
        found = divergence(first, events)
        self.other, self.other_events = other, events
        self.marked = found.first if found is not None else None
        self.other_marked = found.second if found is not None else None
        names = (f"#{self.first.id}", f"#{other.id}")
        self.words.content = divergence_words(first, events, names)
        # Each on its own scale: say how long each took.
        took = f"{duration(events):.1f} s" if is_timed(events) else "untimed"
        parted = f", where it parted from {names[0]} dashed" if found is not None else (
            f", the same path as {names[0]}")  # fmt: skip
        self.caption = (f'<div style="font-size:12px;margin-top:4px">{names[1]} ({took}, '
                        f"its own time scale){parted}:</div>")  # fmt: skip
