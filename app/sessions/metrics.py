"""A session's measures, as a collaboration study reports them.

Hoffman's objective fluency metrics (G. Hoffman, "Evaluating Fluency in
Human-Robot Collaboration", IEEE Trans. Human-Machine Systems 49(3), 2019):
human idle time, robot idle time, concurrent activity and functional delay,
each in seconds and as a share of the task's time. Here the robot is active
during its plan steps (moving, sensing, speaking, a question until its answer,
planning again) and the human during its task actions (events of kind `human`);
task time runs from the first event's start to the last one's end; idle time is
task time less the agent's active time; concurrent activity is the time both
are active; functional delay adds up, each time one agent starts an action
after the other ended one while it had been waiting (its own previous action
ended before), the time between the one's end and the other's start.

Beside them: questions by kind (askHelp, offerHelp, confirmAttach, and the
requests) with their mean answer time (a question's start to its answer; a
request's end to the human starting on it), repairs, fallbacks to clicks (the
voice giving up on a question), and in simulated runs the camera's and the
voice's agreement with the truth. A session stored before events were timed
gives its counts and None for every time (`timed` False).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, fields
from statistics import fmean
from typing import Literal

from app.execution.events import HUMAN, INTERRUPTED, REPAIR, ExecutionEvent, is_step
from planner.vocabulary import QUESTIONS, RequestToAttach, RequestToUnhold

Interval = tuple[float, float]
QuestionKind = Literal["askHelp", "offerHelp", "confirmAttach", "requests"]
QUESTION_KINDS: tuple[QuestionKind, ...] = ("askHelp", "offerHelp", "confirmAttach", "requests")
REQUESTS = (RequestToAttach.name, RequestToUnhold.name)
# The robot's activity: its steps along the plan (a goal takes no time).
ROBOT_KINDS = ("actuation", "sensing", "communication", REPAIR)
FALLBACK = "fell-back"


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


def session_metrics(events: Sequence[ExecutionEvent]) -> SessionMetrics:
    """The measures of the session whose events are `events` (in their order)."""
    timed = bool(events) and all(e.start is not None and e.end is not None for e in events)
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
        steps=sum(1 for e in events if is_step(e)),
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


def _question_kind(event: ExecutionEvent) -> QuestionKind | None:
    if event.kind != "communication" or event.action is None:
        return None
    name = event.action.name
    if name in REQUESTS:
        return "requests"
    if name in QUESTIONS:
        return name  # type: ignore[return-value]  # QUESTIONS are the other kinds
    return None


def _span(event: ExecutionEvent) -> Interval:
    assert event.start is not None and event.end is not None
    return event.start, event.end


def _times(events: Sequence[ExecutionEvent]) -> dict[str, float]:
    """Task time, each agent's active and idle time, concurrency and functional delay."""
    spans = [_span(e) for e in events if e.kind != INTERRUPTED]
    spans = spans or [_span(e) for e in events]
    task = max(end for _, end in spans) - min(start for start, _ in spans)
    robot_spans = sorted(_span(e) for e in events if e.kind in ROBOT_KINDS)
    human_spans = sorted(_span(e) for e in events if e.kind == HUMAN)
    robot, human = _union(robot_spans), _union(human_spans)
    robot_active, human_active = _length(robot), _length(human)
    return {
        "task_s": task,
        "robot_active_s": robot_active,
        "robot_idle_s": task - robot_active,
        "human_active_s": human_active,
        "human_idle_s": task - human_active,
        "concurrent_s": _length(_intersection(robot, human)),
        "functional_delay_s": (_delay(robot_spans, human_spans) + _delay(human_spans, robot_spans)),
    }


def _share(times: dict[str, float], key: str) -> float | None:
    task = times.get("task_s")
    return None if not task else times[key] / task


def _union(spans: list[Interval]) -> list[Interval]:
    """The disjoint intervals covering `spans`, in order."""
    merged: list[Interval] = []
    for start, end in sorted(spans):
        if merged and start <= merged[-1][1]:
            merged[-1] = (merged[-1][0], max(merged[-1][1], end))
        else:
            merged.append((start, end))
    return merged


def _length(spans: list[Interval]) -> float:
    return sum(end - start for start, end in spans)


def _intersection(a: list[Interval], b: list[Interval]) -> list[Interval]:
    out: list[Interval] = []
    for a_start, a_end in a:
        for b_start, b_end in b:
            start, end = max(a_start, b_start), min(a_end, b_end)
            if start < end:
                out.append((start, end))
    return out


def _delay(waiting: list[Interval], other: list[Interval]) -> float:
    """The time `waiting` took to start after `other` ended an action it waited for: for
    each of its actions (in start order), from the last end of an action of `other`
    before it, when all its own earlier actions had ended before that."""
    total = 0.0
    previous_end = float("-inf")
    for start, end in waiting:
        ends = [o_end for _, o_end in other if o_end <= start]
        if ends and max(ends) > previous_end:
            total += start - max(ends)
        previous_end = max(previous_end, end)
    return total


def _answer_times(events: Sequence[ExecutionEvent]) -> dict[QuestionKind, float]:
    """Each kind's mean answer time: a question from its start to its answer; a request
    from its end to the human starting the action it asked for."""
    seconds: dict[QuestionKind, list[float]] = {}
    for k, event in enumerate(events):
        kind = _question_kind(event)
        start, end = _span(event)
        if kind == "requests":
            acted = next((e for e in events[k + 1 :] if e.kind == HUMAN), None)
            if acted is not None and acted.node == event.node:
                seconds.setdefault(kind, []).append(_span(acted)[0] - end)
        elif kind is not None and event.outcome is not None:
            seconds.setdefault(kind, []).append(end - start)
    return {kind: fmean(values) for kind, values in seconds.items()}


def _agreement(events: Sequence[ExecutionEvent], source: str) -> tuple[int, float | None]:
    """How many answers `source` gave where the truth is known, and the share of them
    that agreed with it (None without any)."""
    judged = [
        e.outcome == e.evidence.truth.label
        for e in events
        if e.source == source and e.evidence is not None and e.evidence.truth is not None
    ]
    return len(judged), (sum(judged) / len(judged) if judged else None)
