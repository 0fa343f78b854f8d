"""A dialogue that holds up: the robot never hears itself, and no answer or a too
long one has a defined path (issue 34, items 3 and 4).

Everything goes through a live simulated room (`speech.sources.SimulatedRoom`)
in real time: the robot's sentences come back from its speakers, the simulated
human's words are espeak-ng's Korean voice, and the real vosk model decides.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Sequence
from pathlib import Path

import pytest
from pydantic import ValidationError

from app.execution.events import DIALOGUE_KINDS, ExecutionEvent, is_step
from app.execution.walker import Executor
from app.responses.voice import VoiceResponses, dialogue_times
from app.responses.voice_room import LiveDialogue
from app.sessions.store import SessionStore
from app.sources.outcomes import RandomSource
from app.sources.voice import is_question
from planner.plan.model import Plan, PlanNode
from planner.scenario.sections import Human
from speech.audio import RATE, Samples, read_wav, resample
from speech.dialogue import Commands, DialogueTimes, Ear, Hearing
from speech.recognition import Decoding, Recognizer
from speech.sources import SimulatedRoom, SimulatedVoice, Span
from speech.synthesis import synthesize
from tests.plan_fixtures import korean_plan
from tests.plan_paths import is_plan_path

QUESTION = "leg2 부품에 손이 닿지 않아요. top에 붙여 주시겠어요?"
# Per language: a question, a yes, and a stop word (English: pocketsphinx; Korean: vosk).
SPOKEN = {
    "ko": (QUESTION, "네", "멈춰"),
    "en-us": ("I cannot reach leg two. Can you attach it to the top for me?", "yes", "wait"),
}


@pytest.fixture(scope="module")
def recognizers() -> dict[str, Recognizer]:
    return {}  # each language's model loads once for the whole module


@pytest.fixture(scope="module")
def recognizer(recognizers: dict[str, Recognizer]) -> Recognizer:
    return _recognizer(recognizers, "ko")


def _recognizer(recognizers: dict[str, Recognizer], code: str) -> Recognizer:
    if code not in recognizers:
        recognizers[code] = Recognizer(code)
    return recognizers[code]


@pytest.fixture(scope="module")
def plan() -> Plan:
    return korean_plan()


def _robot_says(room: SimulatedRoom, ear: Ear, text: str, code: str, cache: Path) -> Span:
    """The robot's sentence through its speakers into the room; where it is."""
    recording = read_wav(synthesize(text, code, "espeak", cache).path)
    samples = resample(recording.samples, recording.rate, RATE)
    return room.play_robot(samples, told=ear.robot_speaks)


@pytest.mark.parametrize(("code", "cancel_echo"), [("ko", False), ("ko", True), ("en-us", False)])
def test_the_robots_own_question_is_refused_and_an_answer_right_after_is_taken(
    recognizers: dict[str, Recognizer], tmp_path: Path, code: str, cancel_echo: bool
) -> None:
    question, yes, _ = SPOKEN[code]
    room = SimulatedRoom(seed=4)
    times = DialogueTimes()
    ear = Ear(room, times, Commands(code), cancel_echo=cancel_echo).start()
    try:
        voice_ends = float(_robot_says(room, ear, question, code, tmp_path).speech_end_s)
        human = SimulatedVoice(code, seed=2, room=room)
        # The answer's first sound 0.05 s after the self-hearing tail (render pads 0.3 s).
        human.say_at(yes, voice_ends + times.echo_tail_s + 0.05 - human.pause_s)
        answer = ear.answer(_recognizer(recognizers, code))
    finally:
        ear.close()
    assert answer.hearing is not None and answer.hearing.meaning == "yes", answer
    assert answer.hearing.words == (yes,)
    if not cancel_echo:
        # The question itself reached the microphone while the ear listened: heard,
        # refused as the robot's own voice, never as an answer.
        assert answer.own_voice, ear.heard
        assert all(h.reason == "own voice" and h.meaning is None for h in answer.own_voice)
        assert answer.own_voice[0].start_s < voice_ends
    # Nothing heard was taken as an answer but the human's.
    assert [h for h in ear.heard if h.meaning is not None] == [answer.hearing]


class _StalledStream:
    """The room, whose reading stops at `stall_s` until `go_on` is set: an ear that
    has heard the start of the human's answer when the answer is asked for."""

    def __init__(self, room: SimulatedRoom) -> None:
        self.room = room
        self.stall_s = float("inf")
        self.stalled, self.go_on = threading.Event(), threading.Event()

    @property
    def position_s(self) -> float:
        return self.room.position_s

    def read(self) -> Samples:
        if self.room.position_s >= self.stall_s:
            self.stalled.set()
            self.go_on.wait(10.0)
        return self.room.read()


@pytest.mark.parametrize("late", ["begun", "ended"])
def test_an_answer_given_before_the_ear_was_asked_for_it_is_taken(
    recognizers: dict[str, Recognizer], tmp_path: Path, monkeypatch: pytest.MonkeyPatch, late: str
) -> None:
    """The asking thread late (a busy machine): the human answered right after the
    question, and the ear had heard 0.15 s of the answer, or all of it, when the
    answer was asked for."""
    question, yes, _ = SPOKEN["en-us"]
    stream = _StalledStream(SimulatedRoom(seed=4))
    times = DialogueTimes()
    ear = Ear(stream, times, Commands("en-us"), cancel_echo=False).start()
    recognizer = _recognizer(recognizers, "en-us")
    decode = recognizer.start

    def decode_and_go_on() -> Decoding:  # the stream goes on once the answer is decoded
        stream.go_on.set()
        return decode()

    monkeypatch.setattr(recognizer, "start", decode_and_go_on)
    try:
        voice_ends = float(_robot_says(stream.room, ear, question, "en-us", tmp_path).speech_end_s)
        human = SimulatedVoice("en-us", seed=2, room=stream.room)
        human.say_at(yes, voice_ends + times.echo_tail_s + 0.05 - human.pause_s)
        said = human.spoken_at
        assert said is not None
        ended = said.speech_end_s + times.end_of_speech_s + 0.2
        stream.stall_s = said.speech_start_s + 0.15 if late == "begun" else ended
        assert stream.stalled.wait(30.0), "the room never reached the answer"
        answer = ear.answer(recognizer)
    finally:
        stream.go_on.set()
        ear.close()
    assert answer.hearing is not None and answer.hearing.meaning == "yes", (answer, ear.heard)
    assert answer.hearing.start_s < stream.stall_s  # heard from its start, not from the call
    assert [h for h in ear.heard if h.meaning is not None] == [answer.hearing]
    # The question, heard before the call, is still this answer's own voice.
    assert answer.own_voice and all(h.reason == "own voice" for h in answer.own_voice)
    assert answer.own_voice[0].start_s < voice_ends


def test_what_is_said_after_an_answer_is_not_the_next_answer_without_a_new_question(
    recognizers: dict[str, Recognizer], tmp_path: Path
) -> None:
    """A "yes" said again after the answer, and an answer then asked for with no new
    question the ear was told of (a line the page plays as MP3): no speech."""
    question, yes, _ = SPOKEN["en-us"]
    stream = _StalledStream(SimulatedRoom(seed=4))
    times = DialogueTimes()
    ear = Ear(stream, times, Commands("en-us"), cancel_echo=False).start()
    recognizer = _recognizer(recognizers, "en-us")
    try:
        voice_ends = float(_robot_says(stream.room, ear, question, "en-us", tmp_path).speech_end_s)
        human = SimulatedVoice("en-us", seed=2, room=stream.room)
        human.say_at(yes, voice_ends + times.echo_tail_s + 0.05 - human.pause_s)
        first = ear.answer(recognizer)
        human.say_at(yes, stream.position_s + 0.3)
        said = human.spoken_at
        assert said is not None
        stream.stall_s = said.speech_end_s + times.end_of_speech_s + 0.2
        assert stream.stalled.wait(30.0), "the room never reached the second yes"
        stream.go_on.set()
        second = ear.answer(recognizer, no_speech_s=1.0)
    finally:
        stream.go_on.set()
        ear.close()
    assert first.hearing is not None and first.hearing.meaning == "yes", (first, ear.heard)
    assert second.hearing is None, (second, ear.heard)
    assert len([h for h in ear.heard if h.start_s > said.start_s - 0.1]) == 1  # it was heard


@pytest.mark.parametrize("code", ["ko", "en-us"])
def test_a_stop_said_over_the_robots_voice_is_heard(
    recognizers: dict[str, Recognizer], tmp_path: Path, code: str
) -> None:
    question, _, stop = SPOKEN[code]
    room = SimulatedRoom(seed=6)
    heard: list[Hearing] = []
    ear = Ear(room, DialogueTimes(), Commands(code), lambda _, h: heard.append(h)).start()
    try:
        robot = _robot_says(room, ear, question + " " + question, code, tmp_path)
        human = SimulatedVoice(code, seed=6, room=room)
        # Said 0.5 s into the robot's sentence; not obeyed, said again (three times at most).
        at = robot.start_s + 0.5
        while not heard and at < robot.speech_end_s - 1.5:
            human.say_at(stop, at - human.pause_s)
            assert human.spoken_at is not None
            at = human.spoken_at.end_s + 0.8
            while room.position_s < at and not heard:
                time.sleep(0.03)
        waited = ear.answer(_recognizer(recognizers, code), no_speech_s=1.0)
    finally:
        ear.close()
    assert heard and heard[0].command == "stop", ear.heard
    assert robot.start_s < heard[0].start_s < robot.speech_end_s  # over the robot's voice
    # A command is no answer, and the robot's own voice was none either.
    assert waited.hearing is None and all(h.meaning is None for h in ear.heard)


def test_without_the_canceller_no_command_is_taken_in_the_robots_window(
    recognizers: dict[str, Recognizer], tmp_path: Path
) -> None:
    """The robot's own 멈춰 (and a human's said over it) is refused as its own voice
    when its voice is not cancelled; a 멈춰 said after the window still stops."""
    _, _, stop = SPOKEN["ko"]
    room = SimulatedRoom(seed=6)
    heard: list[Hearing] = []
    ear = Ear(room, DialogueTimes(), Commands("ko"), lambda _, h: heard.append(h),
              cancel_echo=False).start()  # fmt: skip
    try:
        robot = _robot_says(room, ear, f"테이블이 완성됐어요. {stop}", "ko", tmp_path)
        human = SimulatedVoice("ko", seed=6, room=room)
        human.say_at(stop, robot.start_s + 0.5 - human.pause_s)
        while room.position_s < ear.robot_until_s + 0.5:
            time.sleep(0.03)
        assert heard == [], "a command taken in the robot's own voice"
        own = [h for h in ear.heard if h.reason == "own voice"]
        assert own and own[0].start_s < robot.speech_end_s
        human.say_at(stop, room.position_s + 0.2)
        said = human.spoken_at
        assert said is not None
        while room.position_s < said.end_s + 1.0 and not heard:
            time.sleep(0.03)
    finally:
        ear.close()
    assert [h.command for h in heard] == ["stop"], ear.heard
    assert heard[0].start_s > ear.robot_until_s


def _run(
    plan: Plan, voice: VoiceResponses, data: Path, *, narrate: bool = True
) -> list[ExecutionEvent]:
    """Runs `plan` to its goal, stored in a session; the session's events as stored."""
    with SessionStore(data) as store:
        session = store.start(plan)
        narrator = voice.robot if narrate else None
        executor = Executor(plan, voice.source, [store.recorder(session)], narrator=narrator)
        result = executor.run()
        store.finish(session, result)
        assert result == "goal"
        assert is_plan_path(plan, store.path(session))  # the dialogue's turns are no steps
        events = store.events(session)
    assert [(e.seq, e.kind, e.text) for e in events] == [
        (e.seq, e.kind, e.text) for e in executor.events
    ]
    return events


def _questions(plan: Plan, events: Sequence[ExecutionEvent]) -> list[ExecutionEvent]:
    steps = [(e, plan.nodes[e.node]) for e in events if is_step(e)]
    return [e for e, node in steps if is_question(node, node.outcomes)]


def _turns(events: Sequence[ExecutionEvent], node: str) -> list[tuple[str, str]]:
    """The dialogue's turns at `node` (not its steps, nor the human's actions)."""
    return [(e.kind, e.text or "") for e in events if e.kind in DIALOGUE_KINDS and e.node == node]


def test_own_voice_is_kept_as_an_event_of_the_session(
    recognizer: Recognizer, plan: Plan, tmp_path: Path
) -> None:
    dialogue = LiveDialogue(recognizer.language, recognizer, cache_dir=tmp_path, cancel_echo=False)
    voice = dialogue.responses(RandomSource(5), seed=5)
    events = _run(plan, voice, tmp_path)
    questions = _questions(plan, events)
    assert questions and all(e.source == "voice" for e in questions)
    own = [e for e in events if e.kind == "own-voice"]
    # Every question was heard back from the speakers, refused, and kept with its reason.
    assert {e.node for e in own} == {e.node for e in questions}
    assert all(e.source == "voice" and "own voice" in (e.text or "") for e in own)
    truth = voice.speaker
    assert truth is not None
    assert all(e.outcome == truth.choices[e.node] for e in questions)


def test_no_speech_is_asked_again_then_the_fallback_answers(
    recognizer: Recognizer, plan: Plan, tmp_path: Path
) -> None:
    times = dialogue_times(Human(language="ko", no_speech_s=1.0))
    voice = LiveDialogue(recognizer.language, recognizer, times, tmp_path).responses(
        RandomSource(3), seed=3
    )
    voice.voice.on_question = None  # the human says nothing
    events = _run(plan, voice, tmp_path, narrate=False)
    questions = _questions(plan, events)
    assert questions
    for event in questions:
        assert event.source == "random"  # the seeded choice, headless
        hearing = event.evidence.voice if event.evidence is not None else None
        assert hearing is not None and hearing.answered_by == "fallback"
        assert [a.reason for a in hearing.attempts] == ["no speech", "no speech"]
        turns = _turns(events, event.node)
        assert [kind for kind, _ in turns] == ["asked-again", "fell-back"], turns
        assert "no speech" in turns[0][1]
    # The question was asked twice, each time aloud.
    spoken = [a.node_id for a in voice.voice.spoken]
    assert all(spoken.count(e.node) == 2 for e in questions)


class _TalksTooLong:
    """A human who first tells a long story, then answers yes."""

    def __init__(self, voice: SimulatedVoice) -> None:
        self.voice = voice
        self.asked: list[str] = []

    def __call__(self, node_id: str, node: PlanNode, options: Sequence[str]) -> None:
        self.asked.append(node_id)
        if self.asked.count(node_id) == 1:
            self.voice.say("오늘 아침에 테이블 다리를 찾느라고 창고를 한참 뒤졌어요")
        else:
            self.voice.say("네")


def test_an_utterance_over_the_maximum_is_refused_as_too_long(
    recognizer: Recognizer, plan: Plan, tmp_path: Path
) -> None:
    times = dialogue_times(Human(language="ko", max_utterance_s=1.5))
    voice = LiveDialogue(recognizer.language, recognizer, times, tmp_path).responses(
        RandomSource(8), seed=8
    )
    assert voice.speaker is not None
    human = _TalksTooLong(voice.speaker.voice)
    voice.voice.on_question = human
    events = _run(plan, voice, tmp_path, narrate=False)
    questions = _questions(plan, events)
    assert questions
    for event in questions:
        hearing = event.evidence.voice if event.evidence is not None else None
        assert hearing is not None
        assert hearing.attempts[0].reason == "too long" and hearing.attempts[0].meaning is None
        turns = [kind for kind, _ in _turns(events, event.node)]
        assert turns[:2] == ["too-long", "asked-again"], turns
        # Asked again, the short answer is taken by voice.
        assert event.source == "voice" and event.outcome == "yes", hearing


def test_the_dialogue_times_are_the_human_sections() -> None:
    human = Human()
    assert dialogue_times(human) == DialogueTimes(5.0, 0.2, 5.0)
    assert dialogue_times(Human(no_speech_s=8, max_utterance_s=15.0)).max_utterance_s == 15.0
    with pytest.raises(ValidationError, match="end_of_speech_s"):
        Human(end_of_speech_s=2.0, max_utterance_s=1.5)
    with pytest.raises(ValidationError, match="no_speech_s"):
        Human(no_speech_s=0.2)
