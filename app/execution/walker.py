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
a simulated clock by default, in which a request starts the simulated human's own
action (an event of kind `human`) while the robot goes on, or the wall clock, on
which a step ends once it has taken its real time (the motion made by the robot,
played by a `player`, or waited for; the line spoken; the answer given) and a
source that observes the human keeps its actions with `observe_human`.

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

from app.execution.event_log import EventLog
from app.execution.events import (
    INTERRUPTED,
    REPAIR,
    ROBOT_FAULT,
    AnswerSource,
    Attachable,
    EventKind,
    ExecutionEvent,
    Holdable,
    Interruptible,
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
from app.execution.timing import SimulatedTimeline, Timeline, motion_seconds
from planner.plan.model import Motion, Plan, PlanNode

__all__ = ["INTERRUPTED", "Executor", "Listener", "Narrator", "Repairing", "Retarget", "Waypoint"]

Listener = Callable[[ExecutionEvent], None]
# Plans again after a surprise at a node: the repair, and the new plan's hash.
Repairing = Callable[[PlanNode, Surprise], tuple[Repair, str]]
# Speaks a communication node's sentence; what it returns is kept with the event.
Narrator = Callable[[str, PlanNode], Evidence | None]
# Plays an arm motion (node id, motion) while the walk waits: the dashboard's
# animation of the drawn arm. It returns once the motion has been shown, with the
# wall time its first frame was (None: not known).
Player = Callable[[str, Motion], float | None]


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
        player: Player | None = None,
    ) -> None:
        self.plan = plan
        # The robot behind a link that makes the motions (None: they are only drawn).
        self.robot = robot
        self.player = player
        # Without a clock of its own a walk is simulated: fast, the same every time.
        self.timeline: Timeline = timeline if timeline is not None else SimulatedTimeline(0)
        self.slots = Slots(plan, retarget, replans=repairing is not None)
        self.narrator = narrator
        self.repairing = repairing
        self.nodes = plan.nodes
        self.source = source
        self.log = EventLog(self.timeline, listeners, self._where)
        self.listeners = self.log.listeners  # the same list: tests and panels add to it
        # From any thread: a turn of the dialogue, and a human action a source observed.
        self.note = self.log.note
        self.observe_human = self.log.observe_human
        self.step_delay = step_delay
        # Seconds an arm takes from one waypoint of its path to the next (0: a motion
        # takes no time); a pause stops the arm at its next waypoint.
        self.waypoint_s = waypoint_s
        self.waypoint: Waypoint | None = None  # the arm motion under way
        self.result: Result | None = None
        self.error: BaseException | None = None
        self.current: str | None = None  # the node being run
        self.events = self.log.events
        self.gate = RunGate()
        self._thread: threading.Thread | None = None
        self._done = threading.Event()
        if isinstance(source, Attachable):
            source.attach(self)  # a source that pauses and records (the voice) is told who runs

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
        if isinstance(self.source, Holdable):
            self.source.hold(held)

    def step(self) -> None:
        """Single-step mode: pauses, and lets exactly one more node run."""
        self.gate.step()

    def abort(self) -> None:
        self.gate.abort()
        if self.robot is not None:
            self.robot.cancel()
        if isinstance(self.source, Interruptible):
            self.source.interrupt()

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
            if isinstance(self.source, Attachable):
                self.source.detach(self)  # the voice stops listening
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
        # On the wall clock a line lasts as long as it is spoken (a question is asked
        # before it is answered).
        self.gate.sleep(self.timeline.speech_left(node, spoken))
        if node.outcomes:
            return self._branching_step(node_id, node, spoken)
        return self._deterministic_step(node_id, node, spoken)

    def _deterministic_step(self, node_id: str, node: PlanNode, spoken: Evidence | None) -> _Next:
        """An action with one way on: the motion the robot makes (at the world's slots),
        or what it says."""
        text = node.say if node.kind == "communication" else None
        step = self.slots.at(node_id, node, None)
        evidence = merged(spoken, step.evidence)
        if step.motion is not None:
            # The arm moves first: its event says what it did, from start to end.
            moved = self._make_motion(node_id, node, step.motion)
            evidence = merged(evidence, moved)
        self._emit(node_id, node, text=text, motion=step.motion, spoken=spoken, evidence=evidence)
        return _Next(node.children[0].node)

    def _make_motion(self, node_id: str, node: PlanNode, motion: Motion) -> Evidence | None:
        """The motion made, in its time: by the robot (what it did is the evidence),
        played by the page, stepped through its waypoints, or on the wall clock its
        time-parameterised duration waited; on a simulated clock it takes none."""
        if self.robot is not None:
            made = self._drive(node_id, node, motion)
            if made.began is not None:
                self.timeline.moving(made.began)
            return Evidence(robot=made)
        if self.player is not None:
            shown = self.player(node_id, motion)
            if shown is not None:
                self.timeline.moving(shown)
        elif self.waypoint_s > 0:
            self._move(node_id, motion)
        elif self.timeline.clock == "wall":
            self.gate.sleep(motion_seconds(motion))
        return None

    def _drive(self, node_id: str, node: PlanNode, motion: Motion) -> RobotMotion:
        """The robot makes `motion`; a fault it cannot get past stops the walk."""
        assert self.robot is not None

        def fault(record: RobotMotion) -> None:
            event = ExecutionEvent(0, 0.0, node_id, node.action, ROBOT_FAULT, text=record.detail)
            self.log.record(replace(event, evidence=Evidence(robot=record)))

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
        # What the human did is their activity, whatever the plan expected.
        acted = self.timeline.surprise_event(node_id, node, surprise, source)
        if acted is not None:
            self.log.record(acted)
        replanned = Replanned(
            str(surprise), tuple(sorted(repair.observed)), digest, round(repair.seconds, 3)
        )
        self.log.record(
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
        self.log.record(ExecutionEvent(0, 0.0, node_id, None, INTERRUPTED, text=reason))

    # -- recording (app.execution.event_log): the walk's, a source's own thread's

    def _where(self) -> str:
        """The node an event is kept at: the one being run, else the last, else the root."""
        last = self.events[-1].node if self.events else self.plan.root
        return self.current or last

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
        starts or reports, if its times are known."""
        times = self.timeline.finish(node, spoken, motion)
        recorded = self.log.record(
            ExecutionEvent(
                0, 0.0, node_id, node.action, _event_kind(node), outcome=outcome, source=source,
                confidence=confidence, text=text, motion=motion, evidence=evidence,
                start=times.start, end=times.end, wait_start=times.wait_start,
            )
        )  # fmt: skip
        for human in self.timeline.human_events(recorded, node):
            self.log.record(human)
