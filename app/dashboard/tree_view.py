"""The plan tree panel: the tree as a picture (tree_svg.py) the user zooms, pans and clicks.

The picture is an SVG in a `gui.add_html` element. viser sends no clicks from
HTML, so the picture's own handlers (inline attributes: the page runs them,
unlike `<script>`) write what happened into a text field of the panel that
the page never shows, as a user typing would: "select:n7", "toggle:n7" (a
folded branch's badge), "view:x,y,w,h" (after a zoom or a pan, so the next
picture keeps it). The server answers a click by drawing again.

Wheel zooms about the pointer, dragging pans; "Fit" shows all, "Follow"
keeps the node being executed in view. Large plans open on the expected
branch (`SpanningTree.default_collapsed`); a badge "+N" under a folded node
opens it.
"""

from __future__ import annotations

import threading
from collections.abc import Callable

import viser

from app.dashboard.tree_layout import SpanningTree, TreeLayout, layout
from app.dashboard.tree_svg import LEGEND, Geometry, Step, TreeMarks, draw, geometry, label
from planner.plan.model import Plan

VIEW_W, VIEW_H = 560.0, 520.0  # picture pixels shown at first (about the panel's size)
# Fit shrinks a large tree only this far (picture pixels per screen pixel): its
# 11 px labels stay about 7 px high, readable; the rest is reached by panning.
FIT_MOST = 1.55
ZOOMS = ("Fit", "In", "Out", "Root")
WIDTHS = ("Wide", "Narrow")  # the tree's column beside the bench, per page
BRIDGE = "tree:"  # what the hidden field's value starts with

# The picture's handlers, defined once per page (an image that fails to load runs them).
_SCRIPT = (
    "if(!window.tandemTree){window.tandemTree={"
    "send:function(m){var i=document.querySelector('input[value^=\\'tree:\\']');if(!i)return;"
    "Object.getOwnPropertyDescriptor(HTMLInputElement.prototype,'value').set"
    ".call(i,'tree:'+m+':'+Date.now());i.dispatchEvent(new Event('input',{bubbles:true}));},"
    "report:function(s){clearTimeout(this.t);var b=s.viewBox.baseVal;"
    "this.t=setTimeout(function(){tandemTree.send('view:'+[b.x,b.y,b.width,b.height]"
    ".map(function(v){return v.toFixed(1)}).join(','))},250);},"
    # The wheel zooms about the pointer; sideways (a trackpad, or Shift) it pans.
    "wheel:function(e){e.preventDefault();var s=e.currentTarget,b=s.viewBox.baseVal;"
    "var r=s.getBoundingClientRect(),q=Math.max(b.width/r.width,b.height/r.height);"
    "if(e.shiftKey||Math.abs(e.deltaX)>Math.abs(e.deltaY)){"
    "b.x+=(e.shiftKey?e.deltaY:e.deltaX)*q;if(!e.shiftKey)b.y+=e.deltaY*q;this.report(s);return;}"
    "var p=new DOMPoint(e.clientX,e.clientY).matrixTransform(s.getScreenCTM().inverse());"
    "var k=Math.min(4,Math.max(0.25,Math.exp(e.deltaY*0.0015)));"
    "b.x=p.x-(p.x-b.x)*k;b.y=p.y-(p.y-b.y)*k;b.width*=k;b.height*=k;this.report(s);},"
    "down:function(e){var s=e.currentTarget,b=s.viewBox.baseVal,r=s.getBoundingClientRect();"
    "this.drag={x:e.clientX,y:e.clientY,bx:b.x,by:b.y,"
    "k:Math.max(b.width/r.width,b.height/r.height),moved:false};},"
    "move:function(e){var d=this.drag;if(!d)return;var dx=e.clientX-d.x,dy=e.clientY-d.y;"
    "if(Math.abs(dx)+Math.abs(dy)>4)d.moved=true;if(!d.moved)return;"
    "var b=e.currentTarget.viewBox.baseVal;b.x=d.bx-dx*d.k;b.y=d.by-dy*d.k;},"
    "up:function(e){var d=this.drag;this.drag=null;if(d&&d.moved){this.report(e.currentTarget);"
    "return;}var t=e.target.closest('[data-toggle]');"
    "if(t){this.send('toggle:'+t.dataset.toggle);return;}"
    "var n=e.target.closest('[data-node]');if(n)this.send('select:'+n.dataset.node);},"
    # The element's size in pixels when it changed (a panel resized or widened),
    # so the server keeps one picture pixel per screen pixel at zoom 1.
    "size:function(){var s=document.querySelector('svg.tandem-tree');if(!s)return;"
    "var r=s.getBoundingClientRect(),z=Math.round(r.width)+','+Math.round(r.height);"
    "if(r.width>0&&z!==tandemTree.z){tandemTree.z=z;tandemTree.send('size:'+z);}}"
    "};setInterval(function(){tandemTree.size()},700);}"
    "setTimeout(function(){tandemTree.size()},50);"
)
_HANDLERS = (
    'onwheel="tandemTree.wheel(event)" onpointerdown="tandemTree.down(event)" '
    'onpointermove="tandemTree.move(event)" onpointerup="tandemTree.up(event)" '
    'onpointerleave="tandemTree.drag=null"'
)
# The picture fills the tab's width and most of the tree panel's height, leaving
# the selected node's first lines below it in view.
_SVG_STYLE = (
    'style="width:100%;height:max(200px,calc(50vh - 215px));cursor:grab;'
    'touch-action:none;user-select:none"'
)
_STYLE = (
    '<style>.mantine-Flex-root:has(> div > .mantine-TextInput-root input[value^="tree:"])'
    "{display:none}</style>"
)
EMPTY = "<p>No plan yet: press <b>Plan</b>.</p>"


def legend_html() -> str:
    """Every mark the picture draws, in a few short rows."""
    items = "".join(
        f'<span class="legend-item" style="display:inline-flex;align-items:center;'
        f'margin:0 8px 2px 0;white-space:nowrap">'
        f'<span style="display:inline-block;width:14px;height:9px;margin-right:3px;{style}">'
        f"</span>{words}</span>"
        for style, words in LEGEND
    )
    return f'<div class="tandem-legend" style="font-size:10px;line-height:1.25">{items}</div>'


class TreeView:
    """The tree panel. `on_select(node_id)` on a click; `show` draws a plan."""

    def __init__(self, gui: viser.GuiApi, on_select: Callable[[str], None]) -> None:
        self.on_select = on_select
        # Widens (True) or narrows a page's tree column (the layout's, set by the
        # dashboard); None: the buttons do nothing.
        self.on_width: Callable[[viser.ClientHandle, bool], None] | None = None
        self.plan: Plan | None = None
        self.tree: SpanningTree | None = None
        self.collapsed: set[str] = set()
        self.current: TreeLayout | None = None
        self.geometry: Geometry | None = None
        self.marks = TreeMarks()
        self.view: tuple[float, float, float, float] = (0.0, 0.0, VIEW_W, VIEW_H)
        self.size = (VIEW_W, VIEW_H)  # the picture's element on the page, in pixels
        # Pictures sent so far; each carries its number (data-draw), so a page (or a
        # test) can tell the newest picture from one about to be replaced.
        self.draws = 0
        self._found: list[str] = []
        # Planning, execution and clicks redraw from different threads.
        self._lock = threading.RLock()
        self.bridge: viser.GuiTextHandle = gui.add_text("tree events", BRIDGE)
        self.bridge.on_update(lambda _: self._bridged(str(self.bridge.value)))
        # Always at hand, one row: zoom, and the tree beside the bench (Wide) or not.
        view = gui.add_button_group("View", (*ZOOMS, *WIDTHS))
        view.on_click(self._view_clicked)
        self.fit_note = gui.add_markdown("")
        self.picture = gui.add_html(_STYLE + EMPTY)
        # Under the picture and the selected node's details (added by the dashboard
        # between them), so those two share the panel's height.
        self._gui = gui
        # Made by add_find_controls.
        self.found: viser.GuiMarkdownHandle | None = None
        self.follow: viser.GuiCheckboxHandle | None = None

    def add_find_controls(self) -> None:
        """Find, Follow and the legend, in a folder closed at first."""
        gui = self._gui
        with gui.add_folder("Find, follow, legend", expand_by_default=False):
            self.find_text: viser.GuiTextHandle = gui.add_text("Find action or node", "")
            self.find_button = gui.add_button("Find next")
            self.find_button.on_click(lambda _: self.find(str(self.find_text.value)))
            self.found = gui.add_markdown("")
            self.follow = gui.add_checkbox("Follow the execution", True)
            gui.add_html(legend_html())

    def _view_clicked(self, event: viser.GuiEvent[viser.GuiButtonGroupHandle]) -> None:
        what = str(event.target.value)
        if what in ZOOMS:
            self.zoom(what)
        elif self.on_width is not None and event.client is not None:
            self.on_width(event.client, what == "Wide")

    # -- what the page sends ------------------------------------------------------

    def _bridged(self, value: str) -> None:
        parts = value.removeprefix(BRIDGE).split(":")
        if len(parts) < 2:
            return
        what, arg = parts[0], parts[1]
        if what == "select":
            self.on_select(arg)
        elif what == "toggle":
            self.toggle(arg)
        elif what == "size":
            self._resized(arg)
        elif what == "view":
            numbers = [float(v) for v in arg.split(",")]
            if len(numbers) == 4 and numbers[2] > 0 and numbers[3] > 0:
                self.view = (numbers[0], numbers[1], numbers[2], numbers[3])

    def _resized(self, arg: str) -> None:
        numbers = [float(v) for v in arg.split(",")]
        if len(numbers) != 2 or min(numbers) <= 0:
            return
        with self._lock:
            k = self.view[2] / self.size[0]  # picture pixels per screen pixel now
            self.size = (numbers[0], numbers[1])
            x, y, _, _ = self.view
            self.view = (x, y, numbers[0] * k, numbers[1] * k)
            self.redraw()

    # -- drawing --------------------------------------------------------------------

    def show(self, plan: Plan, *, keep_collapsed: bool = False) -> None:
        """Draw `plan`; a new plan gets the default folding (expected branch open)
        and a view on its root (the plan panel says how often a growing plan is
        drawn)."""
        with self._lock:
            first = self.plan is None or self.plan.root != plan.root or not keep_collapsed
            self.plan = plan
            self.tree = SpanningTree.of(plan)
            if not keep_collapsed:
                self.collapsed = self.tree.default_collapsed(plan)
                self.marks = TreeMarks()
            self._layout()
            if first:
                self.zoom("Root")
            self.redraw()

    def clear(self) -> None:
        """No plan: the panel says how to make one."""
        with self._lock:
            self.plan = self.tree = self.current = self.geometry = None
            self.marks = TreeMarks()
            self.picture.content = _STYLE + EMPTY
            self.fit_note.content = ""

    def _layout(self) -> None:
        assert self.plan is not None and self.tree is not None
        self.current = layout(self.tree, self.collapsed)
        self.geometry = geometry(self.plan, self.current)

    def redraw(self) -> None:
        with self._lock:
            if self.plan is None or self.current is None:
                return
            svg = draw(self.plan, self.current, self.marks, self.view)
            self.draws += 1
            stamp = f'data-draw="{self.draws}"'
            svg = svg.replace("<svg ", f"<svg {stamp} {_SVG_STYLE} {_HANDLERS} ", 1)
            script = f'<img src="data:," style="display:none" onerror="{_SCRIPT}">'
            self.picture.content = _STYLE + script + svg

    def toggle(self, node_id: str) -> None:
        """Fold or open the branch below `node_id`; the node stays where it was on
        the screen (the picture moves about it, not it about the picture)."""
        with self._lock:
            if self.tree is None or self.geometry is None or not self.tree.children.get(node_id):
                return
            was = self.geometry.centre(node_id)
            self.collapsed ^= {node_id}
            self._layout()
            assert self.geometry is not None
            now = self.geometry.centre(node_id)
            x, y, w, h = self.view
            self.view = (x + now[0] - was[0], y + now[1] - was[1], w, h)
            self.redraw()

    def expand_to(self, node_id: str) -> None:
        """Open every folded ancestor so `node_id` is visible."""
        with self._lock:
            assert self.tree is not None
            hidden = set(self.tree.lineage(node_id)[:-1]) & self.collapsed
            if hidden:
                self.collapsed -= hidden
                self._layout()

    def highlight(self, node_id: str) -> None:
        """Mark `node_id` selected (and keep it in view if it is off the picture)."""
        with self._lock:
            self.marks = TreeMarks(node_id, self.marks.current, self.marks.path,
                                   self.marks.matches)  # fmt: skip
            self._keep_in_view(node_id)
            self.redraw()

    def show_path(
        self, path: tuple[Step, ...], current: str | None, *, redraw: bool = True
    ) -> None:
        """An execution's (or a review's) steps so far; `current` runs now. Without
        `redraw` the marks wait for the next picture (a selection that follows)."""
        with self._lock:
            self.marks = TreeMarks(self.marks.selected, current, path, self.marks.matches)
            # Without the Follow box (no find controls) the tree follows, its default.
            if current is not None and (self.follow is None or bool(self.follow.value)):
                self._centre(current)
            if redraw:
                self.redraw()

    # -- where the picture looks ------------------------------------------------------

    def _keep_in_view(self, node_id: str) -> None:
        geo = self.geometry
        if geo is None or node_id not in geo.boxes:
            return
        x, y = geo.centre(node_id)
        vx, vy, vw, vh = self.view
        if not (vx <= x <= vx + vw and vy <= y <= vy + vh):
            self._centre(node_id)

    def _centre(self, node_id: str) -> None:
        geo = self.geometry
        if geo is None or node_id not in geo.boxes:
            return
        x, y = geo.centre(node_id)
        _, _, w, h = self.view
        self.view = (x - w / 2, y - h / 3, w, h)

    def zoom(self, how: str) -> None:
        with self._lock:
            geo = self.geometry
            if geo is None or self.plan is None:
                return
            x, y, w, h = self.view
            sw, sh = self.size
            if how == "Fit":
                self._fit(geo)
            elif how in ("In", "Out"):
                k = 0.7 if how == "In" else 1 / 0.7
                cx, cy = x + w / 2, y + h / 2
                self.view = (cx - w * k / 2, cy - h * k / 2, w * k, h * k)
            else:  # the root, at the first zoom
                self.view = (0.0, 0.0, sw, sh)
                self._centre(self.plan.root)
                rx, _, rw, rh = self.view
                self.view = (rx, 0.0, rw, rh)
            self.redraw()

    def _fit(self, geo: Geometry) -> None:
        """All of the tree if it is readable so, else as much as is readable: the
        top, about the root, the rest one drag or sideways scroll away."""
        assert self.plan is not None
        sw, sh = self.size
        scale = max(geo.width / sw, geo.height / sh, 1.0)
        if scale <= FIT_MOST:
            self.view = (0.0, 0.0, sw * scale, sh * scale)
            self.fit_note.content = ""
            return
        w, h = sw * FIT_MOST, sh * FIT_MOST
        x = geo.centre(self.plan.root)[0] - w / 2
        self.view = (min(max(0.0, x), max(0.0, geo.width - w)), 0.0, w, h)
        self.fit_note.content = (
            f"The whole tree ({geo.width:,.0f} × {geo.height:,.0f} px) is too large to read "
            "in this panel: drag, or scroll sideways, to see the rest."
        )

    # -- finding ----------------------------------------------------------------------

    def find(self, text: str) -> None:
        """Go to the next node whose action or id contains `text` (case ignored)."""
        with self._lock:
            plan = self.plan
            wanted = text.strip().lower()
            if plan is None or not wanted:
                self._say_found("")
                return
            matches = [n for n, node in plan.nodes.items()
                       if wanted in label(node).lower() or wanted == n.lower()]  # fmt: skip
            if not matches:
                self._say_found(f"No node's action contains “{text.strip()}”.")
                self.marks = TreeMarks(self.marks.selected, self.marks.current, self.marks.path)
                self.redraw()
                return
            after = [n for n in matches if self._found and n > self._found[-1]]
            target = after[0] if after else matches[0]
            self._found = [target]
            self._say_found(f"{matches.index(target) + 1} of {len(matches)}: `{target}`.")
            self.marks = TreeMarks(self.marks.selected, self.marks.current, self.marks.path,
                                   frozenset(matches))  # fmt: skip
            self.expand_to(target)
            self._centre(target)
        self.on_select(target)

    def _say_found(self, words: str) -> None:
        if self.found is not None:  # None: no find controls, nothing to say it in
            self.found.content = words
