"""A session on a timeline: one lane per agent and channel, as an SVG picture.

Pure (no viser): `lanes_svg(events, shown)` draws the robot's actions, the
human's own actions, the talk and the sensing as bars from each event's
`start` to its `end`, each answered bar marked with who answered (the
letter of its source, the whole word in its tooltip), a cursor at the
step `shown`, and optionally a dashed line at the step `marked` (where two
sessions of one plan diverged). Each bar carries its event's index
(`data-step`), so a click on it can move a review there. The picture scales
to its element's width (a `viewBox`). A session stored before events were timed has no start or end:
its steps are drawn one unit each, one after the other, and the picture says
"untimed".
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from html import escape
from typing import Literal

from app.dashboard.tree_svg import CURRENT, FILLS, QUESTION_FILL
from app.execution.events import ExecutionEvent

Lane = Literal["robot", "human", "talk", "sensing"]
LANES: tuple[Lane, ...] = ("robot", "human", "talk", "sensing")
LANE_OF: dict[str, Lane] = {
    "actuation": "robot", "human": "human", "communication": "talk", "sensing": "sensing"
}
LANE_FILL = {
    "robot": FILLS["actuation"],
    "human": "#f4a582",
    "talk": FILLS["communication"],
    "sensing": FILLS["sensing"],
}
WIDTH_PX = 460.0
LANE_PX = 18.0
LABEL_PX = 52.0  # the lanes' names, left of the bars
DIVERGED = "#c0392b"  # the line where two sessions part


@dataclass(frozen=True)
class Bar:
    """One event on its lane, in seconds from the session's start."""

    lane: Lane
    start: float
    end: float
    event: ExecutionEvent
    index: int  # the event's place in the session


def is_timed(events: Sequence[ExecutionEvent]) -> bool:
    """Whether every event has a start and an end (a session stored since timing)."""
    return bool(events) and all(e.start is not None and e.end is not None for e in events)


def spans(events: Sequence[ExecutionEvent]) -> list[tuple[float, float]]:
    """When each event began and ended, in seconds from the session's first start;
    in an untimed session, one unit per event, one after the other."""
    if not is_timed(events):
        return [(float(k), float(k) + 0.9) for k in range(len(events))]
    t0 = min(e.start for e in events if e.start is not None)
    return [
        (e.start - t0, max(e.end, e.start) - t0)
        for e in events
        if e.start is not None and e.end is not None
    ]


def bars(events: Sequence[ExecutionEvent]) -> tuple[list[Bar], bool]:
    """The events on lanes, and whether the session is timed."""
    timed = is_timed(events)
    out: list[Bar] = []
    t0 = min((e.start for e in events if e.start is not None), default=0.0) if timed else 0.0
    for index, event in enumerate(events):
        lane = LANE_OF.get(event.kind)
        if lane is None:
            continue
        if event.kind == "human" and event.source == "voice":
            lane = "talk"  # the human's speech, beside the robot's
        if timed and event.start is not None and event.end is not None:
            start, end = event.start - t0, event.end - t0
        else:
            start, end = float(index), float(index) + 0.9
        out.append(Bar(lane, start, max(end, start + 0.01), event, index))
    return out, timed


def _bar_svg(bar: Bar, x0: float, scale: float, shown: ExecutionEvent | None) -> str:
    y = LANES.index(bar.lane) * LANE_PX + 2
    x, w = x0 + bar.start * scale, max(2.0, (bar.end - bar.start) * scale)
    event = bar.event
    fill = QUESTION_FILL if bar.lane == "talk" and event.outcome else LANE_FILL[bar.lane]
    stroke = f'stroke="{CURRENT}" stroke-width="2"' if event is shown else 'stroke="#777"'
    who = f", answered by {event.source}" if event.outcome and event.source else ""
    tip = f"{event.node} {event.action or event.kind}{who} ({bar.start:.1f}-{bar.end:.1f} s)"
    mark = ""
    if event.outcome and event.source:
        mark = (f'<text x="{x + w / 2:.1f}" y="{y + 11}" font-size="9" text-anchor="middle" '
                'pointer-events="none">'  # a click on the letter is its bar's
                f"{escape(event.source[0].upper())}</text>")  # fmt: skip
    return (f'<g data-node="{escape(event.node)}" data-step="{bar.index}">'
            f"<title>{escape(tip)}</title>"
            f'<rect x="{x:.1f}" y="{y}" width="{w:.1f}" height="{LANE_PX - 4}" rx="2" '
            f'fill="{fill}" {stroke}/>{mark}</g>')  # fmt: skip


def lanes_svg(
    events: Sequence[ExecutionEvent],
    shown: int | None = None,
    marked: int | None = None,
    until: float | None = None,
) -> str:
    """The session's lanes; `shown` (an index into `events`) gets the cursor at its
    end, `marked` (another index) a dashed line at its start. The axis runs to the
    session's end, or to `until` seconds if that is later (two sessions drawn on
    one scale)."""
    placed, timed = bars(events)
    if not placed:
        return ""
    span = max(max(b.end for b in placed), until or 0.0) or 1.0
    scale = (WIDTH_PX - LABEL_PX - 8) / span
    current = events[shown] if shown is not None and 0 <= shown < len(events) else None
    names = "".join(
        f'<text x="2" y="{i * LANE_PX + 14}" font-size="10">{lane}</text>'
        for i, lane in enumerate(LANES)
    )
    drawn = "".join(_bar_svg(b, LABEL_PX, scale, current) for b in placed)
    cursor = ""
    times = spans(events)
    if current is not None and shown is not None:
        # At the shown step's end: a step off the lanes (the goal, a turn of the
        # dialogue) still has its time.
        x = LABEL_PX + min(span, times[shown][1]) * scale
        cursor = _vertical(x, f'stroke="{CURRENT}" stroke-width="2" class="cursor"')
    if marked is not None and 0 <= marked < len(events):
        x = LABEL_PX + min(span, times[marked][0]) * scale
        cursor += _vertical(x, f'stroke="{DIVERGED}" stroke-width="2" stroke-dasharray="4 2" '
                               'class="diverged"')  # fmt: skip
    height = len(LANES) * LANE_PX + 16
    axis = (f'<text x="{LABEL_PX}" y="{height - 2}" font-size="9" fill="#555">'
            + (f"0 s … {span:.1f} s" if timed else "untimed: one step each") + "</text>")
    return (f'<svg class="tandem-lanes" width="{WIDTH_PX:.0f}" height="{height:.0f}" '
            f'viewBox="0 0 {WIDTH_PX:.0f} {height:.0f}" '
            f'font-family="sans-serif">{names}{drawn}{cursor}{axis}</svg>')  # fmt: skip


def _vertical(x: float, style: str) -> str:
    """A line across every lane at `x`."""
    return f'<line x1="{x:.1f}" x2="{x:.1f}" y1="0" y2="{len(LANES) * LANE_PX + 2}" {style}/>'
