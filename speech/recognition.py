"""Audio to words to an answer: vosk with a closed grammar, and when to refuse.

STRATEGY_DOC_PLACEHOLDER
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from speech.audio import RATE, Recording, as_int16, resample
from speech.languages import Language, language
from speech.models import find_model, in_vocabulary, load_model
from speech.voice_activity import activity

Meaning = Literal["yes", "no"]
Reason = Literal["silence", "low confidence", "out of grammar", "ambiguous"]


@dataclass(frozen=True)
class Heard:
    """What the recogniser made of one answer.

    `meaning` is "yes"/"no" only when accepted; otherwise `reason` says why
    it was refused and `words` still shows what the grammar decoding heard.
    """

    words: tuple[str, ...]
    confidence: float
    meaning: Meaning | None
    reason: Reason | None
    word_confidences: tuple[float, ...] = ()
    decode_s: float = 0.0

    @property
    def accepted(self) -> bool:
        return self.meaning is not None


@dataclass(frozen=True)
class Thresholds:
    min_speech_s: float = 0.12
    min_confidence: float = 0.75
    extra: dict[str, float] = field(default_factory=dict)


class Recognizer:
    """A yes/no recogniser for one language (the model is loaded once per process)."""

    def __init__(
        self,
        language_code: str | Language = "ko",
        model_dir: Path | str | None = None,
        yes_words: tuple[str, ...] | None = None,
        no_words: tuple[str, ...] | None = None,
        distractors: tuple[str, ...] | None = None,
        thresholds: Thresholds | None = None,
    ) -> None:
        self.language = (
            language_code if isinstance(language_code, Language) else language(language_code)
        )
        self.model: Any = load_model(find_model(self.language, model_dir))
        self.thresholds = thresholds or Thresholds()
        known = self._known
        self.yes_words = known(yes_words if yes_words is not None else self.language.yes_words)
        self.no_words = known(no_words if no_words is not None else self.language.no_words)
        if not self.yes_words or not self.no_words:
            raise ValueError("the model knows none of the yes words or none of the no words")
        answers = set(self.yes_words) | set(self.no_words)
        pool = distractors if distractors is not None else self.language.distractors
        self.distractors = tuple(d for d in known(pool) if d not in answers)
        self._grammar = json.dumps(
            [*self.yes_words, *self.no_words, *self.distractors], ensure_ascii=False
        )
        # Longest phrases first, to read a word sequence back into phrases.
        self._phrases = sorted(
            [(p.split(), p) for p in (*self.yes_words, *self.no_words, *self.distractors)],
            key=lambda item: -len(item[0]),
        )

    def _known(self, phrases: tuple[str, ...]) -> tuple[str, ...]:
        return tuple(p for p in phrases if all(in_vocabulary(self.model, w) for w in p.split()))

    def _decode(self, samples: np.ndarray) -> dict[str, Any]:
        import vosk  # type: ignore[import-untyped]

        recognizer = vosk.KaldiRecognizer(self.model, RATE, self._grammar)
        recognizer.SetWords(True)
        recognizer.AcceptWaveform(samples.tobytes())
        result: dict[str, Any] = json.loads(recognizer.FinalResult())
        return result

    def _phrases_of(self, words: list[str]) -> list[str]:
        phrases: list[str] = []
        index = 0
        while index < len(words):
            for parts, phrase in self._phrases:
                if words[index : index + len(parts)] == parts:
                    phrases.append(phrase)
                    index += len(parts)
                    break
            else:
                phrases.append(words[index])
                index += 1
        return phrases

    def meaning_of(self, phrase: str) -> Meaning | None:
        if phrase in self.yes_words:
            return "yes"
        if phrase in self.no_words:
            return "no"
        return None

    def recognize(self, samples: npt.NDArray[np.generic], sample_rate: int) -> Heard:
        """Decide what one recorded answer means (see the module docstring)."""
        started = time.perf_counter()
        audio = resample(as_int16(samples), sample_rate, RATE)
        if not activity(audio, RATE).is_speech(self.thresholds.min_speech_s):
            return Heard((), 0.0, None, "silence", decode_s=time.perf_counter() - started)
        result = self._decode(audio)
        entries = result.get("result", [])
        words = tuple(str(entry["word"]) for entry in entries)
        confidences = tuple(float(entry["conf"]) for entry in entries)
        confidence = min(confidences) if confidences else 0.0

        def heard(meaning: Meaning | None, reason: Reason | None) -> Heard:
            elapsed = time.perf_counter() - started
            return Heard(words, confidence, meaning, reason, confidences, elapsed)

        if not words:
            return heard(None, "silence")
        meanings = {self.meaning_of(p) for p in self._phrases_of(list(words))}
        if None in meanings:
            return heard(None, "out of grammar")
        if len(meanings) > 1:
            return heard(None, "ambiguous")
        if confidence < self.thresholds.min_confidence:
            return heard(None, "low confidence")
        return heard(meanings.pop(), None)

    def recognize_recording(self, recording: Recording) -> Heard:
        return self.recognize(recording.samples, recording.rate)
