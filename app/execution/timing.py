"""When each event of an execution starts and ends: the wall clock, or a simulated one.

Real runs (a camera, a voice, the dashboard, a robot) keep the wall clock
(`WallTimeline`): an event starts when the executor reaches its node and ends
once what it does has taken its real time (a motion played, drawn or made by the
robot; a line spoken; a question until its answer); a click that answers for the
human ends the human's action it reports, begun at the robot's request. Headless
runs simulate time (`SimulatedTimeline`): no sleeping, the same session for the
same seed. There a robot action lasts as long as its motion takes, each segment
of the joint path at the speed of the joint that needs longest at `SPEED_RATIO`
of Baxter's joint velocity limits (read from the URDF the feasibility checks
load; `BAXTER_VELOCITY_LIMITS` if missing); a spoken line as long as its audio
(`Spoken.duration_s`) or, without audio, its words at espeak-ng's default rate;
a sensing action `CAMERA_SETTLE_S`; a question until its answer. The simulated
human reacts to a request after a seeded delay, then acts for a seeded duration
(each a `Pace` the scenario's [human] section sets) while the robot goes on; a
sensing node that watches the human waits until it is done. The simulated clock
leaves out the time planning again takes, which no seed fixes.
"""

from __future__ import annotations

import math
import random
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cache
from typing import Literal, NamedTuple, Protocol, get_args
from xml.etree import ElementTree

from app.execution.events import HUMAN, AnswerSource, Clock, ExecutionEvent, describe
from app.execution.evidence import Evidence
from app.execution.surprises import HumanAttached, Surprise
from planner.plan.model import Motion, PlanNode
from planner.scenario.sections import Human
from planner.vocabulary import (
    AskHelp,
    ConfirmAttach,
    RequestToAttach,
    RequestToUnhold,
    SenseHumanAttachingWhere,
    SenseHumanHolding,
    SenseHumanHoldingWhichPart,
    SenseHumanUnholding,
)

# Baxter's joint velocity limits in rad/s, as example-robot-data's baxter.urdf gives
# them (the same for both arms): shoulders and elbows 1.5, wrists 4.0.
BAXTER_VELOCITY_LIMITS: Mapping[str, float] = {
    "s0": 1.5, "s1": 1.5, "e0": 1.5, "e1": 1.5, "w0": 4.0, "w1": 4.0, "w2": 4.0,
}  # fmt: skip
# The share of those limits a motion runs at: baxter_interface's default joint position
# speed ratio (`Limb.set_joint_position_speed`, 0.3), which Baxter's own motions use.
SPEED_RATIO = 0.3
# An actuation node without a joint path (a plan made without geometry): assumed.
ACTUATION_WITHOUT_PATH_S = 2.0
# The camera settling on the bench after something moved: a sensing action's time
# (30 frames at 30 fps: a frame with no motion blur and a stable reading; assumed).
CAMERA_SETTLE_S = 1.0
# espeak-ng's default rate is 175 words a minute: a spoken line without audio lasts
# its words at that rate.
SPEECH_WORDS_PER_S = 175 / 60

# What the simulated human does in its own time: reacting to a request, attaching a
# part, putting a part down, and answering a question (from the question's end).
HumanActivity = Literal["react", "attach", "unhold", "answer"]
HUMAN_ACTIVITIES: tuple[HumanActivity, ...] = get_args(HumanActivity)
# The human's task actions in the text of their events (of kind `human`).
HUMAN_ACTION_WORDS: Mapping[HumanActivity, str] = {
    "attach": "the human attaches the part",
    "unhold": "the human puts the part down",
}


@dataclass(frozen=True)
class Pace:
    """A lognormal duration: `median_s` seconds, `sigma` the spread of its log."""

    median_s: float
    sigma: float

    def draw(self, rng: random.Random) -> float:
        return self.median_s * math.exp(self.sigma * rng.gauss(0.0, 1.0))


def paces_of(human: Human) -> dict[HumanActivity, Pace]:
    """The paces the scenario's [human] section sets (its defaults say where from)."""
    return {
        "react": Pace(human.react_s, human.react_sigma),
        "attach": Pace(human.attach_s, human.attach_sigma),
        "unhold": Pace(human.unhold_s, human.unhold_sigma),
        "answer": Pace(human.answer_s, human.answer_sigma),
    }


DEFAULT_PACES: Mapping[HumanActivity, Pace] = paces_of(Human())


@cache
def joint_velocity_limits() -> Mapping[str, float]:
    """Each arm joint's velocity limit (rad/s) by its URDF name, from baxter.urdf;
    `BAXTER_VELOCITY_LIMITS` for both arms when the robot model is not installed."""
    from planner.feasibility.robot import RobotModelMissing, baxter_urdf

    fallback = {f"{a}_{j}": v for a in ("left", "right") for j, v in BAXTER_VELOCITY_LIMITS.items()}
    try:
        root = ElementTree.parse(baxter_urdf()).getroot()
    except (RobotModelMissing, OSError, ElementTree.ParseError):
        return fallback
    limits = dict(fallback)
    for joint in root.iter("joint"):
        limit, name = joint.find("limit"), joint.get("name", "")
        if limit is not None and name in fallback and limit.get("velocity"):
            limits[name] = float(limit.get("velocity", "0")) or fallback[name]
    return limits


def segment_seconds(
    joints: Sequence[str], path: Sequence[Sequence[float]], ratio: float = SPEED_RATIO
) -> list[float]:
    """How long each segment of a joint path takes: as long as its slowest joint
    needs at `ratio` of its velocity limit (a path is fine enough that the arm does
    not stop between waypoints)."""
    limits = joint_velocity_limits()
    slowest = min(BAXTER_VELOCITY_LIMITS.values())
    speeds = [ratio * limits.get(name, slowest) for name in joints]
    return [
        max(abs(y - x) / v for x, y, v in zip(a, b, speeds, strict=False))
        for a, b in zip(path, path[1:], strict=False)
    ]


def motion_seconds(motion: Motion | None) -> float:
    """How long the arm takes along `motion`'s path (`segment_seconds`)."""
    if motion is None or len(motion.path) < 2:
        return ACTUATION_WITHOUT_PATH_S
    return sum(segment_seconds(motion.joints, motion.path))


def speech_seconds(text: str | None, spoken: Evidence | None) -> float:
    """How long a spoken line lasts: its audio, or its words at espeak-ng's rate."""
    said = spoken.spoken if spoken is not None else None
    if said is not None and said.duration_s is not None:
        return said.duration_s
    return len((text or "").split()) / SPEECH_WORDS_PER_S


def audio_seconds(spoken: Evidence | None) -> float:
    """How long a line's audio plays on the wall clock; 0 when it was only shown."""
    said = spoken.spoken if spoken is not None else None
    return said.duration_s if said is not None and said.duration_s is not None else 0.0


def human_activity(node: PlanNode, outcome: str | None) -> HumanActivity | None:
    """The task action the human starts after `node`: what a request asks, or agreeing
    to attach (a "yes" to askHelp or confirmAttach)."""
    match node.action:
        case RequestToAttach():
            return "attach"
        case RequestToUnhold():
            return "unhold"
        case AskHelp() | ConfirmAttach() if outcome == "yes":
            return "attach"
    return None


def watches_human(node: PlanNode) -> bool:
    return isinstance(
        node.action,
        SenseHumanHolding | SenseHumanHoldingWhichPart | SenseHumanUnholding
        | SenseHumanAttachingWhere,
    )  # fmt: skip


def waits_for_human(node: PlanNode) -> bool:
    """Whether the robot waits for the human at `node`: a question, or a sensing of the
    human."""
    return (node.kind == "communication" and bool(node.outcomes)) or (
        node.kind == "sensing" and watches_human(node)
    )


class StepTimes(NamedTuple):
    """When a step started and ended, and when within it the robot began waiting for
    the human (`ExecutionEvent.wait_start`; None: it acted throughout)."""

    start: float
    end: float
    wait_start: float | None = None


class Timeline(Protocol):
    """The times of a walk's events, on a `clock`: `simulated` (no time really passes)
    or `wall` (every step takes the time it really takes)."""

    clock: Clock

    def begin(self, node: PlanNode) -> float:
        """When the robot starts `node` (after waiting for the human, if it must)."""
        ...

    def moving(self, began: float) -> None:
        """The step under way began its motion at wall time `began` (the page's
        animation shown, the robot's goal sent): on the wall clock its event starts
        there, not at the work before it (drawing the tree, planning a way to the
        start). A simulated clock times motions itself."""
        ...

    def speech_left(self, node: PlanNode, spoken: Evidence | None) -> float:
        """Seconds the walk still waits for `node`'s spoken line to end (its audio, or
        its words at espeak-ng's rate) on the wall clock; 0 on a simulated one."""
        ...

    def finish(self, node: PlanNode, spoken: Evidence | None, motion: Motion | None) -> StepTimes:
        """When the node last begun started and ends."""
        ...

    def human_events(self, event: ExecutionEvent, node: PlanNode) -> tuple[ExecutionEvent, ...]:
        """The human's actions that the step `event` (just recorded, at `node`) answers,
        starts or ends, as events to record, where their times are known now."""
        ...

    def surprise_event(
        self, node_id: str, node: PlanNode, surprise: Surprise, source: AnswerSource
    ) -> ExecutionEvent | None:
        """The human's surprising action that `source` saw at `node`, if this clock
        times it (a camera keeps what it observes itself)."""
        ...

    def now(self) -> float:
        """The time of an event that takes none (a turn of the dialogue, a stop)."""
        ...


# Who reports a human's action by a click: its end is the click, its start the
# robot's request it answers.
REPORTED: tuple[AnswerSource, ...] = ("click", "console")


class WallTimeline:
    """The wall clock: a step starts when reached and ends when done, the walk having
    waited for what takes time (a motion played or made, a line spoken, an answer).
    The human's actions reported by clicks are timed here (`human_events`); a camera or
    a voice records the ones it observes itself."""

    clock: Clock = "wall"

    def __init__(self) -> None:
        self.started = time.time()
        # When the robot last asked the human for an action not yet reported done.
        self.requested: float | None = None

    def begin(self, node: PlanNode) -> float:
        self.started = time.time()
        return self.started

    def moving(self, began: float) -> None:
        self.started = max(self.started, min(began, time.time()))

    def speech_left(self, node: PlanNode, spoken: Evidence | None) -> float:
        if node.kind != "communication":
            return 0.0
        return max(0.0, self.started + audio_seconds(spoken) - time.time())

    def finish(self, node: PlanNode, spoken: Evidence | None, motion: Motion | None) -> StepTimes:
        end = max(self.started, time.time())
        wait_start = None
        if node.kind == "communication" and node.outcomes:
            wait_start = min(end, self.started + audio_seconds(spoken))
        elif waits_for_human(node):
            wait_start = self.started
        return StepTimes(self.started, end, wait_start)

    def human_events(self, event: ExecutionEvent, node: PlanNode) -> tuple[ExecutionEvent, ...]:
        assert event.start is not None and event.end is not None
        reported: tuple[ExecutionEvent, ...] = ()
        if event.source in REPORTED and waits_for_human(node):
            # The click ends the human's action; it began when the robot asked for it
            # (this question once asked, or an earlier request).
            asked = event.wait_start if event.wait_start is not None else event.start
            start = min(self.requested, asked) if self.requested is not None else asked
            self.requested = None
            what = describe(node.action, event.outcome)
            words = f"the human's action, reported by a {event.source}: {what}"
            reported = (
                ExecutionEvent(
                    0, event.end, event.node, node.action, HUMAN, source=event.source,
                    text=words, start=start, end=event.end,
                ),
            )  # fmt: skip
        if human_activity(node, event.outcome) is not None:
            self.requested = event.end  # asked now: the human starts on it
        return reported

    def surprise_event(
        self, node_id: str, node: PlanNode, surprise: Surprise, source: AnswerSource
    ) -> ExecutionEvent | None:
        if source not in REPORTED:
            return None
        # Reported by a click: the action ended then, and began at the robot's
        # request or, without one, when the robot began the node that saw it.
        end = time.time()
        start = self.requested if self.requested is not None else self.started
        self.requested = None
        words = f"the human's surprise, reported by a {source}: {surprise}"
        return ExecutionEvent(
            0, end, node_id, node.action, HUMAN, source=source, text=words, start=start, end=end
        )

    def now(self) -> float:
        return time.time()


class SimulatedTimeline:
    """A simulated clock for the robot and the human, from `origin` (epoch seconds;
    now by default); the human's times are drawn, seeded by `seed`, from the paces of
    the scenario's [human] section (its defaults without one)."""

    clock: Clock = "simulated"

    def __init__(
        self,
        seed: int,
        human: Human | None = None,
        origin: float | None = None,
    ) -> None:
        self.paces = paces_of(human) if human is not None else dict(DEFAULT_PACES)
        self.rng = random.Random(seed)
        self.robot_free = time.time() if origin is None else origin
        self.human_free = self.robot_free  # when the human's last task action ends

    def begin(self, node: PlanNode) -> float:
        if node.kind == "sensing" and watches_human(node):
            self.robot_free = max(self.robot_free, self.human_free)
        return self.robot_free

    def moving(self, began: float) -> None:
        pass

    def speech_left(self, node: PlanNode, spoken: Evidence | None) -> float:
        return 0.0

    def finish(self, node: PlanNode, spoken: Evidence | None, motion: Motion | None) -> StepTimes:
        start, seconds, wait_start = self.robot_free, 0.0, None
        if node.kind == "actuation":
            seconds = motion_seconds(motion)
        elif node.kind == "sensing":
            seconds = CAMERA_SETTLE_S
        elif node.kind == "communication":
            seconds = speech_seconds(node.say, spoken)
            if node.outcomes:  # a question lasts until the answer
                wait_start = start + seconds
                seconds += self.paces["answer"].draw(self.rng)
        self.robot_free = start + seconds
        return StepTimes(start, self.robot_free, wait_start)

    def human_events(self, event: ExecutionEvent, node: PlanNode) -> tuple[ExecutionEvent, ...]:
        assert event.end is not None
        out: list[ExecutionEvent] = []
        if event.wait_start is not None and event.outcome is not None and event.source != "voice":
            # The simulated human's answer: from the question asked to its answer, as a
            # click reports it on the wall clock (the voice observes the speech itself).
            words = f"the human answers {event.outcome}, as asked at {node.action}"
            out.append(
                ExecutionEvent(
                    0, event.end, event.node, node.action, HUMAN, source="simulated",
                    text=words, start=event.wait_start, end=event.end,
                )
            )  # fmt: skip
        activity = human_activity(node, event.outcome)
        if activity is not None:
            # The human reacts, then acts, once done with what it was doing.
            start = max(event.end + self.paces["react"].draw(self.rng), self.human_free)
            self.human_free = start + self.paces[activity].draw(self.rng)
            words = f"{HUMAN_ACTION_WORDS[activity]}, as asked at {node.action}"
            out.append(
                ExecutionEvent(
                    0, self.human_free, event.node, node.action, HUMAN, source="simulated",
                    text=words, start=start, end=self.human_free,
                )
            )  # fmt: skip
        return tuple(out)

    def surprise_event(
        self, node_id: str, node: PlanNode, surprise: Surprise, source: AnswerSource
    ) -> ExecutionEvent | None:
        # The simulated human did it just before it was seen, once done with what it
        # was doing, in the time of a like task action.
        activity: HumanActivity = "attach" if isinstance(surprise, HumanAttached) else "unhold"
        end = max(self.robot_free, self.human_free)
        start = max(self.human_free, end - self.paces[activity].draw(self.rng))
        self.human_free = end
        words = f"the human's surprise: {surprise}"
        return ExecutionEvent(
            0, end, node_id, node.action, HUMAN, source="simulated", text=words,
            start=start, end=end,
        )  # fmt: skip

    def now(self) -> float:
        return self.robot_free
