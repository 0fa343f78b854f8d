"""How the dashboard's panels are composed: a narrow stage and typed events.

The pattern, for every panel (scenario, plan, selected node, view, execution,
review, live camera, speech):

- `server.py` only composes: it creates the viser server, the `Screen`
  (screen.py: the bench scene, the plan tree, the plan shown and the selected
  node), the `Events` bus and the panels. A panel receives the GUI API to build
  its controls in, the `Stage` it may drive, and the `Events` bus; never the
  dashboard, the server or another panel.
- `Stage` is all a panel may do to what is on screen: show a scenario's bench,
  show a plan (complete or growing), select a node or go to it, fold a branch,
  show the world at a node, move the arms, mark an execution's path on the
  tree, read the current plan and scenario.
- Panels tell each other what happened only through `Events`: typed,
  documented messages (as viser's own messages are), delivered synchronously
  to the subscribers in the order they subscribed. No panel changes another
  panel's state, and no panel polls: sources call back when something changes.
- A panel's own rules (what a choice shows, what a line says, when a button is
  off) are plain functions or small classes beside it, tested without viser.
- Every panel has `close()`; the dashboard closes them all when it stops.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Protocol, TypeVar

from app.dashboard.tree_svg import Step
from app.execution.events import ExecutionEvent, OutcomeSource, Result
from planner.plan.model import Plan, PlanNode
from planner.scenario.model import Scenario


class Stage(Protocol):
    """What a panel may do to the bench, the tree and the selection."""

    def current_plan(self) -> Plan | None:
        """The plan on screen, complete or still being built (`plan.partial`)."""
        ...

    def current_scenario(self) -> Scenario | None:
        """The scenario loaded now (the last good one)."""
        ...

    def show_plan(self, plan: Plan) -> None:
        """Draw a complete plan in the tree and select its root."""
        ...

    def go_to(
        self, node_id: str, *, show_world: bool = True, path: tuple[Step, ...] | None = None
    ) -> None:
        """Open the tree to a node and select it; the bench as the node leaves it; with
        `path`, an execution's (or a review's) steps so far, `node_id` running now."""
        ...

    def show_world(self, node_id: str) -> None:
        """The bench as `node_id` leaves it (after an arm's motion has been played)."""
        ...

    def arms(self) -> dict[str, list[float]]:
        """Each arm's joints as shown now."""
        ...

    def show_arms(self, arms: Mapping[str, list[float]]) -> None:
        """Move the drawn arms (a frame of a played motion)."""
        ...

    def select(self, node_id: str, *, show_world: bool = True) -> None:
        """Select a node as the tree shows it (a node in a folded branch stays hidden)."""
        ...

    def toggle(self, node_id: str) -> None:
        """Fold the branch below a node in the tree, or unfold it."""
        ...

    def show_scenario(self, scenario: Scenario) -> None:
        """Draw another bench (a scenario opened or edited); the shown plan, made
        for the scenario before, is dropped."""
        ...

    def show_growing(self, plan: Plan) -> None:
        """Draw the part of a plan planned so far (`plan.partial`), selecting nothing."""
        ...

    def drop_plan(self) -> None:
        """No plan is shown any more (planning again): nobody may execute it."""
        ...

    def show_path(self, path: tuple[Step, ...], current: str | None) -> None:
        """Mark an execution's (or a review's) steps so far on the tree; `current`
        is the node running now (None: the run ended)."""
        ...


# -- messages -------------------------------------------------------------------


@dataclass(frozen=True)
class PlanChanged:
    """A plan was shown (`plan`), or the shown one was dropped (None: the scenario
    changed, or planning started again)."""

    plan: Plan | None


@dataclass(frozen=True)
class ScenarioChanged:
    """Another scenario was opened, or the open one was edited (`edited`): other
    parts, another bench (`scenario`)."""

    scenario: Scenario
    edited: bool = False


@dataclass(frozen=True)
class Planned:
    """Planning in the page finished with `plan`, which is shown now."""

    plan: Plan


@dataclass(frozen=True)
class NodeSelected:
    """`node_id` (`node` of the shown plan) was selected; `parent` is the node above
    it in the tree (None at the root)."""

    node_id: str
    node: PlanNode
    parent: str | None


@dataclass(frozen=True)
class ExecutionStarted:
    """An execution of the shown plan started, recorded as `session_id`."""

    session_id: int


@dataclass(frozen=True)
class ExecutionFinished:
    """The execution recorded as `session_id` ended with `result` (goal, aborted, ...)."""

    session_id: int
    result: Result


class CameraAnswers(Protocol):
    """A camera that can answer an execution's sensing nodes."""

    name: str

    def for_execution(
        self, plan: Plan, intent: OutcomeSource
    ) -> tuple[OutcomeSource, list[Callable[[ExecutionEvent], None]]]:
        """The answers for one run of `plan` and the listeners to add; `intent` is
        where a simulated human learns what to do (the clicks)."""
        ...


@dataclass(frozen=True)
class CameraChanged:
    """A camera started (`camera`: it answers sensing nodes from now on) or stopped
    or is missing (None: clicks answer)."""

    camera: CameraAnswers | None


@dataclass(frozen=True)
class CameraSeen:
    """The running camera's latest view, as its panel shows it (a few times a
    second): part codes `seen` of the `of` the scenario marks, and whether what
    it believes still `settling`."""

    seen: int
    of: int
    settling: bool


Message = (
    PlanChanged
    | ScenarioChanged
    | Planned
    | NodeSelected
    | ExecutionStarted
    | ExecutionFinished
    | CameraChanged
    | CameraSeen
)
M = TypeVar(
    "M",
    PlanChanged,
    ScenarioChanged,
    Planned,
    NodeSelected,
    ExecutionStarted,
    ExecutionFinished,
    CameraChanged,
    CameraSeen,
)


class Events:
    """Synchronous publish/subscribe of typed messages between panels."""

    def __init__(self) -> None:
        self._handlers: dict[type[Message], list[Callable[[Message], None]]] = {}
        self._lock = threading.Lock()

    def subscribe(self, kind: type[M], handler: Callable[[M], None]) -> None:
        with self._lock:
            self._handlers.setdefault(kind, []).append(handler)  # type: ignore[arg-type]

    def publish(self, message: Message) -> None:
        with self._lock:
            handlers = list(self._handlers.get(type(message), ()))
        for handler in handlers:
            handler(message)

    def clear(self) -> None:
        with self._lock:
            self._handlers.clear()
