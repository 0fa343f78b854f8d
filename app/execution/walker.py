"""Running a plan: one branch, from the root to a leaf.

The `Executor` walks the plan node by node. An actuation node emits a motion
event (the arm's joint path); a communication node without outcomes emits
what the robot says; a node with outcomes (sensing, or a question to the
human) asks the `OutcomeSource` which one happened and follows that branch.
Every step is an `ExecutionEvent` handed to the listeners (the session store,
the dashboard, a log). A `narrator`, when given, is called at every
communication node as the executor reaches it, before its event (and before a
question is asked): it speaks the sentence and returns what to keep of that
(the text, the engine), which the event carries as evidence. It runs
synchronously (`run()`) or in its own thread (`start()`), and can be paused,
single-stepped, resumed and aborted from any thread.

Slots follow the world (planner.feasibility.slot_map): outcomes speak the plan's
names, and the executor keeps a slot map from those names to the world's points.
When the human attaches at another free slot than the branch names (an outcome
with a `slot`), or the robot's arm cannot reach the one its attach names, the
executor keeps to the branch and updates the map; a motion whose node assumes
another map (its `slots`) goes to `retarget` (the motion planner), so the event
carries the motion the robot really makes, and its evidence keeps it.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import replace
from typing import Protocol

from app.execution.events import (
    INTERRUPTED,
    REPAIR,
    Evidence,
    ExecutionEvent,
    Outcome,
    OutcomeError,
    OutcomeSource,
    Repair,
    RepairFailed,
    Result,
    describe,
)
from app.execution.surprises import Surprise, SurpriseError
from planner.feasibility.scene import Site
from planner.feasibility.slot_map import ROBOT_SLOT, SLOTS, SlotError, SlotMap, robot_choice
from planner.plan.model import Motion, Plan, PlanNode
from planner.vocabulary import Action, Hands, SenseHumanAttachingWhere

Listener = Callable[[ExecutionEvent], None]
# Plans again after a surprise at a node: the repair, and the new plan's hash.
Repairing = Callable[[PlanNode, Surprise], tuple[Repair, str]]
# Speaks a communication node's sentence; what it returns is kept with the event.
Narrator = Callable[[str, PlanNode], Evidence | None]


class Retarget(Protocol):
    """The motion planner behind re-targeting (app.execution.retargeting.MotionRetargeter)."""

    def motion(
        self, action: Action, state: list[str], real: Action, real_state: list[str]
    ) -> Motion | None:
        """The motion of `real` in `real_state` (the branch's `action` in `state`, at the
        world's slots); None when the branch's stored motion goes there already."""
        ...

    def reaches(self, arm: str, site: Site) -> bool:
        """Can `arm` work at `site`?"""
        ...

    def close(self) -> None: ...


def merged(first: Evidence | None, second: Evidence | None) -> Evidence | None:
    """Both evidences in one: `second`'s detail wins a shared key, its picture if any."""
    if first is None or second is None:
        return first or second
    return Evidence({**first.detail, **second.detail}, second.jpeg or first.jpeg)


class _Aborted(Exception):
    pass


class Executor:
    """Walks `plan` from its root, asking `source` at every branching node.

    `step_delay` seconds pass after every step but the last (the time a motion
    or a sentence takes). Controls (`pause`, `resume`, `step`, `abort`) are
    safe from any thread; `result` is set once the walk ends.
    """

    def __init__(
        self,
        plan: Plan,
        source: OutcomeSource,
        listeners: Iterable[Listener] = (),
        step_delay: float = 0.0,
        max_steps: int = 10_000,
        narrator: Narrator | None = None,
        repairing: Repairing | None = None,
        retarget: Retarget | None = None,
    ) -> None:
        self.plan = plan
        self.retarget = retarget
        self.slots = SlotMap(plan.facts)
        self.narrator = narrator
        self.repairing = repairing
        self.nodes = plan.nodes
        self.source = source
        self.listeners = list(listeners)
        self.step_delay = step_delay
        self.max_steps = max_steps
        self.result: Result | None = None
        self.error: BaseException | None = None
        self.current: str | None = None  # the node being run
        self.events: list[ExecutionEvent] = []
        self._cond = threading.Condition()
        self._paused = False
        self._credits = 0  # steps allowed while paused
        self._aborted = False
        self._stopped_by: str | None = None  # why the walk was interrupted
        self._thread: threading.Thread | None = None
        self._done = threading.Event()

    # -- controls (any thread) ------------------------------------------------

    def pause(self) -> None:
        with self._cond:
            self._paused = True
            self._credits = 0
            self._cond.notify_all()

    def resume(self) -> None:
        with self._cond:
            self._paused = False
            self._credits = 0
            self._cond.notify_all()

    def step(self) -> None:
        """Single-step mode: pauses, and lets exactly one more node run."""
        with self._cond:
            self._paused = True
            self._credits += 1
            self._cond.notify_all()

    def abort(self) -> None:
        with self._cond:
            self._aborted = True
            self._cond.notify_all()
        interrupt = getattr(self.source, "interrupt", None)
        if callable(interrupt):
            interrupt()

    def interrupt(self, reason: str) -> None:
        """Stops the walk as `interrupted` (the program is stopping, not the operator),
        with a last event saying `reason`."""
        with self._cond:
            self._stopped_by = reason
        self.abort()

    @property
    def paused(self) -> bool:
        with self._cond:
            return self._paused

    @property
    def aborted(self) -> bool:
        with self._cond:
            return self._aborted

    @property
    def done(self) -> bool:
        return self._done.is_set()

    # -- running --------------------------------------------------------------

    def start(self) -> threading.Thread:
        """Runs in a daemon thread; `wait()` for the result."""
        if self._thread is not None:
            raise RuntimeError("this execution has already started")
        self._thread = threading.Thread(target=self._run_quietly, name="executor", daemon=True)
        self._thread.start()
        return self._thread

    def wait(self, timeout: float | None = None) -> Result | None:
        self._done.wait(timeout)
        return self.result

    def _run_quietly(self) -> None:
        try:
            self.run()
        except BaseException as err:  # kept for the caller; the thread must not die loudly
            self.error = err

    def run(self) -> Result:
        """Walks the plan in this thread and returns how it ended."""
        try:
            result = self._walk()
            with self._cond:
                reason = self._stopped_by
            if result == "aborted" and reason is not None:
                result = "interrupted"
                last = self.events[-1].node if self.events else self.plan.root
                self._emit_stop(last, reason)
            self.result = result
        except BaseException:
            self.result = "aborted"
            raise
        finally:
            self.current = None
            if self.retarget is not None:
                self.retarget.close()  # its check cache, in the thread that used it
            self._done.set()
        return self.result

    def _walk(self) -> Result:
        node_id = self.plan.root
        for _ in range(self.max_steps):
            try:
                self._gate()
            except _Aborted:
                return "aborted"
            node = self.nodes.get(node_id)
            if node is None:
                return "dead-end"
            self.current = node_id
            if node.kind == "goal":
                self._emit(node_id, node, text="The table is assembled.")
                return "goal"
            children = node.children
            if not children:
                self._emit(node_id, node, text="no way on from here")
                return "dead-end"
            options = node.outcomes
            spoken = None
            if self.narrator is not None and node.kind == "communication" and node.say:
                spoken = self.narrator(node_id, node)
            if not options:
                text = node.say if node.kind == "communication" else None
                motion, moved = self._motion(node)
                self._emit(node_id, node, text=text, motion=motion, evidence=merged(spoken, moved))
                next_id = children[0].node
            else:
                try:
                    outcome = self._ask(node_id, node, options)
                except _Aborted:
                    return "aborted"
                outcome = self._point_surprise(node, outcome)
                if outcome.surprise is not None:
                    repaired = self._repair(node_id, node, outcome)
                    if repaired is not None:
                        node_id = repaired
                    continue  # on the new plan's root, or the same node asked again
                slot = self._follow_slot(node_id, node, outcome)
                text = node.say if node.kind == "communication" else outcome.text
                self._emit(
                    node_id,
                    node,
                    outcome=outcome.label,
                    source=outcome.source,
                    confidence=outcome.confidence,
                    text=text or describe(node.action, outcome.label),
                    evidence=merged(merged(spoken, outcome.evidence), slot),
                )
                next_id = next(c.node for c in children if c.outcome == outcome.label)
            try:
                self._sleep(self.step_delay)
            except _Aborted:
                return "aborted"
            node_id = next_id
        return "dead-end"

    def _gate(self) -> None:
        """Waits while paused (unless a single step is allowed); raises when aborted."""
        with self._cond:
            while True:
                if self._aborted:
                    raise _Aborted
                if not self._paused:
                    return
                if self._credits > 0:
                    self._credits -= 1
                    return
                self._cond.wait()

    def _sleep(self, seconds: float) -> None:
        if seconds <= 0:
            if self.aborted:
                raise _Aborted
            return
        deadline = time.monotonic() + seconds
        with self._cond:
            while not self._aborted:
                left = deadline - time.monotonic()
                if left <= 0:
                    return
                self._cond.wait(left)
            raise _Aborted

    def _ask(self, node_id: str, node: PlanNode, options: list[str]) -> Outcome:
        """The source's outcome; asks again while it has no answer, until aborted."""
        while True:
            if self.aborted:
                raise _Aborted
            outcome = self.source.choose(node_id, node, options)
            if outcome is None:
                # No answer yet (a click timed out): ask again, unless aborted.
                time.sleep(0.01)
                continue
            if outcome.surprise is not None:
                return outcome
            if outcome.label not in options:
                raise OutcomeError(
                    f"'{outcome.label}' is not an outcome of {node.action} at {node_id}"
                )
            return outcome

    def _follow_slot(self, node_id: str, node: PlanNode, outcome: Outcome) -> Evidence | None:
        """Maps the branch's point onto the one the human used (both in the plan's names:
        the map says where that is in the world), if they differ."""
        if outcome.slot is None or outcome.slot == outcome.label:
            return None
        action = node.action
        if not isinstance(action, SenseHumanAttachingWhere):
            raise OutcomeError(f"{node.action} at {node_id} has no slot to observe")
        if outcome.slot not in self.slot_choices(node):
            raise OutcomeError(
                f"{node.action} at {node_id}: {action.onto} has no free point {outcome.slot} "
                f"(free: {', '.join(self.slot_choices(node))})"
            )
        real = self.slots.real(action.onto, outcome.slot)
        try:
            self.slots.follow(action.onto, outcome.label, real, node.state)
        except SlotError as err:
            raise OutcomeError(f"{node.action} at {node_id}: {err}") from None
        slot = {"onto": action.onto, "branch": outcome.label, "used": outcome.slot, "real": real}
        return Evidence({"slot": slot, "slots": self.slots.to_json()})

    def _point_surprise(self, node: PlanNode, outcome: Outcome) -> Outcome:
        """Where the plan puts parts by points (`points = "each"`, facts
        `pointsChecked`), its later motions and arms count on the point the branch
        names: the human's attach at another one is a surprise to plan again from,
        not a name to map (only when this execution can plan again)."""
        action = node.action
        if (
            self.repairing is None
            or outcome.slot is None
            or outcome.slot == outcome.label
            or not isinstance(action, SenseHumanAttachingWhere)
            or f"pointsChecked({action.onto})" not in self.plan.facts
            or outcome.slot not in self.slot_choices(node)  # refused as before
        ):
            return outcome
        real = self.slots.real(action.onto, outcome.slot)
        return replace(outcome, surprise=Surprise("attach", (action.part, action.onto, real)))

    def slot_choices(self, node: PlanNode) -> list[str]:
        """Where the human can attach at a humanAttachingWhere node: the free points, in
        the plan's names."""
        action = node.action
        if not isinstance(action, SenseHumanAttachingWhere):
            return []
        taken = {point for onto, point in Hands.of(node.state).attached.values()
                 if onto == action.onto}  # fmt: skip
        return [p for p in self.slots.points.get(action.onto, []) if p not in taken]

    def slot_label(self, node: PlanNode, options: Sequence[str], point: str) -> str:
        """The outcome label for attaching at `point`: the point itself if the node has
        that outcome, else its first (and the executor follows `point`)."""
        return point if point in options else options[0]

    def _motion(self, node: PlanNode) -> tuple[Motion | None, Evidence | None]:
        """The node's stored motion where the world's slots are those it assumes; else
        re-targeted to the world's, with evidence saying so and keeping the new motion."""
        if node.motion is None or node.action is None:
            return node.motion, None
        extra = node.model_extra or {}
        chosen = None
        if self.retarget is not None:
            chosen = robot_choice(self.slots, node.action, node.state, self.retarget.reaches)
        elif isinstance(extra.get(ROBOT_SLOT), dict):
            self._take_plans_choice(extra[ROBOT_SLOT], node.state)  # none to ask: the plan's
        planned = SlotMap(self.plan.facts, extra.get(SLOTS))
        if planned == self.slots:
            return node.motion, None
        assumed = planned.action(node.action), planned.state(node.state)
        real = self.slots.action(node.action), self.slots.state(node.state)
        if assumed[0] == real[0] and sorted(assumed[1]) == sorted(real[1]):
            return node.motion, None
        detail: dict[str, object] = {"slots": self.slots.to_json(), "real_action": str(real[0])}
        if chosen:
            detail["robot_slot"] = chosen
        if self.retarget is None:
            return node.motion, Evidence({**detail, "retargeted": "no motion planner"})
        motion = self.retarget.motion(*assumed, *real)
        if motion is None:
            return node.motion, None
        return motion, Evidence({**detail, "retargeted": motion.model_dump()})

    def _take_plans_choice(self, choice: dict[str, str], state: list[str]) -> None:
        """The robot's slot choice the plan made here, where the world lets it."""
        onto, branch, real = choice.get("onto"), choice.get("branch"), choice.get("real")
        if onto is None or branch is None or real is None:
            return
        if real in self.slots.free(onto, state) and real in self.slots.points.get(onto, []):
            self.slots.follow(onto, branch, real, state)

    def _repair(self, node_id: str, node: PlanNode, outcome: Outcome) -> str | None:
        """Plans again from what was observed and switches to that plan; its root, or
        None (no repair possible: the node is asked again)."""
        surprise = outcome.surprise
        assert surprise is not None
        try:
            if self.repairing is None:
                raise RepairFailed("this execution cannot plan again")
            # In the plan's names, as the surprise is: the new plan keeps them, and the
            # slot map goes on saying where they are in the world.
            repair, digest = self.repairing(node, surprise)
        except (RepairFailed, SurpriseError) as err:
            self._emit(node_id, node, source=outcome.source, text=f"surprise ignored: {err}")
            return None
        detail = {
            "surprise": str(surprise),
            "observed": sorted(repair.observed),
            "plan": digest,
            "plan_s": round(repair.seconds, 3),
        }
        event = ExecutionEvent(
            seq=len(self.events), time=time.time(), node=node_id,
            action=None if node.action is None else str(node.action), kind=REPAIR,
            source=outcome.source, text=repair.words, evidence=Evidence(detail),
            plan=repair.plan,
        )  # fmt: skip
        self.events.append(event)
        for listener in self.listeners:
            listener(event)
        self.plan = repair.plan
        self.nodes = repair.plan.nodes
        return repair.plan.root

    def _emit_stop(self, node_id: str, reason: str) -> None:
        """The last event of an interrupted walk: where it stood, and why it stopped."""
        event = ExecutionEvent(
            seq=len(self.events), time=time.time(), node=node_id, action=None,
            kind=INTERRUPTED, text=reason,
        )  # fmt: skip
        self.events.append(event)
        for listener in self.listeners:
            listener(event)

    def _emit(
        self,
        node_id: str,
        node: PlanNode,
        *,
        outcome: str | None = None,
        source: str | None = None,
        confidence: float | None = None,
        text: str | None = None,
        motion: Motion | None = None,
        evidence: Evidence | None = None,
    ) -> None:
        event = ExecutionEvent(
            seq=len(self.events),
            time=time.time(),
            node=node_id,
            action=None if node.action is None else str(node.action),
            kind=node.kind,
            outcome=outcome,
            source=source,
            confidence=confidence,
            text=text,
            motion=motion,
            evidence=evidence,
        )
        self.events.append(event)
        for listener in self.listeners:
            listener(event)
