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
single-stepped, resumed and aborted from any thread (its `RunGate`); with
`waypoint_s` an arm motion takes time and a pause stops it at its next
waypoint. With a `robot` (`app.execution.robot_drive`), a robot behind a link
makes each motion before its event is recorded, and a pause cancels it at once. A source with
`attach`/`detach` is handed the executor while it runs (the voice pauses it on
"stop" and keeps the dialogue's turns with `note`, from its own thread).

Every event has a `start` and an `end` from the `timeline` (`app.execution.timing`):
the wall clock by default, or a simulated one in which a request starts the
simulated human's own action (an event of kind `human`) while the robot goes on.

Slots follow the world: what the human's and the robot's slot choices change
(the slot map, re-targeted motions, a surprise where the plan counts on a point)
is `app.execution.slots`, which the walk asks once per node.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import replace
from typing import NamedTuple

from app.execution.events import (
    INTERRUPTED,
    REPAIR,
    ROBOT_FAULT,
    AnswerSource,
    DialogueKind,
    EventKind,
    ExecutionEvent,
    Outcome,
    OutcomeError,
    OutcomeSource,
    Repair,
    RepairFailed,
    Result,
    Waypoint,
    describe,
)
from app.execution.evidence import Evidence, Replanned, RobotMotion, merged
from app.execution.robot_drive import RobotDriver, RobotStopped
from app.execution.run_gate import Aborted, RunGate
from app.execution.slots import Retarget, Slots
from app.execution.surprises import Surprise, SurpriseError
from app.execution.timing import Timeline, WallTimeline
from planner.plan.model import Motion, Plan, PlanNode

__all__ = ["INTERRUPTED", "Executor", "Listener", "Narrator", "Repairing", "Retarget", "Waypoint"]

Listener = Callable[[ExecutionEvent], None]
# Plans again after a surprise at a node: the repair, and the new plan's hash.
Repairing = Callable[[PlanNode, Surprise], tuple[Repair, str]]
# Speaks a communication node's sentence; what it returns is kept with the event.
Narrator = Callable[[str, PlanNode], Evidence | None]


def _event_kind(node: PlanNode) -> EventKind:
    """A node's kind as an event's: a node still open (only in a partial plan, which is
    never executed) is a dead end."""
    if node.kind == "open":
        raise OutcomeError("a partial plan cannot be executed")
    return node.kind


# A walk longer than this is a loop no plan should have: it ends as a dead end.
MAX_STEPS = 10_000


class _Next(NamedTuple):
    """Where the walk goes after a node; `stepped` False when no step of the plan was
    taken (a surprise: the repaired plan's root, or the same node asked again)."""

    node: str
    stepped: bool = True


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
        *,
        step_delay: float = 0.0,
        narrator: Narrator | None = None,
        repairing: Repairing | None = None,
        retarget: Retarget | None = None,
        waypoint_s: float = 0.0,
        timeline: Timeline | None = None,
        robot: RobotDriver | None = None,
    ) -> None:
        self.plan = plan
        # The robot behind a link that makes the motions (None: they are only drawn).
        self.robot = robot
        self.timeline: Timeline = timeline if timeline is not None else WallTimeline()
        self.slots = Slots(plan, retarget, replans=repairing is not None)
        self.narrator = narrator
        self.repairing = repairing
        self.nodes = plan.nodes
        self.source = source
        self.listeners = list(listeners)
        self.step_delay = step_delay
        # Seconds an arm takes from one waypoint of its path to the next (0: a motion
        # takes no time); a pause stops the arm at its next waypoint.
        self.waypoint_s = waypoint_s
        self.waypoint: Waypoint | None = None  # the arm motion under way
        self.result: Result | None = None
        self.error: BaseException | None = None
        self.current: str | None = None  # the node being run
        self.events: list[ExecutionEvent] = []
        self.gate = RunGate()
        self._thread: threading.Thread | None = None
        self._done = threading.Event()
        self._recording = threading.RLock()  # events come from the walk and the voice
        attach = getattr(source, "attach", None)
        if callable(attach):
            attach(self)  # a source that pauses and records (the voice) is told who runs

    # -- controls (any thread) ------------------------------------------------

    def pause(self, why: str | None = None, evidence: Evidence | None = None) -> None:
        """Pauses before the next node (an arm motion under way stops at its next
        waypoint; a robot's, at once). `why`, when given (the human said "stop"), is
        kept as a `paused` event, with the `evidence` of what was heard."""
        was = self.gate.pause()
        if self.robot is not None:
            self.robot.cancel()
        self._hold_source(True)
        if why is not None and not was:
            self.note("paused", why, "voice", evidence)

    def resume(self, why: str | None = None, evidence: Evidence | None = None) -> None:
        """Goes on; `why`, when given, is kept as a `resumed` event (as for `pause`)."""
        was = self.gate.resume()
        self._hold_source(False)
        if why is not None and was:
            self.note("resumed", why, "voice", evidence)

    def _hold_source(self, held: bool) -> None:
        # A live voice takes no answer while paused, whoever paused or resumed.
        hold = getattr(self.source, "hold", None)
        if callable(hold):
            hold(held)

    def step(self) -> None:
        """Single-step mode: pauses, and lets exactly one more node run."""
        self.gate.step()

    def abort(self) -> None:
        self.gate.abort()
        if self.robot is not None:
            self.robot.cancel()
        interrupt = getattr(self.source, "interrupt", None)
        if callable(interrupt):
            interrupt()

    def interrupt(self, reason: str) -> None:
        """Stops the walk as `interrupted` (the program is stopping, not the operator),
        with a last event saying `reason`."""
        self.gate.stop(reason)
        self.abort()

    @property
    def paused(self) -> bool:
        return self.gate.paused

    @property
    def aborted(self) -> bool:
        return self.gate.aborted

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
            reason = self.gate.stopped_by
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
            self.slots.close()  # the motion planner's check cache, in the thread that used it
            detach = getattr(self.source, "detach", None)
            if callable(detach):
                detach(self)  # the voice stops listening
            self._done.set()
        return self.result

    def _walk(self) -> Result:
        node_id = self.plan.root
        try:
            for _ in range(MAX_STEPS):
                self.gate.before_node()
                node = self.nodes.get(node_id)
                if node is None:
                    return "dead-end"
                self.current = node_id
                after = self._step(node_id, node)
                if isinstance(after, str):
                    return after
                if after.stepped:
                    self.gate.sleep(self.step_delay)
                node_id = after.node
        except Aborted:
            return "aborted"
        return "dead-end"

    def _step(self, node_id: str, node: PlanNode) -> _Next | Result:
        """Runs one node: where the walk goes next, or how it ended."""
        self.timeline.begin(node)
        if node.kind == "goal":
            self._emit(node_id, node, text="The table is assembled.")
            return "goal"
        if not node.children:
            self._emit(node_id, node, text="no way on from here")
            return "dead-end"
        spoken = None
        if self.narrator is not None and node.kind == "communication" and node.say:
            spoken = self.narrator(node_id, node)
        if node.outcomes:
            return self._branching_step(node_id, node, spoken)
        return self._deterministic_step(node_id, node, spoken)

    def _deterministic_step(self, node_id: str, node: PlanNode, spoken: Evidence | None) -> _Next:
        """An action with one way on: the motion the robot makes (at the world's slots),
        or what it says."""
        text = node.say if node.kind == "communication" else None
        step = self.slots.at(node_id, node, None)
        evidence = merged(spoken, step.evidence)
        if step.motion is not None and self.robot is not None:
            # The robot moves first: its event says what it did, when it is done.
            moved = Evidence(robot=self._drive(node_id, node, step.motion))
            evidence = merged(evidence, moved)
        self._emit(node_id, node, text=text, motion=step.motion, spoken=spoken, evidence=evidence)
        if step.motion is not None and self.waypoint_s > 0 and self.robot is None:
            self._move(node_id, step.motion)
        return _Next(node.children[0].node)

    def _drive(self, node_id: str, node: PlanNode, motion: Motion) -> RobotMotion:
        """The robot makes `motion`; a fault it cannot get past stops the walk."""
        assert self.robot is not None

        def fault(record: RobotMotion) -> None:
            event = ExecutionEvent(0, 0.0, node_id, node.action, ROBOT_FAULT, text=record.detail)
            self._record(replace(event, evidence=Evidence(robot=record)))

        try:
            return self.robot.drive(motion, node.action, self.gate.within_node, fault)
        except RobotStopped:
            raise Aborted from None

    def _branching_step(self, node_id: str, node: PlanNode, spoken: Evidence | None) -> _Next:
        """A node with outcomes: the one the source says happened, followed (at the
        world's slots); a surprise plans again."""
        outcome = self._ask(node_id, node, node.outcomes)
        step = self.slots.at(node_id, node, outcome)
        surprise = step.surprise or outcome.surprise
        if surprise is not None:
            repaired = self._repair(node_id, node, outcome.source, surprise)
            return _Next(node_id if repaired is None else repaired, stepped=False)
        text = node.say if node.kind == "communication" else outcome.text
        self._emit(
            node_id,
            node,
            spoken=spoken,
            outcome=outcome.label,
            source=outcome.source,
            confidence=outcome.confidence,
            text=text or describe(node.action, outcome.label),
            evidence=merged(merged(spoken, outcome.evidence), step.evidence),
        )
        return _Next(next(c.node for c in node.children if c.outcome == outcome.label))

    def _move(self, node_id: str, motion: Motion) -> None:
        """The arm goes through its path, `waypoint_s` a waypoint; paused, it stops at
        the waypoint it reaches next (a single step's motion goes to its end)."""
        count = len(motion.path)
        for index in range(count):
            self.waypoint = Waypoint(node_id, index, count)
            self.gate.within_node()
            if index + 1 < count:
                self.gate.sleep(self.waypoint_s)
        self.waypoint = None

    def _ask(self, node_id: str, node: PlanNode, options: list[str]) -> Outcome:
        """The source's outcome; asks again while it has no answer, until aborted."""
        while True:
            if self.aborted:
                raise Aborted
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

    # -- slots (app.execution.slots); a click source asks the executor

    def slot_choices(self, node: PlanNode) -> list[str]:
        """Where the human can attach at a humanAttachingWhere node, in the plan's names."""
        return self.slots.slot_choices(node)

    def slot_label(self, node: PlanNode, options: Sequence[str], point: str) -> str:
        """The outcome label for attaching at `point` (the walk follows `point`)."""
        return self.slots.slot_label(node, options, point)

    def _repair(
        self, node_id: str, node: PlanNode, source: AnswerSource, surprise: Surprise
    ) -> str | None:
        """Plans again from what `source` observed and switches to that plan; its root, or
        None (no repair possible: the node is asked again)."""
        try:
            if self.repairing is None:
                raise RepairFailed("this execution cannot plan again")
            # In the plan's names, as the surprise is: the new plan keeps them, and the
            # slot map goes on saying where they are in the world.
            repair, digest = self.repairing(node, surprise)
        except (RepairFailed, SurpriseError) as err:
            self._emit(node_id, node, source=source, text=f"surprise ignored: {err}")
            return None
        replanned = Replanned(
            str(surprise), tuple(sorted(repair.observed)), digest, round(repair.seconds, 3)
        )
        self._record(
            ExecutionEvent(
                0, 0.0, node_id, node.action, REPAIR, source=source, text=repair.words,
                evidence=Evidence(replanned=replanned), plan=repair.plan,
            )
        )  # fmt: skip
        self.plan = repair.plan
        self.nodes = repair.plan.nodes
        self.slots.switch_plan(repair.plan)
        return repair.plan.root

    def _emit_stop(self, node_id: str, reason: str) -> None:
        """The last event of an interrupted walk: where it stood, and why it stopped."""
        self._record(ExecutionEvent(0, 0.0, node_id, None, INTERRUPTED, text=reason))

    def note(
        self,
        kind: DialogueKind,
        text: str,
        source: AnswerSource | None = None,
        evidence: Evidence | None = None,
        node_id: str | None = None,
    ) -> ExecutionEvent:
        """Keeps a turn of the dialogue (from any thread) at `node_id`, by default the
        node being run (else the last one, else the root)."""
        if node_id is None:
            last = self.events[-1].node if self.events else self.plan.root
            node_id = self.current or last
        event = ExecutionEvent(0, 0.0, node_id, None, kind, source=source, text=text)
        return self._record(replace(event, evidence=evidence))

    def _record(self, event: ExecutionEvent) -> ExecutionEvent:
        """`event`, numbered and timed (now, when it has no times of its own), kept and
        told to the listeners in order."""
        with self._recording:
            now = self.timeline.now()
            start = now if event.start is None else event.start
            end = now if event.end is None else event.end
            event = replace(event, seq=len(self.events), time=end, start=start, end=end)
            self.events.append(event)
            for listener in self.listeners:
                listener(event)
        return event

    def _emit(
        self,
        node_id: str,
        node: PlanNode,
        *,
        spoken: Evidence | None = None,
        outcome: str | None = None,
        source: AnswerSource | None = None,
        confidence: float | None = None,
        text: str | None = None,
        motion: Motion | None = None,
        evidence: Evidence | None = None,
    ) -> None:
        """Records the step at `node`, timed from its `begin`, then the human's action it
        starts, if any."""
        start, end = self.timeline.finish(node, spoken, motion)
        self._record(
            ExecutionEvent(
                0, 0.0, node_id, node.action, _event_kind(node), outcome=outcome, source=source,
                confidence=confidence, text=text, motion=motion, evidence=evidence,
                start=start, end=end,
            )
        )  # fmt: skip
        human = self.timeline.human_event(node_id, node, outcome, end)
        if human is not None:
            self._record(human)
