"""A session on a timeline: one lane per agent and channel, as an SVG picture.

Pure (no viser): `lanes_svg(events, shown)` draws the robot's actions, the
human's own actions, the talk (the robot's and, heard by the voice, the
human's) and the sensing as bars from each event's `start` to its `end`. A
question or a sensing of the human is solid while the robot asks and hatched
from its `wait_start` on, while the robot waits. Each answered bar, and each
human action, carries its source's mark (lane_marks.py). A cursor stands at
the step `shown`, and a dashed line at the step `marked` (where two sessions
of one plan parted).

The picture shows a `window` of the session's time (all of it by default).
Every positioned element carries its times (`data-t0`/`data-t1`, or
`data-at` for a point), so the page can zoom and pan by placing them again
(review_timeline.py) exactly as `place` does here. A bar is drawn as long as
it lasted, at least `MIN_BAR` wide, under a transparent target at least
`MIN_TARGET` wide: the shortest action can be hovered and clicked at any
zoom. Each bar carries its event's index (`data-step`) and a tooltip
(`data-tip`). A session stored before events were timed has no start or end:
its steps are drawn one unit each, one after the other, and the picture says
"untimed".
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from html import escape
from typing import Literal

from app.dashboard.lane_marks import (
    CURSOR_COLOUR,
    DIVERGED_COLOUR,
    HUMAN_TIMES,
    SOURCE_MARKS,
    glyph,
)
from app.dashboard.tree_svg import FILLS, QUESTION_FILL
from app.execution.events import HUMAN, AnswerSource, ExecutionEvent

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
PLOT_PX = WIDTH_PX - LABEL_PX - 8
HEIGHT_PX = len(LANES) * LANE_PX + 30  # the lanes, the ticks, the axis words
MIN_BAR = 2.0  # the thinnest bar drawn
MIN_TARGET = 14.0  # the thinnest a bar is to the pointer
Window = tuple[float, float]  # the seconds (steps, untimed) shown: from, to


@dataclass(frozen=True)
class Bar:
    """One event on its lane, in seconds from the session's start; `wait` is when
    the robot began waiting within it (None: it acted throughout)."""

    lane: Lane
    start: float
    end: float
    event: ExecutionEvent
    index: int  # the event's place in the session
    wait: float | None = None


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


def duration(events: Sequence[ExecutionEvent]) -> float:
    """How long the session took (steps, untimed); 1 for an empty one."""
    return max((end for _, end in spans(events)), default=0.0) or 1.0


def bars(events: Sequence[ExecutionEvent]) -> tuple[list[Bar], bool]:
    """The events on lanes, and whether the session is timed."""
    timed = is_timed(events)
    out: list[Bar] = []
    t0 = min((e.start for e in events if e.start is not None), default=0.0) if timed else 0.0
    for index, event in enumerate(events):
        lane = LANE_OF.get(event.kind)
        if lane is None:
            continue
        if event.kind == HUMAN and event.source == "voice":
            lane = "talk"  # the human's speech, beside the robot's
        wait = None
        if timed and event.start is not None and event.end is not None:
            start, end = event.start - t0, event.end - t0
            if event.wait_start is not None and event.start < event.wait_start < event.end:
                wait = event.wait_start - t0
        else:
            start, end = float(index), float(index) + 0.9
        out.append(Bar(lane, start, max(end, start + 0.01), event, index, wait))
    return out, timed


def whole(events: Sequence[ExecutionEvent], until: float | None = None) -> Window:
    """The window showing all of the session (to `until` if that is later)."""
    return (0.0, max(duration(events), until or 0.0))


def place(window: Window, t0: float, t1: float, least: float = 0.0) -> tuple[float, float]:
    """Where a span of time is drawn in `window`: its x and width, at least `least`
    wide about its middle (the page's script places it the same way)."""
    k = PLOT_PX / (window[1] - window[0])
    x, w = LABEL_PX + (t0 - window[0]) * k, (t1 - t0) * k
    if w < least:
        x, w = x - (least - w) / 2, least
    return x, w


def _span(t0: float, t1: float, window: Window, least: float, rest: str) -> str:
    x, w = place(window, t0, t1, least)
    return (f'<rect data-t0="{t0:.3f}" data-t1="{t1:.3f}" data-min="{least:g}" x="{x:.1f}" '
            f'width="{w:.1f}" {rest}/>')  # fmt: skip


def tip(bar: Bar) -> str:
    """The tooltip of a bar: what happened, who answered or timed it, when."""
    e = bar.event
    what = f"{e.node} {e.action if e.action is not None else e.kind}"
    lines = [what + (f" → {e.outcome}" if e.outcome else "")]
    if e.text:
        lines.append(f"“{e.text}”" if e.kind in ("communication", HUMAN) else e.text)
    if e.source is not None:
        sure = f" ({e.confidence:.2f} sure)" if e.confidence is not None else ""
        if e.kind == HUMAN:
            lines.append("times: " + HUMAN_TIMES.get(e.source, SOURCE_MARKS[e.source].words))
        elif e.outcome:
            lines.append(f"answered by {e.source}{sure}")
    when = f"{bar.start:.1f}–{bar.end:.1f} s ({bar.end - bar.start:.1f} s)"
    if bar.wait is not None:
        when += f"; asking {bar.wait - bar.start:.1f} s, then waiting {bar.end - bar.wait:.1f} s"
    lines.append(when)
    return "\n".join(lines)


def _bar_svg(bar: Bar, window: Window, current: ExecutionEvent | None, name: str) -> str:
    y = LANES.index(bar.lane) * LANE_PX + 2
    event = bar.event
    fill = QUESTION_FILL if bar.lane == "talk" and event.outcome else LANE_FILL[bar.lane]
    stroke = (f'stroke="{CURSOR_COLOUR}" stroke-width="2"' if event is current
              else 'stroke="#777" stroke-width="0.8"')  # fmt: skip
    box = f'y="{y}" height="{LANE_PX - 4}"'
    # The target takes the pointer, the bar drawn over it (as its mark) does not.
    parts = [
        _span(bar.start, bar.end, window, MIN_TARGET, f'{box} fill="transparent" class="target"'),
        _span(bar.start, bar.end, window, MIN_BAR,
              f'{box} rx="2" fill="{fill}" {stroke} pointer-events="none"'),
    ]  # fmt: skip
    if bar.wait is not None:
        pattern = f"tandem-wait-{name}-{fill[1:]}"
        parts.append(_span(bar.wait, bar.end, window, 0.0,
                           f'{box} fill="url(#{pattern})" class="waiting" '
                           'pointer-events="none"'))  # fmt: skip
    if event.source is not None and _marked(event):
        middle = (bar.start + bar.end) / 2
        x, _ = place(window, middle, middle)
        mark = glyph(event.source, y + LANE_PX / 2 - 2)
        parts.append(f'<g data-at="{middle:.3f}" transform="translate({x:.1f},0)" '
                     f'pointer-events="none">{mark}</g>')  # fmt: skip
    return (f'<g class="bar" data-lane="{bar.lane}" data-node="{escape(event.node)}" '
            f'data-step="{bar.index}" data-tip="{escape(tip(bar))}">'
            f'{"".join(parts)}</g>')  # fmt: skip


def _marked(event: ExecutionEvent) -> bool:
    """Whether a bar carries its source's mark: an answer, or a human action (its
    source says where its times came from)."""
    return bool(event.outcome) or event.kind == HUMAN


def tick_step(span: float) -> float:
    """A round step giving about five ticks over `span` (the page's script agrees)."""
    raw = span / 5
    p = 10.0 ** math.floor(math.log10(raw))
    m = raw / p
    return (1 if m < 1.5 else 2 if m < 3.5 else 5 if m < 7.5 else 10) * p


def _ticks(window: Window) -> str:
    step = tick_step(window[1] - window[0])
    y = len(LANES) * LANE_PX + 2
    out = []
    t = math.ceil(window[0] / step - 1e-9) * step
    while t <= window[1] + 1e-9:
        x, _ = place(window, t, t)
        label = f"{t:.0f}" if step >= 1 else f"{t:.1f}"
        out.append(f'<line x1="{x:.1f}" x2="{x:.1f}" y1="{y}" y2="{y + 4}" stroke="#999"/>'
                   f'<text x="{x:.1f}" y="{y + 13}" font-size="8" text-anchor="middle" '
                   f'fill="#555">{label}</text>')  # fmt: skip
        t += step
    return f'<g class="ticks">{"".join(out)}</g>'


def axis_words(window: Window, total: float, timed: bool) -> str:
    """The time shown, in words (the page's script says it the same way)."""
    if not timed:
        return "untimed: one step each"
    if window[0] <= 1e-6 and window[1] >= total - 1e-6:
        return f"0 s … {window[1]:.1f} s"
    return f"{window[0]:.1f} s … {window[1]:.1f} s of {total:.1f} s"


def _defs(name: str) -> str:
    """The hatching of a wait, one per bar colour; the plot's clip."""
    patterns = "".join(
        f'<pattern id="tandem-wait-{name}-{fill[1:]}" width="5" height="5" '
        'patternUnits="userSpaceOnUse" patternTransform="rotate(45)">'
        f'<rect width="5" height="5" fill="{fill}"/>'
        '<line x1="0" y1="0" x2="0" y2="5" stroke="#ffffff" stroke-width="2.4"/></pattern>'
        for fill in {*LANE_FILL.values(), QUESTION_FILL}
    )
    clip = (f'<clipPath id="tandem-plot-{name}"><rect x="{LABEL_PX - 1}" y="0" '
            f'width="{PLOT_PX + 2}" height="{HEIGHT_PX}"/></clipPath>')  # fmt: skip
    return f"<defs>{patterns}{clip}</defs>"


def lanes_svg(
    events: Sequence[ExecutionEvent],
    shown: int | None = None,
    marked: int | None = None,
    until: float | None = None,
    *,
    window: Window | None = None,
    name: str = "first",
) -> str:
    """The session's lanes, picture `name` of the page; `shown` (an index into
    `events`) gets the cursor at its end, `marked` (another index) a dashed line at
    its start. It shows `window`, by default the whole session (to `until`
    seconds if that is later)."""
    placed, timed = bars(events)
    if not placed:
        return ""
    total = max(duration(events), until or 0.0)
    view = window or (0.0, total)
    current = events[shown] if shown is not None and 0 <= shown < len(events) else None
    names = "".join(
        f'<text x="2" y="{i * LANE_PX + 14}" font-size="10">{lane}</text>'
        for i, lane in enumerate(LANES)
    )
    drawn = "".join(_bar_svg(b, view, current, name) for b in placed)
    times = spans(events)
    lines = ""
    if current is not None and shown is not None:
        # At the shown step's end: a step off the lanes (the goal, a turn of the
        # dialogue) still has its time.
        lines += _vertical(times[shown][1], view,
                           f'stroke="{CURSOR_COLOUR}" stroke-width="2" class="cursor"')  # fmt: skip
    if marked is not None and 0 <= marked < len(events):
        lines += _vertical(times[marked][0], view,
                           f'stroke="{DIVERGED_COLOUR}" stroke-width="2" '
                           'stroke-dasharray="4 2" class="diverged"')  # fmt: skip
    axis = (f'<text class="axis" x="{LABEL_PX}" y="{HEIGHT_PX - 2}" font-size="9" fill="#555">'
            f"{axis_words(view, total, timed)}</text>")  # fmt: skip
    return (f'<svg class="tandem-lanes" data-lanes="{name}" data-a="{view[0]:.4f}" '
            f'data-b="{view[1]:.4f}" data-total="{total:.4f}" data-timed="{int(timed)}" '
            f'data-left="{LABEL_PX}" data-plot="{PLOT_PX}" width="{WIDTH_PX:.0f}" '
            f'height="{HEIGHT_PX:.0f}" viewBox="0 0 {WIDTH_PX:.0f} {HEIGHT_PX:.0f}" '
            f'font-family="sans-serif">{_defs(name)}{names}'
            f'<g clip-path="url(#tandem-plot-{name})">{drawn}{lines}</g>{_ticks(view)}'
            f"{axis}</svg>")  # fmt: skip


def _vertical(t: float, window: Window, style: str) -> str:
    """A line across every lane at time `t`."""
    x, _ = place(window, t, t)
    return (f'<line data-at="{t:.3f}" x1="{x:.1f}" x2="{x:.1f}" y1="0" '
            f'y2="{len(LANES) * LANE_PX + 2}" {style}/>')  # fmt: skip


def sources(events: Sequence[ExecutionEvent]) -> set[AnswerSource]:
    """The sources whose marks the lanes of `events` carry."""
    placed, _ = bars(events)
    return {b.event.source for b in placed if b.event.source is not None and _marked(b.event)}
