"""The review's timeline in words and pictures: the clock, the transcript, the lanes.

Pure (no viser). `clock_words` says where the shown step stands in the
session's time ("t = 12.4 s of 95.0 s", or "untimed" for a session stored
before events were timed); `transcript` is what was said, done and answered
up to that time, newest last, in the log's sentences (log_lines.py);
`lanes_html` is the lanes picture (timeline_svg.py) made clickable.

viser sends no clicks from HTML, so, as the tree panel does (tree_view.py),
a click on a bar writes "lanes:step:<index>" into a text field of the panel
the page never shows, and the panel moves the timeline there.
"""

from __future__ import annotations

from collections.abc import Sequence

from app.dashboard.log_lines import sentence
from app.dashboard.timeline_svg import is_timed, lanes_svg, spans
from app.execution.events import ExecutionEvent
from app.sessions.summary import summary

BRIDGE = "lanes:"  # what the hidden field's value starts with
TRANSCRIPT_LINES = 8  # the newest lines shown: a session has hundreds

# The click handler, inline (the page runs attributes, not <script>): the bar's
# event index into the hidden field, as typing would.
_ON_CLICK = (
    "var g=event.target.closest('[data-step]');"
    "var i=document.querySelector('input[value^=\\'lanes:\\']');if(!g||!i)return;"
    "Object.getOwnPropertyDescriptor(HTMLInputElement.prototype,'value').set"
    ".call(i,'lanes:step:'+g.dataset.step+':'+Date.now());"
    "i.dispatchEvent(new Event('input',{bubbles:true}));"
)
HIDE_BRIDGE = (
    '<style>.mantine-Flex-root:has(> div > .mantine-TextInput-root input[value^="lanes:"])'
    "{display:none}</style>"
)
# The picture as wide as the tab, its height following (the SVG has a viewBox).
_SVG_STYLE = 'style="width:100%;height:auto;cursor:pointer"'


def clock_words(events: Sequence[ExecutionEvent], shown: int) -> str:
    """Where step `shown` ends in the session's time, and how long the session took."""
    if not events:
        return ""
    if not is_timed(events):
        return "untimed"
    times = spans(events)
    total = max(end for _, end in times)
    return f"t = {times[shown][1]:.1f} s of {total:.1f} s"


def transcript(
    events: Sequence[ExecutionEvent], shown: int, lines: int = TRANSCRIPT_LINES
) -> list[str]:
    """The newest `lines` sentences up to step `shown`: in a timed session every event
    ended by the time the shown one ends (the human acts beside the robot, so an
    event recorded later may have ended sooner), in their order of ending; untimed,
    the events up to the shown one."""
    if not events:
        return []
    if is_timed(events):
        ends = [end for _, end in spans(events)]
        ended = [k for k, end in enumerate(ends) if end <= ends[shown] or k == shown]
        ended.sort(key=lambda k: (ends[k], k))
    else:
        ended = list(range(shown + 1))
    return [_line(events[k]) for k in ended[-lines:]]


def _line(event: ExecutionEvent) -> str:
    heard = summary(event)
    return sentence(event) + (f" *({heard})*" if heard else "")


def lanes_html(
    events: Sequence[ExecutionEvent],
    shown: int | None,
    marked: int | None = None,
    *,
    until: float | None = None,
    clickable: bool = True,
) -> str:
    """The lanes picture for the page, at the tab's width (`lanes_svg` says what
    `marked` and `until` do); a click on a bar (if `clickable`) reports its step
    through the hidden field."""
    svg = lanes_svg(events, shown, marked, until)
    if not svg:
        return "<p><i>No step of this session is on a lane.</i></p>"
    handlers = f' onclick="{_ON_CLICK}"' if clickable else ""
    return svg.replace("<svg ", f"<svg {_SVG_STYLE}{handlers} ", 1)


def bridged_step(value: str) -> int | None:
    """The step a click on the lanes reported, or None for anything else."""
    parts = value.removeprefix(BRIDGE).split(":")
    if len(parts) < 2 or parts[0] != "step" or not parts[1].isdigit():
        return None
    return int(parts[1])
