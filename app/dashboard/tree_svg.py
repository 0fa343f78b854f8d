"""The plan tree as an SVG picture: boxes in words, outcomes on edges, marks of a run.

Pure (no viser): `draw(plan, layout, marks, view)` returns the SVG text the
tree panel puts in the page. The layout (tree_layout.py) gives every visible
node its own column and every depth its own row, and every column is as wide
as the plan's widest label, whole (never cut), so no two labels can overlap;
zooming scales the picture as a whole, so they do not overlap at any zoom
either. The width comes from the whole plan, not the nodes shown, so opening
a fold never widens the columns under the user's eyes.

Only a node's box and a fold's badge take the pointer: its words (the label,
the id, the outcome on its edge) let a click through to the box under them.

What the marks say: the node being executed (orange, `current`), the nodes
and edges an execution or a review passed (blue, `path`, each answered node
with who answered and how sure), the branches not taken (faded once a path
exists), the selected node (magenta), and search matches (yellow).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from html import escape

from app.dashboard.tree_layout import Edge, TreeLayout
from app.execution.events import AnswerSource
from planner.plan.model import Plan, PlanNode

ROW_PX = 64.0  # between depths: a box, an elbow and an outcome label
BOX_PX = 32.0  # a box's height: the action, then the node and its answer
CHAR_PX = 6.7  # width of a character at FONT_PX (measured in Chromium's sans-serif)
FONT_PX = 11.0
SMALL_PX = 9.0
MARGIN_PX = 24.0
GAP_PX = 18.0  # between neighbouring columns

QUESTION_FILL = "#d4c4ff"  # communication with outcomes: the robot asks
FILLS = {
    "actuation": "#d9d9d9",
    "sensing": "#ffe680",
    "communication": "#9fd3ff",
    "goal": "#a8e6a1",
    "open": "#f4f4f4",
}
CURRENT = "#ff7f0e"
PATH = "#1f6fd1"
SELECTED = "#d0209c"
MATCH = "#fff200"
# Words never take the pointer: a click on a label is the click on its box.
_THROUGH = 'pointer-events="none"'

# The legend, in the order the panel shows it: (swatch style, words).
LEGEND: tuple[tuple[str, str], ...] = (
    (f"background:{FILLS['actuation']}", "robot action"),
    (f"background:{FILLS['sensing']}", "sensing"),
    (f"background:{QUESTION_FILL}", "question"),
    (f"background:{FILLS['communication']}", "talk"),
    (f"background:{FILLS['goal']}", "goal"),
    (f"background:{FILLS['open']};border:1px dashed #999", "still planned"),
    ("border-top:3px solid #333;height:0", "expected branch"),
    ("border-top:2px dashed #8a8ad0;height:0", "shared state (reached twice)"),
    (f"border-top:4px solid {PATH};height:0", "path taken, · who answered"),
    (f"background:{FILLS['actuation']};opacity:0.4", "faded: not taken"),
    (f"border:3px solid {CURRENT}", "executing now"),
    (f"border:3px solid {SELECTED}", "selected"),
    (f"background:{MATCH}", "found (Find)"),
    ("background:#555;border-radius:6px", "+N: a folded branch, click to open"),
)


@dataclass(frozen=True)
class Step:
    """A node an execution passed: who answered its question, how sure, and the
    answer (None: not answered yet, or no question)."""

    node: str
    source: AnswerSource | None = None
    confidence: float | None = None
    outcome: str | None = None


@dataclass(frozen=True)
class TreeMarks:
    """What the picture marks besides the plan itself."""

    selected: str | None = None
    current: str | None = None
    path: tuple[Step, ...] = ()
    matches: frozenset[str] = field(default_factory=frozenset)


@dataclass(frozen=True)
class Geometry:
    """Where each visible node's box is, in picture pixels (top-left corner)."""

    boxes: dict[str, tuple[float, float]]
    column_px: float
    width: float
    height: float

    def centre(self, node_id: str) -> tuple[float, float]:
        x, y = self.boxes[node_id]
        return x + self.column_px / 2, y + BOX_PX / 2


def label(node: PlanNode) -> str:
    """The node's action in the paper's terms, whole ("goal" at a goal, "planning"
    at a state still being planned)."""
    if node.action is None:
        return "goal" if node.kind == "goal" else "planning"
    return str(node.action)


_widest: dict[int, tuple[Plan, int, int]] = {}  # id(plan) -> (plan, nodes, widest label)


def widest_label(plan: Plan) -> int:
    """Characters of the plan's longest label (kept per plan: U10 has 7,240 nodes;
    a growing plan is measured again when it has more)."""
    known = _widest.get(id(plan))
    if known is not None and known[0] is plan and known[1] == len(plan.nodes):
        return known[2]
    widest = max((len(label(n)) for n in plan.nodes.values()), default=4)
    _widest.clear()  # one plan on screen at a time
    _widest[id(plan)] = (plan, len(plan.nodes), widest)
    return widest


def is_question(node: PlanNode) -> bool:
    return node.kind == "communication" and len(node.children) > 1


def geometry(plan: Plan, layout: TreeLayout) -> Geometry:
    column = max(widest_label(plan) * CHAR_PX + 16.0, 110.0)
    boxes: dict[str, tuple[float, float]] = {}
    for node_id, (x, depth_y) in layout.positions.items():
        row = round(depth_y / 1.6)  # tree_layout's ROW
        boxes[node_id] = (MARGIN_PX + x * (column + GAP_PX), MARGIN_PX + 14.0 + row * ROW_PX)
    width = max((x for x, _ in boxes.values()), default=0.0) + column + 2 * MARGIN_PX
    height = max((y for _, y in boxes.values()), default=0.0) + BOX_PX + 2 * MARGIN_PX + 14.0
    return Geometry(boxes, column, width, height)


def _answer_words(step: Step | None) -> str:
    if step is None or step.source is None:
        return ""
    sure = ""
    if step.confidence is not None and step.source != "click":  # a click is sure
        sure = f" {step.confidence:.2f}"
    return f" · {step.source}{sure}"


def _node_svg(plan: Plan, node_id: str, geo: Geometry, marks: TreeMarks,
              layout: TreeLayout, steps: dict[str, Step]) -> str:  # fmt: skip
    node = plan.nodes[node_id]
    x, y = geo.boxes[node_id]
    w = geo.column_px
    fill = QUESTION_FILL if is_question(node) else FILLS.get(node.kind, FILLS["open"])
    on_path = node_id in steps
    faded = bool(marks.path) and not on_path and node_id != marks.current
    stroke, stroke_w, dash = "#777", 1.0, ""
    if node.kind == "open":
        dash = ' stroke-dasharray="4 3"'
    if on_path:
        stroke, stroke_w = PATH, 2.5
    if node_id == marks.current:
        stroke, stroke_w = CURRENT, 4.0
    parts = [f'<g class="node" data-node="{node_id}" opacity="{0.4 if faded else 1}">']
    parts.append(f"<title>{escape(node_id)}: {escape(str(node.action or node.kind))}</title>")
    if node_id in marks.matches:
        parts.append(f'<rect x="{x - 5}" y="{y - 5}" width="{w + 10}" height="{BOX_PX + 10}" '
                     f'rx="8" fill="{MATCH}"/>')  # fmt: skip
    if node_id == marks.selected:
        parts.append(f'<rect x="{x - 4}" y="{y - 4}" width="{w + 8}" height="{BOX_PX + 8}" '
                     f'rx="7" fill="none" stroke="{SELECTED}" stroke-width="3"/>')  # fmt: skip
    parts.append(f'<rect class="box" x="{x}" y="{y}" width="{w}" height="{BOX_PX}" rx="5" '
                 f'fill="{fill}" '
                 f'stroke="{stroke}" stroke-width="{stroke_w}"{dash}/>')  # fmt: skip
    parts.append(f'<text class="label" x="{x + w / 2}" y="{y + 13}" text-anchor="middle" '
                 f'font-size="{FONT_PX}" {_THROUGH}>{escape(label(node))}</text>')  # fmt: skip
    small = node_id + _answer_words(steps.get(node_id))
    parts.append(f'<text x="{x + w / 2}" y="{y + 26}" text-anchor="middle" font-size='
                 f'"{SMALL_PX}" fill="#444" {_THROUGH}>{escape(small)}</text>')  # fmt: skip
    hidden = layout.hidden_below.get(node_id)
    if hidden:
        parts.append(_badge(node_id, x + w / 2, y + BOX_PX, hidden))
    parts.append("</g>")
    return "".join(parts)


def _badge(node_id: str, cx: float, top: float, hidden: int) -> str:
    """A folded branch: how many nodes it hides; a click opens it."""
    text = f"+{hidden}"
    w = len(text) * 6.5 + 10
    return (f'<g class="fold" data-toggle="{node_id}"><title>Open the {hidden} nodes below</title>'
            f'<rect x="{cx - w / 2}" y="{top + 3}" width="{w}" height="14" rx="7" fill="#555"/>'
            f'<text x="{cx}" y="{top + 13.5}" text-anchor="middle" font-size="{SMALL_PX}" '
            f'fill="#fff" {_THROUGH}>{text}</text></g>')  # fmt: skip


def _edge_svg(edge: Edge, geo: Geometry, expected: set[tuple[str, str]],
              taken: set[tuple[str, str]]) -> str:  # fmt: skip
    (px, py), (cx, cy) = geo.boxes[edge.parent], geo.boxes[edge.child]
    half = geo.column_px / 2
    x1, y1, x2, y2 = px + half, py + BOX_PX, cx + half, cy
    if edge.shared:
        return (f'<path d="M{x1},{y1} C{x1},{y1 + 40} {x2},{y2 - 40} {x2},{y2}" fill="none" '
                f'stroke="#8a8ad0" stroke-width="1.5" stroke-dasharray="5 4"/>')  # fmt: skip
    key = (edge.parent, edge.child)
    colour, width = "#b5b5b5", 1.2
    if key in expected:
        colour, width = "#333", 2.5
    if key in taken:
        colour, width = PATH, 4.0
    mid = y1 + 10.0
    out = (f'<path d="M{x1},{y1} V{mid} H{x2} V{y2}" fill="none" stroke="{colour}" '
           f'stroke-width="{width}"/>')  # fmt: skip
    if edge.outcome is not None:
        out += (f'<text class="outcome" x="{x2}" y="{y2 - 5}" text-anchor="middle" '
                f'font-size="{SMALL_PX + 1}" font-style="italic" fill="#333" {_THROUGH}>'
                f"{escape(edge.outcome)}</text>")  # fmt: skip
    return out


def draw(plan: Plan, layout: TreeLayout, marks: TreeMarks, view: tuple[float, ...]) -> str:
    """The SVG of the visible tree; `view` is its viewBox (x, y, width, height)."""
    geo = geometry(plan, layout)
    steps = {s.node: s for s in marks.path}
    walked = [s.node for s in marks.path]
    taken = set(zip(walked, walked[1:], strict=False))
    branch = [n for n, _ in plan.expected_path()]
    expected = set(zip(branch, branch[1:], strict=False))
    edges = "".join(_edge_svg(e, geo, expected, taken) for e in layout.edges
                    if e.parent in geo.boxes and e.child in geo.boxes)  # fmt: skip
    nodes = "".join(_node_svg(plan, n, geo, marks, layout, steps) for n in layout.positions)
    vx, vy, vw, vh = view
    return (f'<svg class="tandem-tree" data-width="{geo.width:.0f}" '
            f'data-height="{geo.height:.0f}" viewBox="{vx:.1f} {vy:.1f} {vw:.1f} {vh:.1f}" '
            f'font-family="sans-serif">{edges}{nodes}</svg>')  # fmt: skip


STRIP_CELL_PX = 14.0
STRIP_MAX = 40  # the last steps the strip shows


def strip_svg(nodes: list[str], kinds: list[str]) -> str:
    """The execution as a compact timeline: one cell per step, coloured by its
    kind as in the tree, the last (running) one framed in orange."""
    if not nodes:
        return ""
    shown = list(zip(nodes, kinds, strict=True))[-STRIP_MAX:]
    cells = []
    for i, (node, kind) in enumerate(shown):
        last = i == len(shown) - 1
        stroke = f'stroke="{CURRENT}" stroke-width="3"' if last else 'stroke="#777"'
        cells.append(f'<rect x="{i * STRIP_CELL_PX + 2}" y="2" width="{STRIP_CELL_PX - 3}" '
                     f'height="16" rx="2" fill="{FILLS.get(kind, FILLS["open"])}" {stroke}>'
                     f"<title>{escape(node)} ({kind})</title></rect>")  # fmt: skip
    width = len(shown) * STRIP_CELL_PX + 4
    skipped = len(nodes) - len(shown)
    words = f"step {len(nodes)}" + (f" (the last {len(shown)} shown)" if skipped else "")
    return (f'<div style="font-size:11px">Timeline: {words}</div>'
            f'<svg class="tandem-strip" width="{width}" height="20">{"".join(cells)}</svg>')
