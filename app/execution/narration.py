"""The robot's voice during an execution: every sentence it says, as it says it.

`RobotVoice` synthesises a communication node's sentence in the plan's
language (gTTS when its service answers, else espeak-ng; cached), hands the
spoken `Line` (text, engine, the audio file) to its listeners (the log, the
dashboard's audio, the local speakers) and returns the evidence the executor
keeps with the event: what was said and by which engine. Used as the
executor's narrator it speaks every communication node when it is reached;
`questions=False` leaves the questions to the voice source, which speaks them
itself before each listen.

A voice that cannot speak (no espeak-ng) never stops a session: the line is
kept with `engine` "none" and the error, and the text still reaches the log.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path

from app.execution.evidence import Evidence, Spoken
from planner.plan.model import Plan, PlanNode
from speech.languages import Language, language
from speech.synthesis import Engine, SynthesisError, Utterance, synthesize


@dataclass(frozen=True)
class Line:
    """One sentence the robot said at a node; `utterance` is None when no engine could."""

    node_id: str
    text: str
    utterance: Utterance | None
    error: str | None = None

    @property
    def engine(self) -> str:
        return self.utterance.engine if self.utterance is not None else "none"


LineListener = Callable[[Line], None]

# What the robot says when the human stops it and when it goes on. No stop or
# continue word is in them, so its own voice never sounds like a command.
STOPPED = {"en-us": "I have stopped.", "ko": "멈췄습니다."}
GOING_ON = {"en-us": "Going on.", "ko": "다시 시작합니다."}


def plan_language(plan: Plan, default: str = "en-us") -> str:
    """The language a plan speaks: its `language("...")` fact, else `default`."""
    for fact in plan.facts:
        if fact.startswith("language(") and fact.endswith(")"):
            return fact[len("language(") : -1].strip('"')
    return default


class RobotVoice:
    """Speaks sentences in one language and tells its listeners (see the module)."""

    def __init__(
        self,
        language_code: str | Language,
        engine: Engine = "auto",
        cache_dir: Path | None = None,
        listeners: Iterable[LineListener] = (),
        questions: bool = True,
    ) -> None:
        self.language = (
            language_code if isinstance(language_code, Language) else language(language_code)
        )
        self.engine: Engine = engine
        self.cache_dir = cache_dir
        self.listeners = list(listeners)
        self.questions = questions
        self.lines: list[Line] = []
        self._lock = threading.Lock()

    def say(self, node_id: str, text: str) -> Line:
        try:
            utterance = synthesize(text, self.language, self.engine, self.cache_dir)
        except SynthesisError as error:
            line = Line(node_id, text, None, str(error))
        else:
            line = Line(node_id, text, utterance)
        with self._lock:
            self.lines.append(line)
        for listener in self.listeners:
            listener(line)
        return line

    def __call__(self, node_id: str, node: PlanNode) -> Evidence | None:
        """The executor's narrator: speaks `node`'s sentence (questions only if asked to)."""
        if not node.say or (node.outcomes and not self.questions):
            return None
        line = self.say(node_id, node.say)
        return Evidence(spoken=spoken(line))


def spoken(line: Line) -> Spoken:
    """What a session keeps of a spoken line."""
    utterance = line.utterance
    return Spoken(
        said=line.text,
        engine=line.engine,
        voice=None if utterance is None else utterance.voice,
        duration_s=None if utterance is None else round(utterance.duration_s, 2),
        speech_error=line.error,
    )
