"""A session's measures, as a collaboration study reports them.

Hoffman's objective fluency metrics (G. Hoffman, "Evaluating Fluency in
Human-Robot Collaboration", IEEE Trans. Human-Machine Systems 49(3), 2019),
each in seconds and as a share of the task time:

- task time: from the first event's start to the last one's end (an
  interruption's own event only when there is nothing else).
- robot activity: its steps along the plan (moving, sensing, speaking, asking,
  planning again after a surprise), each from its start to its end, except
  the part from the step's `wait_start` to its end: a question waiting for its
  answer, a sensing of the human watching the human act. Hoffman counts an
  agent waiting for the other as idle. Robot idle time (R-IDLE) is the task
  time less the robot's activity.
- human activity: every `human` event, whatever its source (the simulator's
  times, the camera's or the voice's observations, an operator's clicks),
  surprising actions included. Human idle time (H-IDLE) is the task time less
  the human's activity.
- concurrent activity (C-ACT): the time both agents are active.
- functional delay (F-DEL): the time lost between one agent's action ending and
  the other's beginning. It adds up every stretch in which neither agent acts
  that begins when one agent's action ends and ends when the other agent's
  action begins: one agent waited for the other, and nobody acted meanwhile.
  A pause between two actions of the same agent, the other idle throughout, is
  not a delay (nobody waited for anybody); nor is the time before the first
  action or after the last. Earlier versions counted the whole gap from one
  agent's end to the other's start even when the first agent had gone on with
  another action (the human reacting to a request while the robot already
  moved): time in which the robot worked is not lost, so that reading is gone.

An agent's activity is the union of its intervals: two overlapping actions
count once.

Beside them: questions by kind (askHelp, offerHelp, confirmAttach, and the
requests) with their mean answer time (a question's start to its answer; a
request's end to the human starting on it), repairs, fallbacks to clicks (the
voice giving up on a question), and in simulated runs the camera's and the
voice's agreement with the truth. A session is timed when its clock is known
(`simulated` or `wall`) and each of its events has a start and an end; an
untimed one (stored before events had times, or before sessions said their
clock) gives its counts and None for every time.

The measures read only a few fields of each event (`EventTimes`): the session
store reads those straight from its rows for thousands of sessions
(`app.sessions.stored_metrics`), with the same numbers as `session_metrics`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, fields
from statistics import fmean
from typing import Literal, NamedTuple

from app.execution.events import (
    CLOCKS,
    DIALOGUE_KINDS,
    HUMAN,
    INTERRUPTED,
    REPAIR,
    ROBOT_FAULT,
    ExecutionEvent,
)
from planner.vocabulary import QUESTIONS, RequestToAttach, RequestToUnhold

Interval = tuple[float, float]
QuestionKind = Literal["askHelp", "offerHelp", "confirmAttach", "requests"]
QUESTION_KINDS: tuple[QuestionKind, ...] = ("askHelp", "offerHelp", "confirmAttach", "requests")
REQUESTS = (RequestToAttach.name, RequestToUnhold.name)
# The robot's activity: its steps along the plan (a goal takes no time).
ROBOT_KINDS = ("actuation", "sensing", "communication", REPAIR)
FALLBACK = "fell-back"
# Not steps of the plan (`app.execution.events.is_step`).
NOT_STEPS = frozenset((INTERRUPTED, HUMAN, ROBOT_FAULT, *DIALOGUE_KINDS))
Agent = Literal["robot", "human"]


class EventTimes(NamedTuple):
    """What the measures read of an event: its kind, its action's name, node, outcome
    and source, its times, and the truth's label where a simulation knew it."""

    kind: str
    action: str | None
    node: str
    outcome: str | None
    source: str | None
    start: float | None
    end: float | None
    wait_start: float | None
    truth: str | None


def event_times(event: ExecutionEvent) -> EventTimes:
    truth = event.evidence.truth if event.evidence is not None else None
    return EventTimes(
        event.kind,
        None if event.action is None else event.action.name,
        event.node,
        event.outcome,
        event.source,
        event.start,
        event.end,
        event.wait_start,
        None if truth is None else truth.label,
    )


@dataclass(frozen=True)
class SessionMetrics:
    """One session's measures; times in seconds, None when the session is untimed
    (or, for a share, when the task took no time; for an answer time, no such
    question was asked)."""

    timed: bool
    events: int
    steps: int
    task_s: float | None
    robot_active_s: float | None
    robot_idle_s: float | None
    human_active_s: float | None
    human_idle_s: float | None
    concurrent_s: float | None
    functional_delay_s: float | None
    robot_idle_share: float | None
    human_idle_share: float | None
    concurrent_share: float | None
    functional_delay_share: float | None
    askHelp: int
    offerHelp: int
    confirmAttach: int
    requests: int
    askHelp_answer_s: float | None
    offerHelp_answer_s: float | None
    confirmAttach_answer_s: float | None
    requests_answer_s: float | None
    repairs: int
    fallbacks: int
    camera_answers: int
    camera_agreement: float | None
    voice_answers: int
    voice_agreement: float | None

    def row(self) -> dict[str, float | int | str | None]:
        """The measures as one flat, CSV-ready row, keyed by `METRIC_KEYS` in order."""
        return {key: getattr(self, key) for key in METRIC_KEYS}


METRIC_KEYS: tuple[str, ...] = tuple(f.name for f in fields(SessionMetrics))


def session_metrics(events: Sequence[ExecutionEvent], clock: str | None) -> SessionMetrics:
    """The measures of the session whose events are `events` (in their order), timed on
    `clock` (its `SessionRecord.clock`; None, a session stored before clocks: untimed)."""
    return measure([event_times(e) for e in events], clock)


def measure(events: Sequence[EventTimes], clock: str | None) -> SessionMetrics:
    """The measures of a session from what they read of its events, in their order."""
    timed = (
        clock in CLOCKS
        and bool(events)
        and all(e.start is not None and e.end is not None for e in events)
    )
    counts = {kind: 0 for kind in QUESTION_KINDS}
    for event in events:
        kind = _question_kind(event)
        if kind is not None:
            counts[kind] += 1
    camera_answers, camera_agreement = _agreement(events, "camera")
    voice_answers, voice_agreement = _agreement(events, "voice")
    times = _times(events) if timed else {}
    answers = _answer_times(events) if timed else {}
    return SessionMetrics(
        timed=timed,
        events=len(events),
        steps=sum(1 for e in events if e.kind not in NOT_STEPS),
        task_s=times.get("task_s"),
        robot_active_s=times.get("robot_active_s"),
        robot_idle_s=times.get("robot_idle_s"),
        human_active_s=times.get("human_active_s"),
        human_idle_s=times.get("human_idle_s"),
        concurrent_s=times.get("concurrent_s"),
        functional_delay_s=times.get("functional_delay_s"),
        robot_idle_share=_share(times, "robot_idle_s"),
        human_idle_share=_share(times, "human_idle_s"),
        concurrent_share=_share(times, "concurrent_s"),
        functional_delay_share=_share(times, "functional_delay_s"),
        askHelp=counts["askHelp"],
        offerHelp=counts["offerHelp"],
        confirmAttach=counts["confirmAttach"],
        requests=counts["requests"],
        askHelp_answer_s=answers.get("askHelp"),
        offerHelp_answer_s=answers.get("offerHelp"),
        confirmAttach_answer_s=answers.get("confirmAttach"),
        requests_answer_s=answers.get("requests"),
        repairs=sum(1 for e in events if e.kind == REPAIR),
        fallbacks=sum(1 for e in events if e.kind == FALLBACK),
        camera_answers=camera_answers,
        camera_agreement=camera_agreement,
        voice_answers=voice_answers,
        voice_agreement=voice_agreement,
    )


def _question_kind(event: EventTimes) -> QuestionKind | None:
    if event.kind != "communication" or event.action is None:
        return None
    if event.action in REQUESTS:
        return "requests"
    if event.action in QUESTIONS:
        return event.action  # type: ignore[return-value]  # QUESTIONS are the other kinds
    return None


def _span(event: EventTimes) -> Interval:
    assert event.start is not None and event.end is not None
    return event.start, event.end


def robot_activity(event: EventTimes) -> Interval:
    """The part of a robot's step in which it acts: all of it, or up to its wait."""
    start, end = _span(event)
    if event.wait_start is None:
        return start, end
    return start, min(end, max(start, event.wait_start))


def _times(events: Sequence[EventTimes]) -> dict[str, float]:
    """Task time, each agent's active and idle time, concurrency and functional delay."""
    spans = [_span(e) for e in events if e.kind != INTERRUPTED]
    spans = spans or [_span(e) for e in events]
    task = max(end for _, end in spans) - min(start for start, _ in spans)
    robot = _union([robot_activity(e) for e in events if e.kind in ROBOT_KINDS])
    human = _union([_span(e) for e in events if e.kind == HUMAN])
    robot_active, human_active = _length(robot), _length(human)
    return {
        "task_s": task,
        "robot_active_s": robot_active,
        "robot_idle_s": task - robot_active,
        "human_active_s": human_active,
        "human_idle_s": task - human_active,
        "concurrent_s": _length(_intersection(robot, human)),
        "functional_delay_s": functional_delay(robot, human),
    }


def _share(times: dict[str, float], key: str) -> float | None:
    task = times.get("task_s")
    return None if not task else times[key] / task


def _union(spans: list[Interval]) -> list[Interval]:
    """The disjoint intervals covering `spans` (those that last), in order; intervals
    that touch are one."""
    merged: list[Interval] = []
    for start, end in sorted(spans):
        if end <= start:
            continue
        if merged and start <= merged[-1][1]:
            merged[-1] = (merged[-1][0], max(merged[-1][1], end))
        else:
            merged.append((start, end))
    return merged


def _length(spans: list[Interval]) -> float:
    return sum(end - start for start, end in spans)


def _intersection(a: list[Interval], b: list[Interval]) -> list[Interval]:
    """Where two ordered, disjoint interval lists overlap (one walk along both)."""
    out: list[Interval] = []
    i = j = 0
    while i < len(a) and j < len(b):
        start, end = max(a[i][0], b[j][0]), min(a[i][1], b[j][1])
        if start < end:
            out.append((start, end))
        if a[i][1] < b[j][1]:
            i += 1
        else:
            j += 1
    return out


def functional_delay(robot: list[Interval], human: list[Interval]) -> float:
    """The stretches in which neither agent acts, each from the end of one agent's
    activity to the start of the other's (`robot` and `human`: each agent's activity,
    disjoint and in order)."""
    bounds: list[tuple[float, float, Agent]] = [(s, e, "robot") for s, e in robot]
    bounds += [(s, e, "human") for s, e in human]
    bounds.sort()
    starters: dict[float, set[Agent]] = {}
    for start, _, agent in bounds:
        starters.setdefault(start, set()).add(agent)
    total = 0.0
    reach = float("-inf")  # the end of all activity so far
    enders: set[Agent] = set()  # whose activity ends at `reach`
    for start, end, agent in bounds:
        # A stretch nobody acts in, opened by `enders` and closed by this start: a
        # delay unless one and the same agent opens and closes it.
        if start > reach and enders and (enders != starters[start] or len(enders) > 1):
            total += start - reach
        if end > reach:
            reach, enders = end, {agent}
        elif end == reach:
            enders.add(agent)
    return total


def _answer_times(events: Sequence[EventTimes]) -> dict[QuestionKind, float]:
    """Each kind's mean answer time: a question from its start to its answer; a request
    from its end to the human starting the action it asked for."""
    seconds: dict[QuestionKind, list[float]] = {}
    for k, event in enumerate(events):
        kind = _question_kind(event)
        if kind is None:
            continue
        start, end = _span(event)
        if kind == "requests":
            acted = next((e for e in events[k + 1 :] if e.kind == HUMAN), None)
            if acted is not None and acted.node == event.node:
                seconds.setdefault(kind, []).append(_span(acted)[0] - end)
        elif event.outcome is not None:
            seconds.setdefault(kind, []).append(end - start)
    return {kind: fmean(values) for kind, values in seconds.items()}


def _agreement(events: Sequence[EventTimes], source: str) -> tuple[int, float | None]:
    """How many answers `source` gave where the truth is known, and the share of them
    that agreed with it (None without any)."""
    judged = [e.outcome == e.truth for e in events if e.source == source and e.truth is not None]
    return len(judged), (sum(judged) / len(judged) if judged else None)
