"""The words of an execution, in one low module every other imports.

What an execution says as it runs (`ExecutionEvent`), how it ends (`Result`),
the outcome a source chose (`Outcome`) and what decided it (`Evidence`), and
the protocol of a source (`OutcomeSource`). It imports only the planner's plan
and vocabulary, so the session store and its readers load neither clingo nor
pybullet.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Literal, Protocol, get_args, runtime_checkable

from app.execution.evidence import Evidence
from app.execution.surprises import Surprise
from planner.plan.model import Motion, Plan, PlanNode
from planner.vocabulary import (
    QUESTIONS,
    Action,
    SenseHumanAttachingWhere,
    SenseHumanHolding,
    SenseHumanHoldingWhichPart,
    SenseHumanUnholding,
    SenseLengthOf,
    SenseShapeOf,
    State,
)

Node = PlanNode

# The dialogue's own events at a node, none a step of the plan (the text says more):
# `own-voice`: what the microphone heard was the robot's own voice, not an answer;
# `too-long`: an utterance longer than the scenario's maximum, refused;
# `asked-again`: a question asked once more after a refusal or no speech;
# `fell-back`: the voice gave up on a question and the fallback answers it;
# `paused` / `resumed`: the human said "stop" / "continue" (source `voice`).
DialogueKind = Literal["own-voice", "too-long", "asked-again", "fell-back", "paused", "resumed"]
DIALOGUE_KINDS: tuple[DialogueKind, ...] = get_args(DialogueKind)
# What an event is: the kind of the plan node run, or one of the execution's own.
# `repair`: the execution changed plans after a surprise (its evidence says which);
# `interrupted`: the walk stopped at this node for the reason in its text (the
# program stopping, not a step of the plan); `human`: the human's task
# action (or speech), observed or reported, with its source; `robot-fault`:
# the robot behind a link stopped (its text the cause, its evidence the robot's last
# joint state); or one of the dialogue's.
EventKind = Literal[
    "actuation", "sensing", "communication", "goal", "repair", "interrupted", "human",
    "robot-fault", DialogueKind,
]  # fmt: skip
EVENT_KINDS: tuple[EventKind, ...] = get_args(EventKind)
REPAIR: EventKind = "repair"
INTERRUPTED: EventKind = "interrupted"
HUMAN: EventKind = "human"
ROBOT_FAULT: EventKind = "robot-fault"
# Who answered a branching node: a click in the dashboard, the console's numbered
# choices, a seeded random choice, a script, the planner's hoped outcome, the
# camera or the voice. A `human` event's source says where its times come from:
# `simulated` (the simulated human's own times), `camera` or `voice` (observed), or
# `click`/`console` (reported: an operator's click ends the human's action).
AnswerSource = Literal[
    "click", "console", "random", "scripted", "expected", "camera", "voice", "simulated"
]
ANSWER_SOURCES: tuple[AnswerSource, ...] = get_args(AnswerSource)


@dataclass(frozen=True)
class Outcome:
    """The outcome that happened at a node, and who said so."""

    label: str
    source: AnswerSource
    confidence: float | None = None
    text: str = ""
    evidence: Evidence | None = None
    surprise: Surprise | None = None  # what happened fits no outcome: plan again
    # sense(humanAttachingWhere): the free slot the human really used, when it is
    # another than the branch `label` names (the executor maps one onto the other)
    slot: str | None = None


class OutcomeSource(Protocol):
    def choose(self, node_id: str, node: Node, options: Sequence[str]) -> Outcome | None:
        """The outcome at `node` (one of `options`), or None when there is no answer."""
        ...


class ExecutionControls(Protocol):
    """What a source may do to the execution it answers for (the voice: "stop",
    "continue", and the turns of the dialogue kept as events)."""

    def pause(self, why: str | None = None, evidence: Evidence | None = None) -> None: ...

    def resume(self, why: str | None = None, evidence: Evidence | None = None) -> None: ...

    def note(
        self,
        kind: DialogueKind,
        text: str,
        source: AnswerSource | None = None,
        evidence: Evidence | None = None,
        node_id: str | None = None,
    ) -> ExecutionEvent: ...

    def observe_human(
        self,
        start: float,
        end: float,
        text: str,
        source: AnswerSource,
        evidence: Evidence | None = None,
        node_id: str | None = None,
    ) -> ExecutionEvent: ...


# What a source may do beyond answering, each optional: the walker asks the source
# with isinstance (runtime-checkable), never by probing attribute names.
@runtime_checkable
class Attachable(Protocol):
    """A source told which execution it answers for (the voice: to pause it and keep
    the dialogue's turns; a live camera: to keep the human's actions it sees)."""

    def attach(self, controls: ExecutionControls) -> None: ...

    def detach(self, controls: ExecutionControls) -> None: ...


@runtime_checkable
class Interruptible(Protocol):
    """A source whose wait for an answer an abort ends at once."""

    def interrupt(self) -> None: ...


@runtime_checkable
class Holdable(Protocol):
    """A source that takes no answer while the execution is paused (a live voice)."""

    def hold(self, held: bool) -> None: ...


class OutcomeError(Exception):
    """A source answered with something that is not an outcome of the node."""


# Which clock a session ran on: `simulated` (headless runs and studies: no time
# passes, the same session for the same seed) or `wall` (a person, a device or a
# robot: every step takes the time it really takes).
Clock = Literal["simulated", "wall"]
CLOCKS: tuple[Clock, ...] = get_args(Clock)

# How an execution ended: at a goal leaf, stopped by the operator, stopped by the
# program (a signal, the dashboard closing), or at a node with no way on.
Result = Literal["goal", "aborted", "interrupted", "dead-end"]
RESULTS: tuple[Result, ...] = get_args(Result)


@dataclass(frozen=True)
class ExecutionEvent:
    """One step of an execution: the node run and how it turned out.

    `kind` is the node's kind, or `repair`/`interrupted` (see `EventKind`);
    `action` is the node's action (None at a goal and for the execution's own
    events); `outcome` is the branch taken (None after a deterministic node); `text`
    is what the robot said, or the outcome in words. `motion` (actuation
    only) is the node's `{arm, joints, path}`; it is not stored, the plan has it
    (a re-targeted one is, in the evidence).
    An interrupted walk ends with an event of kind `interrupted` at the node it
    stood at, saying why (it is not a step of the plan).
    `evidence` is what decided the answer (a camera frame, the words heard),
    stored beside the event.
    `start`/`end` (epoch seconds, simulated in a headless run) are when the step
    began and ended: a question until its answer, a `human` event the human's
    action; None in a session stored before events were timed. `time` is when the
    event was recorded, its `end` in a timed session. `wait_start` is when, within
    the step, the robot began waiting for the human: a question once asked (its
    speech over), a sensing of the human on the wall clock from its start; from
    then to `end` the robot is idle in Hoffman's sense (None: it acted throughout).
    """

    seq: int
    time: float  # seconds since the epoch
    node: str
    action: Action | None
    kind: EventKind
    outcome: str | None = None
    source: AnswerSource | None = None
    confidence: float | None = None
    text: str | None = None
    motion: Motion | None = field(default=None, compare=False, repr=False)
    evidence: Evidence | None = field(default=None, compare=False, repr=False)
    plan: Plan | None = field(default=None, compare=False, repr=False)  # a repair's new plan
    # Not compared: the JSON export does not carry them yet, and reads back as equal.
    start: float | None = field(default=None, compare=False)
    end: float | None = field(default=None, compare=False)
    wait_start: float | None = field(default=None, compare=False)


@dataclass(frozen=True)
class Waypoint:
    """Where an arm motion under way stands: its node, the waypoint reached (from 0)
    and how many its path has."""

    node: str
    index: int
    count: int


def is_step(event: ExecutionEvent) -> bool:
    """Whether `event` is a step along the plan (a node run, or a change of plans), not
    an interruption, the human's own action or a turn of the dialogue."""
    return event.kind not in (INTERRUPTED, HUMAN, ROBOT_FAULT) and event.kind not in DIALOGUE_KINDS


def describe(action: Action | None, label: str | None) -> str:
    """Words for the outcome `label` of `action`, for buttons and logs."""
    if label is None:
        return "done"
    if action is None:
        return label
    match action:
        case SenseHumanHolding():
            return {"yes": "Human holds a part", "no": "Human's hands are free"}.get(label, label)
        case SenseHumanHoldingWhichPart():
            return f"Human holds {label}"
        case SenseHumanUnholding(part):
            words = {"yes": f"Human puts {part} down", "no": f"Human keeps holding {part}"}
            return words.get(label, label)
        case SenseHumanAttachingWhere(part, onto):
            return f"Human attaches {part} to {onto} at {label}"
        case SenseShapeOf(part) | SenseLengthOf(part):
            return f"{part} is {label}"
    if action.name in QUESTIONS and label in ("yes", "no"):
        return f"Human says {label}"
    return f"{action}: {label}"


@dataclass(frozen=True)
class Repair:
    """The plan to go on with, from `observed`; `words` is what the robot says."""

    plan: Plan
    observed: State
    words: str
    seconds: float


class RepairFailed(Exception):
    """No plan from the observed state; one line saying why."""
