"""What every page shows: the bench in 3D, the plan tree in its panel, the selection.

The `Screen` is the panels' `Stage` (stage.py). Planning, executions, reviews
and clicks reach it from different threads, so one lock keeps the plan, the
tree and the selection in step; selecting a node is announced on `Events`
(`NodeSelected`) and showing or dropping a complete plan too (`PlanChanged`).

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
from app.dashboard.stage import Events, ExecutionFinished, NodeSelected, PlanChanged
from app.dashboard.tree_svg import Step
from app.dashboard.tree_view import TreeView
from app.execution.world import world_at
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


class Screen:
    """The stage of the dashboard. The tree panel is built in the GUI container
    current when the screen is made (the server's "Plan tree" tab); the bench's
    models are loaded apart (`bench.load_models`), after the panels, so a new
    page can be used first."""

    def __init__(self, server: viser.ViserServer, events: Events) -> None:
        self.events = events
        self.server = server
        self.bench = BenchScene(server, load_models=False)
        self.tree = TreeView(server.gui, self.select)
        self.plan: Plan | None = None
        self.scenario: Scenario | None = None
        self.selected: str | None = None
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
            self.plan = None
            self.selected = None
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
            lineage = tree.lineage(node_id)
            self.tree.highlight(node_id)
            if show_world:
                self._show_world(plan, lineage)
            parent = lineage[-2] if len(lineage) > 1 else None
            self.events.publish(NodeSelected(node_id, plan.nodes[node_id], parent))

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
            if self.plan is not None and self.tree.tree is not None:
                self._show_world(self.plan, self.tree.tree.lineage(node_id))

    def _show_world(self, plan: Plan, lineage: list[str]) -> None:
        world = world_at(
            plan.nodes, lineage, self.bench.boxes, human_edge_x=self.bench.human_edge_x
        )
        self.bench.show(world)
        self.current_arms = world.arms

    def arms(self) -> dict[str, list[float]]:
        return dict(self.current_arms)

    def show_arms(self, arms: Mapping[str, list[float]]) -> None:
        self.bench.show_arms(dict(arms))
