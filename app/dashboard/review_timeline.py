"""The review's timeline in words and pictures: the clock, the transcript, the lanes.

Pure (no viser). `clock_words` says where the shown step stands in the
session's time ("t = 12.4 s of 95.0 s", or "untimed" for a session stored
before events were timed); `transcript` is what was said, done and answered
up to that time, newest last, in the log's sentences (log_lines.py);
`lanes_html` is the lanes picture (timeline_svg.py) made to zoom, pan,
hover and click in the page.

viser sends no clicks from HTML, so, as the tree panel does (tree_view.py),
the picture's handlers write what happened into a text field of the panel
the page never shows: "lanes:step:<index>:<picture>:<from>,<to>:<stamp>" for
a click on a bar, "lanes:view:-:<picture>:<from>,<to>:<stamp>" after a zoom
or a pan (`bridged` reads both); the panel moves the timeline there and keeps
each picture's time shown (`zoomed`, `following`) for its next drawing.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

from app.dashboard.log_lines import sentence
from app.dashboard.timeline_svg import (
    LANE_PX,
    LANES,
    Window,
    is_timed,
    lanes_svg,
    spans,
)
from app.execution.events import ExecutionEvent
from app.sessions.summary import summary

BRIDGE = "lanes:"  # what the hidden field's value starts with
TRANSCRIPT_LINES = 8  # the newest lines shown: a session has hundreds
Picture = Literal["first", "second"]  # the session reviewed; the one compared with it
PICTURES: tuple[Picture, ...] = ("first", "second")
ZOOM_STEP = 0.5  # "In" halves the time shown, "Out" doubles it

# The pictures' handlers, defined once per page (an image that fails to load runs
# them; the page runs attributes, not <script>). Wheel zooms about the pointer and
# dragging pans, by placing every element again from its times (`data-t0`/`data-t1`,
# `data-at`) as timeline_svg.place does; the time shown goes to the server a
# moment later, and with every click, so the next picture keeps it. A click on a
# bar reports its step; hovering one shows its `data-tip`.
_TICK_Y = len(LANES) * LANE_PX + 2
_SCRIPT = (
    "if(!window.tandemLanes){window.tandemLanes={"
    "send:function(s,what,arg){var i=document.querySelector('input[value^=\\'lanes:\\']');"
    "if(!i)return;var d=s.dataset;"
    "Object.getOwnPropertyDescriptor(HTMLInputElement.prototype,'value').set.call(i,"
    "'lanes:'+what+':'+arg+':'+d.lanes+':'+(+d.a).toFixed(3)+','+(+d.b).toFixed(3)+':'"
    "+Date.now());i.dispatchEvent(new Event('input',{bubbles:true}));},"
    "report:function(s){clearTimeout(this.t);var me=this;"
    "this.t=setTimeout(function(){me.send(s,'view','-');},250);},"
    "x:function(s,t){var d=s.dataset;return +d.left+(t-d.a)*d.plot/(d.b-d.a);},"
    "lay:function(s){var me=this,d=s.dataset,k=d.plot/(d.b-d.a),a=+d.a,b=+d.b;"
    "s.querySelectorAll('[data-t0]').forEach(function(r){var q=r.dataset,x=me.x(s,+q.t0),"
    "w=(q.t1-q.t0)*k,m=+q.min;if(w<m){x-=(m-w)/2;w=m;}"
    "r.setAttribute('x',x.toFixed(1));r.setAttribute('width',w.toFixed(1));});"
    "s.querySelectorAll('[data-at]').forEach(function(e){var x=me.x(s,+e.dataset.at).toFixed(1);"
    "if(e.tagName=='line'){e.setAttribute('x1',x);e.setAttribute('x2',x);}"
    "else{e.setAttribute('transform','translate('+x+',0)');}});"
    "var raw=(b-a)/5,p=Math.pow(10,Math.floor(Math.log10(raw))),m=raw/p,"
    "st=(m<1.5?1:m<3.5?2:m<7.5?5:10)*p,y=" + f"{_TICK_Y:g}" + ",h='';"
    "for(var t=Math.ceil(a/st-1e-9)*st;t<=b+1e-9;t+=st){var x=me.x(s,t).toFixed(1);"
    "h+='<line x1=\\''+x+'\\' x2=\\''+x+'\\' y1=\\''+y+'\\' y2=\\''+(y+4)+'\\' "
    "stroke=\\'#999\\'/><text x=\\''+x+'\\' y=\\''+(y+13)+'\\' font-size=\\'8\\' "
    "text-anchor=\\'middle\\' fill=\\'#555\\'>'+(st>=1?t.toFixed(0):t.toFixed(1))"
    "+'</text>';}s.querySelector('g.ticks').innerHTML=h;"
    "if(d.timed=='1'){var T=+d.total;s.querySelector('text.axis').textContent="
    "(a<=1e-6&&b>=T-1e-6)?'0 s … '+b.toFixed(1)+' s':"
    "a.toFixed(1)+' s … '+b.toFixed(1)+' s of '+T.toFixed(1)+' s';}},"
    "set:function(s,a,b){var d=s.dataset,T=+d.total,"
    "w=Math.min(T,Math.max(T*" + f"{1 / 2000:g}" + ",0.05,b-a));"
    "if(a+w>T)a=T-w;if(a<0)a=0;d.a=a;d.b=a+w;this.lay(s);},"
    "wheel:function(e){e.preventDefault();var s=e.currentTarget,d=s.dataset,"
    "p=new DOMPoint(e.clientX,e.clientY).matrixTransform(s.getScreenCTM().inverse()),"
    "a=+d.a,b=+d.b,t=a+(p.x-d.left)*(b-a)/d.plot,"
    "f=Math.min(4,Math.max(0.25,Math.exp(e.deltaY*0.0015)));"
    "this.hide();this.set(s,t-(t-a)*f,t+(b-t)*f);this.report(s);},"
    "down:function(e){var s=e.currentTarget,d=s.dataset,r=s.getBoundingClientRect();"
    "this.drag={x:e.clientX,a:+d.a,b:+d.b,"
    "k:(d.b-d.a)/d.plot*s.viewBox.baseVal.width/r.width,moved:false};},"
    "move:function(e){var s=e.currentTarget,g=this.drag;if(g){var dx=e.clientX-g.x;"
    "if(Math.abs(dx)>4)g.moved=true;"
    "if(g.moved){this.hide();this.set(s,g.a-dx*g.k,g.b-dx*g.k);return;}}this.tip(e);},"
    "up:function(e){var s=e.currentTarget,g=this.drag;this.drag=null;"
    "if(g&&g.moved){this.report(s);return;}var b=e.target.closest('[data-step]');"
    "if(b&&s.dataset.click=='1'){clearTimeout(this.t);this.send(s,'step',b.dataset.step);}},"
    "leave:function(e){var g=this.drag;this.drag=null;this.hide();"
    "if(g&&g.moved)this.report(e.currentTarget);},"
    "tip:function(e){var b=e.target.closest('[data-tip]'),"
    "t=document.getElementById('tandem-lanes-tip');"
    "if(!b){this.hide();return;}"
    "if(!t){t=document.createElement('div');t.id='tandem-lanes-tip';"
    "t.style.cssText='position:fixed;z-index:10000;pointer-events:none;background:#fff;"
    "border:1px solid #888;border-radius:4px;padding:4px 6px;font:12px sans-serif;"
    "white-space:pre-line;max-width:340px;box-shadow:0 1px 4px rgba(0,0,0,.3)';"
    "document.body.appendChild(t);}"
    "t.textContent=b.dataset.tip;t.style.display='block';"
    "var x=e.clientX+14,y=e.clientY+14;"
    "if(x+t.offsetWidth>innerWidth)x=e.clientX-t.offsetWidth-8;"
    "if(y+t.offsetHeight>innerHeight)y=e.clientY-t.offsetHeight-8;"
    "t.style.left=x+'px';t.style.top=y+'px';},"
    "hide:function(){var t=document.getElementById('tandem-lanes-tip');"
    "if(t)t.style.display='none';}"
    "};}tandemLanes.hide();"
)
_HANDLERS = (
    'onwheel="tandemLanes.wheel(event)" onpointerdown="tandemLanes.down(event)" '
    'onpointermove="tandemLanes.move(event)" onpointerup="tandemLanes.up(event)" '
    'onpointerleave="tandemLanes.leave(event)"'
)
HIDE_BRIDGE = (
    '<style>.mantine-Flex-root:has(> div > .mantine-TextInput-root input[value^="lanes:"])'
    "{display:none}svg.tandem-lanes g.bar{cursor:pointer}</style>"
)
# The picture as wide as the tab, its height following (the SVG has a viewBox).
_SVG_STYLE = 'style="width:100%;height:auto;cursor:grab;touch-action:none;user-select:none"'
SCRIPT_HTML = f'<img src="data:," style="display:none" onerror="{_SCRIPT}">'


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
    window: Window | None = None,
    name: Picture = "first",
) -> str:
    """The lanes picture `name` for the page, at the tab's width (`lanes_svg` says
    what `marked`, `until` and `window` do), zoomed, panned and hovered in the page;
    a click on a bar (if `clickable`) reports its step through the hidden field."""
    svg = lanes_svg(events, shown, marked, until, window=window, name=name)
    if not svg:
        return "<p><i>No step of this session is on a lane.</i></p>"
    stamp = f'data-click="{int(clickable)}"'
    return svg.replace("<svg ", f"<svg {stamp} {_SVG_STYLE} {_HANDLERS} ", 1)


@dataclass(frozen=True)
class LaneMessage:
    """What the page reported: a click on a bar (`step`) or a zoom or pan (`view`),
    in picture `picture`, showing `window` then (None: an older page's message)."""

    what: Literal["step", "view"]
    step: int | None
    picture: Picture
    window: Window | None


def bridged(value: str) -> LaneMessage | None:
    """The message in the hidden field's `value`, or None for anything else."""
    parts = value.removeprefix(BRIDGE).split(":")
    if len(parts) < 2 or parts[0] not in ("step", "view"):
        return None
    step = int(parts[1]) if parts[1].isdigit() else None
    if parts[0] == "step" and step is None:
        return None
    picture: Picture = "second" if len(parts) >= 5 and parts[2] == "second" else "first"
    window = None
    if len(parts) >= 5:
        try:
            a, b = (float(v) for v in parts[3].split(","))
        except ValueError:
            return None
        window = (a, b) if b > a else None
    return LaneMessage("step" if parts[0] == "step" else "view", step, picture, window)


def bridged_step(value: str) -> int | None:
    """The step a click on the lanes reported, or None for anything else."""
    message = bridged(value)
    return message.step if message is not None and message.what == "step" else None


def clamped(window: Window, total: float) -> Window:
    """`window` within the session's time, no narrower than the page lets it be
    (as the page's script clamps it)."""
    width = min(total, max(total / 2000, 0.05, window[1] - window[0]))
    start = max(0.0, min(window[0], total - width))
    return (start, start + width)


def zoomed(window: Window | None, total: float, how: str) -> Window | None:
    """The window after "All", "In" or "Out" (about its middle); None: all of it."""
    if how == "All" or window is None and how == "Out":
        return None
    a, b = window or (0.0, total)
    k = ZOOM_STEP if how == "In" else 1 / ZOOM_STEP
    middle, half = (a + b) / 2, (b - a) * k / 2
    out = clamped((middle - half, middle + half), total)
    return None if out[1] - out[0] >= total - 1e-9 else out


def following(window: Window | None, t: float, total: float) -> Window | None:
    """`window` moved, its width kept, so time `t` (the cursor) is in it."""
    if window is None or window[0] <= t <= window[1]:
        return window
    width = window[1] - window[0]
    return clamped((t - width / 3, t - width / 3 + width), total)


def step_time(events: Sequence[ExecutionEvent], k: int) -> float:
    """Where the cursor of step `k` stands: its end."""
    return spans(events)[k][1]
