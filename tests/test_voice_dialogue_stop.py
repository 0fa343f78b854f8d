"""Stop at any time (issue 34, item 5): the simulated human says 멈춰 into the live
room, during an arm motion or over the robot's own voice; the real vosk model hears
it, the execution pauses, the robot says it stopped, and 계속 resumes it.

How soon the pause follows the word is a speed, measured by `python -m
speech.dialogue`; here only where the execution stopped is checked.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

import pytest

from app.execution.events import DIALOGUE_KINDS, ExecutionEvent, is_step
from app.execution.narration import GOING_ON, STOPPED, Line
from app.execution.walker import Executor, Waypoint
from app.responses.voice import VoiceResponses
from app.responses.voice_room import LiveDialogue
from app.sources.outcomes import RandomSource
from planner.plan.model import Plan
from speech.dialogue import Hearing
from speech.recognition import Recognizer
from speech.sources import SimulatedVoice, Span
from tests.plan_fixtures import default_plan, korean_plan
from tests.plan_paths import is_plan_path


@pytest.fixture(scope="module")
def recognizer() -> Recognizer:
    return Recognizer("ko")


@pytest.fixture(scope="module")
def plan() -> Plan:
    return korean_plan()


def live_dialogue(
    recognizer: Recognizer, cache: Path, seed: int
) -> tuple[VoiceResponses, SimulatedVoice]:
    voice = LiveDialogue(recognizer.language, recognizer, cache_dir=cache).responses(
        RandomSource(seed), seed=seed
    )
    assert voice.speaker is not None and voice.room is not None and voice.stops is not None
    return voice, voice.speaker.voice


def _heard(voice: VoiceResponses) -> list[Hearing]:
    """Everything the live ear heard."""
    assert voice.ear is not None
    return voice.ear.heard


def until(condition: Callable[[], bool], within_s: float = 20.0) -> bool:
    """Waits for `condition` (a real-time dialogue), giving up after `within_s`."""
    deadline = time.monotonic() + within_s
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.02)
    return True


def say_once(human: SimulatedVoice, text: str, said: list[Span], delay_s: float) -> None:
    """The human says `text` `delay_s` from now, once."""
    if not said:
        assert human.room is not None
        human.say_at(text, human.room.now_s() + delay_s - human.pause_s)
        assert human.spoken_at is not None
        said.append(human.spoken_at)


def resume_by_voice(voice: VoiceResponses, human: SimulatedVoice, executor: Executor) -> None:
    """Once the robot has said it stopped, the human says 계속해 (계속) and it goes on;
    not heard, the human says it again, as a person would (at most three times)."""
    stopped = STOPPED["ko"]
    assert until(lambda: any(line.text == stopped for line in voice.robot.lines))
    room = human.room
    assert room is not None
    for words in ("계속해", "계속", "계속해"):
        assert until(lambda: room.now_s() > room.robot_until_s)
        human.say_at(words, room.now_s())
        if until(lambda: not executor.paused, within_s=4.0):
            break
    assert not executor.paused, _heard(voice)
    assert executor.wait(120) == "goal"


def _kinds(events: list[ExecutionEvent]) -> list[str]:
    return [e.kind for e in events]


def _check_pause_and_resume(plan: Plan, voice: VoiceResponses, executor: Executor) -> None:
    events = executor.events
    paused = [e for e in events if e.kind == "paused"]
    resumed = [e for e in events if e.kind == "resumed"]
    assert len(paused) == 1 and len(resumed) == 1, _kinds(events)
    assert paused[0].seq < resumed[0].seq
    for event, command in ((paused[0], "stop"), (resumed[0], "continue")):
        hearing = event.evidence.voice if event.evidence is not None else None
        assert event.source == "voice" and hearing is not None and hearing.meaning == command
    commands = [h.command for h in _heard(voice) if h.command]
    assert commands == ["stop", "continue"], _heard(voice)
    said = [line.text for line in voice.robot.lines]
    assert said.index(STOPPED["ko"]) < said.index(GOING_ON["ko"])
    assert is_plan_path(plan, [(e.node, e.outcome) for e in events if is_step(e)])
    assert voice.stops is not None and voice.stops.pauses


def test_stop_halts_an_arm_motion_at_its_next_waypoint_and_continue_resumes(
    recognizer: Recognizer, plan: Plan, tmp_path: Path
) -> None:
    voice, human = live_dialogue(recognizer, tmp_path, seed=1)
    # A motion takes 0.1 s a waypoint, so the first one lasts 3 s.
    executor = Executor(plan, voice.source, narrator=voice.robot, waypoint_s=0.1)
    said: list[Span] = []

    def on_event(event: ExecutionEvent) -> None:
        if event.kind == "actuation":  # the first motion starts: the human says stop
            say_once(human, "멈춰", said, 0.2)

    executor.listeners.append(on_event)
    executor.start()
    assert until(lambda: executor.paused), _heard(voice)
    at_pause = executor.waypoint
    assert at_pause is not None, "the pause came after the motion"
    time.sleep(0.6)  # six waypoints' time: the arm must not move on
    halted = executor.waypoint
    assert isinstance(halted, Waypoint) and halted.node == at_pause.node
    assert at_pause.index <= halted.index <= at_pause.index + 1
    assert halted.index < halted.count - 1  # stopped inside the motion
    assert executor.waypoint == halted
    resume_by_voice(voice, human, executor)
    _check_pause_and_resume(plan, voice, executor)
    paused = next(e for e in executor.events if e.kind == "paused")
    assert paused.node == halted.node


def test_stop_said_over_the_robots_own_voice_is_heard(
    recognizer: Recognizer, plan: Plan, tmp_path: Path
) -> None:
    voice, human = live_dialogue(recognizer, tmp_path, seed=2)
    assert voice.room is not None
    room = voice.room
    said: list[Span] = []
    speaking: list[tuple[str, float, float]] = []  # each line: text, from, to

    def on_line(line: Line) -> None:
        if line.utterance is None:
            return
        start = max(room.now_s(), room.robot_until_s)
        speaking.append((line.text, start, start + line.utterance.duration_s))
        # The greeting starts: 0.5 s into it, the human says stop over it.
        say_once(human, "멈춰", said, 0.5)

    voice.robot.listeners.insert(0, on_line)
    executor = Executor(plan, voice.source, narrator=voice.robot)
    executor.start()
    assert until(lambda: executor.paused), _heard(voice)
    _, greeting_from, greeting_to = speaking[0]
    assert greeting_from < said[0].speech_start_s < said[0].speech_end_s < greeting_to
    # The robot fell silent before the end of its greeting (its next line, that it
    # stopped, starts before), and moved no arm.
    assert until(lambda: len(speaking) > 1)
    assert speaking[1][0] == STOPPED["ko"] and speaking[1][1] < greeting_to
    time.sleep(0.5)
    assert "actuation" not in _kinds(executor.events)
    resume_by_voice(voice, human, executor)
    _check_pause_and_resume(plan, voice, executor)
    kinds = _kinds(executor.events)
    assert kinds.index("paused") < kinds.index("actuation")
    assert kinds.index("resumed") < kinds.index("actuation")


def test_a_pause_with_a_reason_is_an_event_and_holds_the_arm_where_it_is() -> None:
    """The executor's side alone: what the voice's stop and continue call."""
    plan = default_plan()
    executor = Executor(plan, RandomSource(4), waypoint_s=0.02)
    executor.start()
    # The arm moves before its step is recorded: stop it part-way through its path.
    assert until(lambda: executor.waypoint is not None and executor.waypoint.index >= 3)
    moving = executor.waypoint
    executor.pause("heard 'stop'")
    at_pause = executor.waypoint
    assert moving is not None and at_pause is not None and at_pause.node == moving.node
    time.sleep(0.2)  # ten waypoints' time
    halted = executor.waypoint
    assert halted is not None and at_pause.index <= halted.index <= at_pause.index + 1
    executor.pause("heard 'stop' again")  # already paused: no second event
    executor.resume("heard 'continue'")
    assert executor.wait(60) == "goal"
    turns = [(e.kind, e.text, e.source) for e in executor.events if e.kind in DIALOGUE_KINDS]
    assert turns == [
        ("paused", "heard 'stop'", "voice"),
        ("resumed", "heard 'continue'", "voice"),
    ]
    assert is_plan_path(plan, [(e.node, e.outcome) for e in executor.events if is_step(e)])
    # A pause without a reason (the dashboard's button) keeps no event, as before.
    quiet = Executor(plan, RandomSource(4))
    quiet.pause()
    quiet.resume()
    assert quiet.run() == "goal"
    assert not [e for e in quiet.events if e.kind in DIALOGUE_KINDS]


def test_paused_by_voice_and_resumed_by_the_button_the_voice_answers_again(
    recognizer: Recognizer, plan: Plan, tmp_path: Path
) -> None:
    """The operator's Resume (not "continue") ends the voice's pause too: the ear,
    held while paused, takes the next questions' answers again."""
    voice, human = live_dialogue(recognizer, tmp_path, seed=2)
    assert voice.ear is not None
    said: list[Span] = []

    def on_line(line: Line) -> None:
        if line.utterance is not None:
            say_once(human, "멈춰", said, 0.5)  # over the greeting

    voice.robot.listeners.insert(0, on_line)
    executor = Executor(plan, voice.source, narrator=voice.robot)
    executor.start()
    assert until(lambda: executor.paused), _heard(voice)
    assert voice.ear.held
    executor.resume()  # the Resume button: no words, no event
    assert not voice.ear.held
    assert executor.wait(180) == "goal"
    events = executor.events
    assert [e.kind for e in events if e.kind in ("paused", "resumed")] == ["paused"]
    questions = [e for e in events if is_step(e) and e.kind == "communication" and e.outcome]
    assert questions and all(e.source == "voice" for e in questions), [
        (e.node, e.source) for e in questions
    ]
