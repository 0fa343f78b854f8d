"""Who answered, or where a human action's times came from, as a mark on the lanes.

Pure (no viser). Every answer source has its own shape and colour
(`SOURCE_MARKS`), so no two read alike even in grey or at a glance (one letter
used to stand for both click and camera); the colours are Okabe and Ito's,
told apart by most colour-blind readers too. `glyph` draws one mark centred
on (0, y); `legend_html` says what the marks, the hatching and the lines of
the lanes mean.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Literal

from app.execution.events import ANSWER_SOURCES, AnswerSource

Shape = Literal["circle", "square", "diamond", "triangle", "star", "cross", "plus", "ring"]


@dataclass(frozen=True)
class SourceMark:
    shape: Shape
    colour: str
    words: str  # who answered, in a sentence's words


SOURCE_MARKS: dict[AnswerSource, SourceMark] = {
    "click": SourceMark("circle", "#0072b2", "a click in the dashboard"),
    "console": SourceMark("square", "#000000", "the console"),
    "camera": SourceMark("diamond", "#009e73", "the camera"),
    "voice": SourceMark("triangle", "#cc79a7", "the voice"),
    "simulated": SourceMark("star", "#d55e00", "the simulated human"),
    "random": SourceMark("cross", "#e69f00", "a random choice"),
    "scripted": SourceMark("plus", "#56b4e9", "a script"),
    "expected": SourceMark("ring", "#666666", "the plan's expected outcome"),
}
assert set(SOURCE_MARKS) == set(ANSWER_SOURCES)  # a new source needs its own mark

# Where a human action's times came from, by its source.
HUMAN_TIMES: dict[AnswerSource, str] = {
    "simulated": "the simulated human's own times",
    "camera": "observed by the camera",
    "voice": "heard by the voice",
    "click": "reported by a click (it ends the action)",
    "console": "reported at the console (it ends the action)",
}
CURSOR_COLOUR = "#ff7f0e"
DIVERGED_COLOUR = "#c0392b"
# Five points, 6 units out and 2.6 in, the first up.
_STAR = " ".join(
    f"{r * math.sin(k * math.pi / 5):.2f},{-r * math.cos(k * math.pi / 5):.2f}"
    for k, r in enumerate([6.0, 2.6] * 5)
)
_OUTLINE = 'stroke="#ffffff" stroke-width="1.2"'  # a mark stays readable on any bar


def _shape(shape: Shape, colour: str, y: float) -> str:
    fill = f'fill="{colour}" {_OUTLINE}'
    if shape == "circle":
        return f'<circle cx="0" cy="{y:.1f}" r="4.3" {fill}/>'
    if shape == "square":
        return f'<rect x="-3.8" y="{y - 3.8:.1f}" width="7.6" height="7.6" {fill}/>'
    if shape == "ring":
        return (f'<circle cx="0" cy="{y:.1f}" r="3.6" fill="#ffffff" stroke="{colour}" '
                'stroke-width="2.2"/>')  # fmt: skip
    if shape in ("cross", "plus"):
        d = "M-3.5,-3.5L3.5,3.5M-3.5,3.5L3.5,-3.5" if shape == "cross" else "M0,-4.5V4.5M-4.5,0H4.5"
        return (f'<path transform="translate(0,{y:.1f})" d="{d}" stroke="#ffffff" '
                f'stroke-width="4.4"/><path transform="translate(0,{y:.1f})" d="{d}" '
                f'stroke="{colour}" stroke-width="2.4"/>')  # fmt: skip
    points = {
        "diamond": "0,-5.2 5.2,0 0,5.2 -5.2,0",
        "triangle": "0,-5 5,4 -5,4",
        "star": _STAR,
    }[shape]
    return f'<polygon transform="translate(0,{y:.1f})" points="{points}" {fill}/>'


def glyph(source: AnswerSource, y: float) -> str:
    """The source's mark centred on (0, y), tagged with the source."""
    mark = SOURCE_MARKS[source]
    return f'<g class="mark" data-source="{source}">{_shape(mark.shape, mark.colour, y)}</g>'


def _swatch(inner: str, width: int = 14) -> str:
    return (f'<svg width="{width}" height="12" viewBox="{-width / 2} -6 {width} 12" '
            f'style="vertical-align:middle;margin-right:3px">{inner}</svg>')  # fmt: skip


def _item(swatch: str, words: str) -> str:
    return (f'<span style="display:inline-flex;align-items:center;margin:0 9px 2px 0">'
            f"{swatch}{words}</span>")  # fmt: skip


def legend_html(sources: Iterable[AnswerSource], compared: bool = False) -> str:
    """What the marks of `sources` (those on the lanes drawn), the hatching and the
    lines mean, and how to zoom."""
    seen = [s for s in ANSWER_SOURCES if s in set(sources)]
    items = [_item(_swatch(glyph(s, 0.0)), s) for s in seen]
    hatch = ('<rect x="-7" y="-5" width="14" height="10" fill="#ffe680" stroke="#777"/>'
             '<path d="M-7,5L3,-5M-2,5L7,-4" stroke="#ffffff" stroke-width="2"/>')  # fmt: skip
    items.append(_item(_swatch(hatch), "robot waits for the human"))
    line = f'<line x1="0" x2="0" y1="-6" y2="6" stroke="{CURSOR_COLOUR}" stroke-width="2"/>'
    items.append(_item(_swatch(line, 8), "step shown"))
    if compared:
        parted = (f'<line x1="0" x2="0" y1="-6" y2="6" stroke="{DIVERGED_COLOUR}" '
                  'stroke-width="2" stroke-dasharray="3 2"/>')  # fmt: skip
        items.append(_item(_swatch(parted, 8), "where the paths parted"))
    hint = ('<span style="color:#666">Wheel zooms, drag pans, hover or click a bar.</span>')
    return (f'<div class="tandem-lanes-legend" style="font-size:11px;line-height:1.3;'
            f'margin-top:3px">{"".join(items)}{hint}</div>')  # fmt: skip
