"""The Speech panel: the robot's voice and the answers it hears.

It shows the speech engine in use, a listening indicator with the input level,
the last words heard with their confidence and the meaning taken, and a mute
box. Every line the robot says is sent to the page as audio (an `<audio
autoplay>` element with a data: URI, which viser's HTML element plays), or,
with `speak="local"`, played on the server's speakers.

"Answers by" chooses who answers the questions: clicks, the simulated voice
(a simulated human says its answer, the real recogniser hears it), the
simulated room (the same human in a live room where the ear listens all the
time: the robot's own voice comes back from its speakers and is refused, and
**Human says stop** / **Human says continue** have the human say the command
into the room, over whatever the robot is saying) or the microphone, which
listens all the time as the room does (`app.responses.voice_mic`: stop and
continue at any time, the robot's own voice gated, the device opened when the
execution starts and released when it ends; a device that goes away ends the
voice in one line and the clicks answer). The
click buttons stay visible while the voice listens, and a click that comes
first wins; a question refused twice waits for a click.
Without a speech model for the plan's language the panel says so in one line
and the questions stay with the clicks.

The execution panel asks `responses(plan, clicks)` for its outcome source and
narrator when an execution starts; the panel needs nothing else from it.
"""

from __future__ import annotations

import base64
import random
import threading
import time
from typing import Literal

import viser

from app.dashboard.stage import Events, ExecutionFinished, ScenarioChanged, Stage
from app.dashboard.widgets import show
from app.execution.events import OutcomeSource
from app.execution.narration import Line, RobotVoice, plan_language
from app.execution.walker import Narrator
from app.responses.voice import (
    Conversation,
    SpeechModels,
    VoiceListeners,
    VoiceResponses,
    voice_responses,
)
from app.sources.outcomes import ClickSource
from app.sources.voice import Attempt
from planner.plan.model import Plan
from speech.devices import NoAudioDevice, play_local
from speech.dialogue import Command
from speech.microphone import MicrophoneStream
from speech.models import NoSpeechModel
from speech.recognition import Recognizer
from speech.sources import SimulatedVoice
from speech.synthesis import Engine

Speak = Literal["page", "local"]
ROOM = "simulated room"  # the live dialogue, where the human's commands are heard
MODES = ("clicks", "simulated voice", ROOM, "microphone")
# What the simulated human says for stop and continue: of each language's
# command words, the ones its recogniser took best (speech/dialogue.py).
SAID_COMMANDS: dict[str, dict[Command, str]] = {
    "en-us": {"stop": "wait", "continue": "resume"},
    "ko": {"stop": "멈춰", "continue": "계속해"},
}
PANEL_ORDER = 10_000.0
LEVEL_EVERY_S = 0.1  # the input-level meter's updates (blocks arrive every 30 ms)
LINES_KEPT = 200  # the robot's latest lines kept here (a run says ~10-40)


def audio_html(line: Line) -> str:
    """An autoplaying `<audio>` element carrying the line's audio as a data: URI."""
    assert line.utterance is not None
    mime = "audio/mpeg" if line.utterance.format == "mp3" else "audio/wav"
    data = base64.b64encode(line.utterance.path.read_bytes()).decode("ascii")
    return f'<audio autoplay controls src="data:{mime};base64,{data}"></audio>'


class SpeechPanel:
    def __init__(
        self, gui: viser.GuiApi, stage: Stage, events: Events, speak: Speak = "page"
    ) -> None:
        self.gui = gui
        self.stage = stage
        self.speak = speak
        self.voice: VoiceResponses | None = None
        self.lines: list[Line] = []
        # None: a new simulated voice per execution; a number repeats one (tests).
        self.seed: int | None = None
        self._recognizers: dict[str, Recognizer] = {}
        self._loading = threading.Lock()  # apart from _lock: a load takes seconds
        self._level_at = 0.0
        self._lock = threading.Lock()
        # Last on the page, below the panels that were there before it.
        with gui.add_folder("Speech", order=PANEL_ORDER):
            self.mode: viser.GuiDropdownHandle[str] = gui.add_dropdown(
                "Answers by", MODES, initial_value=MODES[0]
            )
            self.mute: viser.GuiCheckboxHandle = gui.add_checkbox(
                "Mute", False, hint="Answered by clicks, a muted robot shows its lines "
                "without speaking them (they take no time)",
            )  # fmt: skip
            self.engine = gui.add_markdown("Voice: not spoken yet.")
            self.listening = gui.add_markdown("Not listening.")
            self.level = gui.add_progress_bar(0.0)  # viser does not export its handle class
            self.heard = gui.add_markdown("Nothing heard yet.")
            self.says = {
                command: gui.add_button(f"Human says {command}", disabled=True, visible=False)
                for command in ("stop", "continue")
            }
            self.audio = gui.add_html("")
        self.says["stop"].on_click(lambda _: self._say("stop"))
        self.says["continue"].on_click(lambda _: self._say("continue"))
        events.subscribe(ExecutionFinished, lambda _: self._finished())
        events.subscribe(ScenarioChanged, self._scenario_changed)
        self.mode.on_update(lambda _: self._prepare())

    def _finished(self) -> None:
        self._listening(False)
        for button in self.says.values():
            button.disabled = True

    def _scenario_changed(self, changed: ScenarioChanged) -> None:
        """Another scenario has another language: the voice and the words heard were
        the one before's (an edit keeps the language)."""
        if not changed.edited:
            self.engine.content = "Voice: not spoken yet."
            self.heard.content = "Nothing heard yet."

    def _say(self, command: Command) -> None:
        """The simulated human says `command` into the live room, now."""
        voice = self.voice
        if voice is None or voice.room is None:
            return
        code = voice.robot.language.code
        words = SAID_COMMANDS.get(code, SAID_COMMANDS["en-us"])[command]
        human = SimulatedVoice(voice.robot.language, room=voice.room)
        human.say_at(words, voice.room.now_s() + 0.05)
        self.heard.content = f"The simulated human says '{words}'."

    def _prepare(self) -> None:
        """Loads the speech model as soon as a voice is chosen (it takes seconds), so
        the first question does not wait for it; says at once if there is none."""
        for button in self.says.values():
            button.visible = self.mode.value == ROOM
        plan = self.stage.current_plan()
        if self.mode.value == "clicks" or plan is None:
            return
        code = plan_language(plan)

        def load() -> None:
            try:
                self._recognizer(code)
            except NoSpeechModel as error:
                self.heard.content = f"**No voice answers:** {error}. Answer by clicks."
            else:
                self.heard.content = f"Speech model for {code} ready."

        threading.Thread(target=load, name="speech-model", daemon=True).start()

    # -- what the execution panel asks for ------------------------------------------

    def responses(
        self, plan: Plan, clicks: ClickSource
    ) -> tuple[OutcomeSource, Narrator | None]:
        """The outcome source and narrator of an execution of `plan` (clicks as fallback)."""
        code = plan_language(plan)
        mode = self.mode.value
        self.voice = None
        if mode != "clicks":
            try:
                self.voice = voice_responses(
                    "mic" if mode == "microphone" else "sim",
                    code,
                    clicks,
                    conversation=Conversation(
                        live=mode == ROOM,
                        seed=random.randrange(2**31) if self.seed is None else self.seed,
                        speakers=self.speak,
                    ),
                    speech=SpeechModels(self._recognizer(code), engine=self._engine),
                    told=VoiceListeners(
                        on_line=self._spoken,
                        on_attempt=self._heard,
                        on_listening=self._listening,
                        on_lost=self._lost,
                        on_unplayed=self._unplayed,
                    ),
                )
            except (NoSpeechModel, NoAudioDevice) as error:
                self.heard.content = f"**No voice answers:** {error}. Answer by clicks."
        if self.voice is not None:
            for button in self.says.values():
                button.disabled = self.voice.room is None
            audio = self.voice.voice.audio
            if isinstance(audio, MicrophoneStream):
                audio.on_level = self._level  # the meter moves while a person speaks
            return self.voice.source, self.voice.robot
        if self.mute.value:
            # Muted, clicks answering: the lines are shown in the log, not spoken, so on
            # the wall clock they take no time (a spoken one lasts as its audio plays).
            return clicks, None
        return clicks, RobotVoice(code, self._engine, listeners=[self._spoken])

    @property
    def _engine(self) -> Engine:
        # Local playback takes WAV (espeak-ng); gTTS's MP3 plays only in the page.
        return "espeak" if self.speak == "local" else "auto"

    def _recognizer(self, code: str) -> Recognizer:
        # One model per language for the dashboard's life: it takes seconds to load.
        with self._loading:
            if code not in self._recognizers:
                self._recognizers[code] = Recognizer(code)
            return self._recognizers[code]

    # -- callbacks from the executor's thread -----------------------------------------

    def _spoken(self, line: Line) -> None:
        with self._lock:
            # Windowed: the session store keeps what was said, a day has thousands.
            self.lines = [*self.lines[-(LINES_KEPT - 1):], line]
        if line.utterance is None:
            self.engine.content = f"Voice: **not spoken** ({line.error})"
            return
        self.engine.content = f"Voice: **{line.engine}** ({line.utterance.voice})"
        if self.mute.value:
            return
        if self.speak == "local" and self._microphone:
            return  # the microphone's dialogue plays it, so its ear knows when
        if self.speak == "local":
            threading.Thread(target=self._play_local, args=(line,), daemon=True).start()
        else:
            self.audio.content = audio_html(line)

    @property
    def _microphone(self) -> bool:
        voice = self.voice
        return voice is not None and voice.ear is not None and voice.room is None

    def _lost(self, why: str) -> None:
        """The microphone went away (the ear's thread): said in one line."""
        self.heard.content = f"**The voice has ended** ({why}): answer by clicks."
        self._listening(False)

    def _unplayed(self, why: str) -> None:
        self.engine.content = f"Voice: not played here: {why}"

    def _play_local(self, line: Line) -> None:
        assert line.utterance is not None
        try:
            play_local(line.utterance)
        except (NoAudioDevice, ValueError) as error:
            self.engine.content = f"Voice: {line.engine}, not played here: {error}"

    def _listening(self, on: bool) -> None:
        self.listening.content = "**Listening...**" if on else "Not listening."
        if self.voice is not None:
            self._level(float(getattr(self.voice.voice.audio, "level", 0.0)), force=True)

    def _level(self, rms: float, force: bool = False) -> None:
        now = time.monotonic()
        if force or now - self._level_at >= LEVEL_EVERY_S:
            self._level_at = now
            show(self.level, min(100.0, 400.0 * rms))  # speech RMS is ~0.05-0.25

    def _heard(self, attempt: Attempt) -> None:
        words = attempt.heard or "-"
        if attempt.accepted:
            verdict = f"meaning **{attempt.meaning}**"
        else:
            verdict = f"refused: {attempt.reason}"
        self.heard.content = (
            f"Heard '{words}' (confidence {attempt.confidence:.2f}, try {attempt.number}): "
            f"{verdict}"
        )

    def close(self) -> None:
        if self.voice is not None:
            self.voice.source.interrupt()
            if self.voice.ear is not None:
                self.voice.ear.close()  # the microphone is released
