"""What every page shows: the bench in 3D, the plan tree in its panel, the selection.

The `Screen` is the panels' `Stage` (stage.py). Planning, executions, reviews
and clicks reach it from different threads, so one lock keeps the plan, the
tree and the selection in step; selecting a node is announced on `Events`
(`NodeSelected`) and showing or dropping a complete plan too (`PlanChanged`).

A node clicked in the tree is shown in two beats: the picture's frame and the
node's details at once, the bench `BENCH_AFTER_S` later. A browser without a
GPU draws the bench in software for a few hundred milliseconds, and a bench
sent with the frame would hold the frame back until it is drawn. What the bench
shows at a node comes from node_world.py, for a click, a run and a review
alike.

viser keeps every message in a buffer it replays to pages that join later, and
a removed element (a question's answer buttons) leaves its
removal there until a page connects; the screen sweeps those out when an
execution ends, so a day of executions watched by the same pages stays flat.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import threading
from collections.abc import Callable, Mapping

import viser

from app.dashboard.bench_scene import BenchScene
from app.dashboard.node_world import node_world
from app.dashboard.stage import Events, ExecutionFinished, NodeSelected, PlanChanged
from app.dashboard.tree_svg import Step
from app.dashboard.tree_view import TreeView
from planner.plan.model import Plan
from planner.scenario.model import Scenario


def _malloc_trim() -> Callable[[int], int] | None:
    """glibc's `malloc_trim`, where there is one."""
    name = ctypes.util.find_library("c")
    try:
        trim: Callable[[int], int] = ctypes.CDLL(name).malloc_trim
    except (OSError, AttributeError, TypeError):
        return None  # not glibc (musl, macOS): nothing to give back this way
    return trim


_TRIM = _malloc_trim()
BENCH_AFTER_S = 0.12  # a clicked node's bench follows its frame in the tree by this


class Screen:
    """The stage of the dashboard. The tree panel is built in the GUI container
    current when the screen is made (the server's "Plan tree" tab); the bench's
    models are loaded apart (`bench.load_models`), after the panels, so a new
    page can be used first."""

    def __init__(self, server: viser.ViserServer, events: Events) -> None:
        self.events = events
        self.server = server
        self.bench = BenchScene(server, load_models=False)
        self.tree = TreeView(server.gui, self.clicked)
        self.plan: Plan | None = None
        self.scenario: Scenario | None = None
        self.selected: str | None = None
        self.bench_at: str | None = None  # the node whose world the bench shows
        self._soon: threading.Timer | None = None  # a clicked node's bench, to come
        self.current_arms: dict[str, list[float]] = {}
        # Reentrant: a `NodeSelected` subscriber may drive the stage again.
        self._lock = threading.RLock()
        events.subscribe(ExecutionFinished, lambda _: self.sweep())

    def sweep(self) -> None:
        """Drops from viser's replay buffer the removals of elements and the
        updates of removed ones that every connected page has already received.

        viser runs the same sweep only when a page connects (its API has no
        public entry); without it an execution watched by the same pages leaves
        ~30 removal messages behind for good. Then the C heap's free pages go back
        to the system: an execution's messages are many small allocations spread
        over the heap, which glibc otherwise keeps as the process's memory."""
        self.server._run_garbage_collector()
        if _TRIM is not None:
            _TRIM(0)

    def current_plan(self) -> Plan | None:
        return self.plan

    def current_scenario(self) -> Scenario | None:
        return self.scenario

    def show_scenario(self, scenario: Scenario) -> None:
        with self._lock:
            self.scenario = scenario
            self.bench.load(scenario)
        self.drop_plan()

    def drop_plan(self) -> None:
        with self._lock:
            self._cancel_soon()
            self.plan = None
            self.selected = self.bench_at = None
            self.tree.clear()
        self.events.publish(PlanChanged(None))

    def show_growing(self, plan: Plan) -> None:
        with self._lock:
            self.plan = plan
            self.tree.show(plan)

    def show_plan(self, plan: Plan) -> None:
        """A complete plan (planned here or stored with a session) in the tree and panels."""
        with self._lock:
            self.plan = plan
            self.tree.show(plan)
        self.select(plan.root)
        self.events.publish(PlanChanged(plan))

    def select(self, node_id: str, *, show_world: bool = True) -> None:
        """Show a node: its details, and the bench as the node leaves it (a node
        hidden in a collapsed branch stays hidden: `go_to` opens it)."""
        with self._lock:
            plan, tree = self.plan, self.tree.tree
            if plan is None or tree is None or node_id not in plan.nodes:
                return
            self.selected = node_id
            self.tree.highlight(node_id)
            if show_world:
                self._show_world(plan, node_id)
            parent = tree.parent.get(node_id)
            self.events.publish(NodeSelected(node_id, plan.nodes[node_id], parent))

    def clicked(self, node_id: str) -> None:
        """A node clicked in the tree (or found): selected at once, its bench
        drawn a moment later unless another node was selected meanwhile."""
        self.select(node_id, show_world=False)
        with self._lock:
            if self.selected != node_id:
                return
            self._cancel_soon()
            self._soon = threading.Timer(BENCH_AFTER_S, self._bench_if_selected, (node_id,))
            self._soon.daemon = True
            self._soon.start()

    def _bench_if_selected(self, node_id: str) -> None:
        with self._lock:
            if self.selected == node_id and self.plan is not None:
                self._show_world(self.plan, node_id)

    def _cancel_soon(self) -> None:
        if self._soon is not None:
            self._soon.cancel()
            self._soon = None

    def go_to(
        self, node_id: str, *, show_world: bool = True, path: tuple[Step, ...] | None = None
    ) -> None:
        """Open every collapsed ancestor of `node_id`, then select it; with `path`, the
        run's steps are marked in the same picture (one drawing per step, not two)."""
        if self.tree.tree is not None and node_id in self.tree.tree.depth:
            self.tree.expand_to(node_id)
        if path is not None:
            self.tree.show_path(path, node_id, redraw=False)
        self.select(node_id, show_world=show_world)

    def toggle(self, node_id: str) -> None:
        self.tree.toggle(node_id)
        self.tree.highlight(node_id)

    def show_path(self, path: tuple[Step, ...], current: str | None) -> None:
        self.tree.show_path(path, current)

    def show_world(self, node_id: str) -> None:
        """The bench as `node_id` leaves it (after an arm's motion has been played)."""
        with self._lock:
            if self.plan is not None:
                self._show_world(self.plan, node_id)

    def _show_world(self, plan: Plan, node_id: str) -> None:
        """The bench at `node_id` (node_world.py), by the path the tree marks now."""
        tree = self.tree.tree
        if tree is None or node_id not in tree.depth:
            return
        self._cancel_soon()  # whatever was to come is older than this
        world = node_world(plan.nodes, tree, node_id, self.tree.marks.path, self.bench.boxes,
                           human_edge_x=self.bench.human_edge_x)  # fmt: skip
        self.bench.show(world)
        self.current_arms = world.arms
        self.bench_at = node_id

    def arms(self) -> dict[str, list[float]]:
        return dict(self.current_arms)

    def show_arms(self, arms: Mapping[str, list[float]]) -> None:
        self.bench.show_arms(dict(arms))
