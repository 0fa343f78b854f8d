"""Korean (and any language given a vosk model): vosk with a closed grammar, and when to refuse.

A closed grammar forces every sound into one of its words, and the Korean
model has no `[unk]` word, so what the grammar hears cannot be trusted on its
own. Rejecting is cheap (the question is asked again, then falls back to a
click); accepting the wrong answer is the dangerous case. So `recognize`
accepts only when five checks pass, in this order:

1. **Energy gate** (`voice_activity`): less than 0.12 s of frames 12 dB above
   the clip's noise floor is "silence" (silence, hiss, hum, a knock).
2. **Answers grammar** (yes and no words only): every word heard must carry
   one meaning, else "ambiguous". A first word of at most `onset_s` (0.2 s)
   before a longer one is the answer's onset, not a word: espeak-ng's 아니요
   and 아니야 often start with a 0.18 s "좋아요" (the shortest its three
   syllables decode to), and dropping it turned those refusals into answers
   with no more wrong ones. The same rule reads every hypothesis below.
3. **Word confidence**: every word kept must have vosk's per-word confidence
   `min_word_confidence` (0.65) or more, else "low confidence". With the
   chosen answer words the misheard 네 (as 아니요) came out at 0.51-0.61,
   right answers mostly at 1.0.
4. **Margin**: the n-best list of the same grammar (8 hypotheses) must put
   the best hypothesis of the other meaning at least `min_margin` (log-score)
   below the best one, else "low confidence".
5. **Distractor grammar** (answers plus the language's distractor words):
   decoded again, the answer words (widened by `coverage_pad_s` each side,
   since vosk's word ends fall before the energy does) must have the same
   meaning and cover at least `min_coverage` of the speech frames, else "out
   of grammar": speech that is not an answer is decoded as distractors.
   Requiring the whole utterance to be an answer is what rejects sentences.

A free-form decoding (no grammar) beside the grammar one was measured and
dropped: on this model it took 0.6-1.2 s per clip and rarely produced the
right answer word even for clean answers.

The thresholds were tuned on seeds 7, 101, 33, 55 of `speech.evaluation` and
checked on 202, 303, 404 (504 answers, 147 non-answers in all): 89.5 % right,
0.4 % wrong, 93 % of non-answers refused. Before the onset rule, the word
confidence and the padding (margin 2.0): 86 %, 0.7 %, 93 %. Most of the gain
is the choice of answer words (`speech.languages`).

Audio is decoded in 30 ms blocks (`VoskDecoding`), as the microphone delivers it,
so a live answer is decoded while it is spoken and a recording is decoded
the same way.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from speech.audio import BLOCK, RATE, Recording, Samples, as_int16, resample
from speech.heard import Heard, Meaning, Reason, phrases_of
from speech.languages import Language, language
from speech.models import find_model, in_vocabulary, load_model
from speech.voice_activity import activity

FRAME_S = 0.02
# vosk decodes the same audio differently as a process goes on (its model keeps
# state from one recogniser to the next: alphacep/vosk-api#660). Measured: repeating
# one espeak-ng "네" 20 times in a process, the distractor grammar heard no word at
# all 5 times (alone, it hears 네). A grammar without [unk] that hears nothing where
# another grammar heard words has failed rather than refused, so that decoding is
# run again from the start, up to this many times.
EMPTY_RETRIES = 2


@dataclass(frozen=True)
class Thresholds:
    min_speech_s: float = 0.12
    onset_s: float = 0.2
    min_word_confidence: float = 0.65
    min_margin: float = 1.0
    min_coverage: float = 0.6
    coverage_pad_s: float = 0.04


class VoskRecognizer:
    """A yes/no recogniser on a vosk model (loaded once per process)."""

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
        self._answers = json.dumps([*self.yes_words, *self.no_words], ensure_ascii=False)
        self._with_distractors = json.dumps(
            [*self.yes_words, *self.no_words, *self.distractors], ensure_ascii=False
        )
        self._answer_words = {w for p in (*self.yes_words, *self.no_words) for w in p.split()}
        # Longest phrases first, to read a word sequence back into phrases.
        self._phrases = sorted(
            [(p.split(), p) for p in (*self.yes_words, *self.no_words, *self.distractors)],
            key=lambda item: -len(item[0]),
        )

    def _known(self, phrases: tuple[str, ...]) -> tuple[str, ...]:
        return tuple(p for p in phrases if all(in_vocabulary(self.model, w) for w in p.split()))

    @property
    def description(self) -> str:
        return f"vosk ({self.language.code}, closed grammar)"

    def start(self) -> VoskDecoding:
        """A decoding to feed an answer into as it is spoken (see `VoskDecoding`)."""
        return VoskDecoding(self)

    def _kaldi(self, grammar: str, alternatives: int = 0) -> Any:
        import vosk  # type: ignore[import-untyped]

        recognizer = vosk.KaldiRecognizer(self.model, RATE, grammar)
        if alternatives:
            recognizer.SetMaxAlternatives(alternatives)
        recognizer.SetWords(True)
        return recognizer

    def _phrases_of(self, words: list[str]) -> list[str]:
        return phrases_of(words, self._phrases)

    def meaning_of(self, phrase: str) -> Meaning | None:
        if phrase in self.yes_words:
            return "yes"
        if phrase in self.no_words:
            return "no"
        return None

    def _meanings(self, words: list[str]) -> set[Meaning | None]:
        return {self.meaning_of(p) for p in self._phrases_of(words)}

    def _without_onset(self, entries: list[dict[str, Any]]) -> list[dict[str, Any]]:
        """`entries` without a short first word before a longer one (see rule 2)."""
        if len(entries) >= 2:
            first = entries[0]
            if float(first["end"]) - float(first["start"]) <= self.thresholds.onset_s:
                return entries[1:]
        return entries

    def _margin(self, decoded: dict[str, Any], meaning: Meaning) -> float:
        """Log-score lead of the best hypothesis over the best of another meaning."""
        hypotheses = decoded.get("alternatives", [])
        scores = [
            (
                float(h["confidence"]),
                self._meanings(
                    [str(e["word"]) for e in self._without_onset(list(h.get("result", [])))]
                ),
            )
            for h in hypotheses
        ]
        if not scores:
            return 0.0
        own = [score for score, meanings in scores if meanings == {meaning}]
        rivals = [score for score, meanings in scores if meanings != {meaning}]
        if not own:
            return 0.0
        return max(own) - max(rivals) if rivals else float("inf")

    def _coverage(
        self, decoded: dict[str, Any], meaning: Meaning, active: npt.NDArray[np.bool_]
    ) -> float:
        """Share of the speech frames that the distractor grammar hears as `meaning`."""
        entries = self._without_onset(list(decoded.get("result", [])))
        words = [str(entry["word"]) for entry in entries]
        phrases = self._phrases_of(words)
        if {self.meaning_of(p) for p in phrases} - {None} != {meaning}:
            return 0.0
        covered = np.zeros(len(active), dtype=bool)
        pad = int(round(self.thresholds.coverage_pad_s / FRAME_S))
        for entry in entries:
            if str(entry["word"]) in self._answer_words:
                first = max(0, int(float(entry["start"]) / FRAME_S) - pad)
                covered[first : int(np.ceil(float(entry["end"]) / FRAME_S)) + pad] = True
        return float((covered & active).sum()) / max(1, int(active.sum()))

    def recognize(self, samples: npt.NDArray[np.generic], sample_rate: int) -> Heard:
        """Decide what one recorded answer means (see the module docstring)."""
        started = time.perf_counter()
        audio = resample(as_int16(samples), sample_rate, RATE)
        if not activity(audio, RATE).is_speech(self.thresholds.min_speech_s):
            return Heard((), 0.0, None, "silence", decode_s=time.perf_counter() - started)
        decoding = self.start()
        for first in range(0, len(audio), BLOCK):
            decoding.feed(audio[first : first + BLOCK])
        return decoding.finish(started)

    def decide(
        self, audio: Samples, answers: dict[str, Any], nbest: dict[str, Any],
        distractors: dict[str, Any], started: float,
    ) -> Heard:  # fmt: skip
        """The checks of the module docstring on the three decodings of `audio`."""
        speech = activity(audio, RATE)
        entries = answers.get("result", [])
        words = tuple(str(entry["word"]) for entry in entries)
        confidences = tuple(float(entry["conf"]) for entry in entries)
        confidence = min(confidences) if confidences else 0.0

        def heard(meaning: Meaning | None, reason: Reason | None) -> Heard:
            elapsed = time.perf_counter() - started
            return Heard(words, confidence, meaning, reason, confidences, elapsed)

        if not speech.is_speech(self.thresholds.min_speech_s):
            return heard(None, "silence")
        if not words:
            return heard(None, "out of grammar")
        kept = self._without_onset(list(entries))
        meanings = self._meanings([str(entry["word"]) for entry in kept])
        if None in meanings or len(meanings) != 1:
            return heard(None, "ambiguous" if len(meanings - {None}) > 1 else "out of grammar")
        meaning = next(iter(meanings))
        assert meaning is not None
        if min(float(e["conf"]) for e in kept) < self.thresholds.min_word_confidence:
            return heard(None, "low confidence")
        if self._margin(nbest, meaning) < self.thresholds.min_margin:
            return heard(None, "low confidence")
        if self._coverage(distractors, meaning, speech.active) < self.thresholds.min_coverage:
            return heard(None, "out of grammar")
        return heard(meaning, None)

    def recognize_recording(self, recording: Recording) -> Heard:
        return self.recognize(recording.samples, recording.rate)


class VoskDecoding:
    """One answer decoded while it is spoken: `feed` 16 kHz blocks, then `finish`.

    The three decodings (the answers, their n-best list, the answers with the
    distractors) take each block as it comes, so once the speaker has stopped
    only their last step is left: the answer follows the end of the
    microphone's pause by some 10-40 ms instead of a whole decoding (100 ms and
    more on a busy machine). `VoskRecognizer.recognize` feeds a recording the same
    way, in 30 ms blocks, so a recording and a live stream are decoded alike
    (vosk's results depend slightly on how the audio is cut into calls).
    """

    def __init__(self, recognizer: VoskRecognizer) -> None:
        self.recognizer = recognizer
        self._grammars = (
            (recognizer._answers, 0),
            (recognizer._answers, 8),
            (recognizer._with_distractors, 0),
        )
        self._decoders = tuple(recognizer._kaldi(*grammar) for grammar in self._grammars)
        self._chunks: list[Samples] = []

    def feed(self, block: npt.NDArray[np.generic]) -> None:
        chunk = as_int16(block)
        self._chunks.append(chunk)
        data = chunk.tobytes()
        for decoder in self._decoders:
            decoder.AcceptWaveform(data)

    def finish(self, started: float | None = None) -> Heard:
        """What the answer fed so far means; `decode_s` counts from `started` (default: now)."""
        begun = time.perf_counter() if started is None else started
        audio = np.concatenate(self._chunks) if self._chunks else np.zeros(0, dtype=np.int16)
        results = [json.loads(decoder.FinalResult()) for decoder in self._decoders]
        if any(_has_words(result) for result in results):
            results = [
                result if _has_words(result) else self._again(grammar)
                for result, grammar in zip(results, self._grammars, strict=True)
            ]
        answers, nbest, distractors = results
        return self.recognizer.decide(audio, answers, nbest, distractors, begun)

    def _again(self, grammar: tuple[str, int]) -> dict[str, Any]:
        """The utterance decoded anew in `grammar`, up to `EMPTY_RETRIES` times, until
        it hears a word (see `EMPTY_RETRIES`)."""
        result: dict[str, Any] = {}
        for _ in range(EMPTY_RETRIES):
            decoder = self.recognizer._kaldi(*grammar)
            for chunk in self._chunks:
                decoder.AcceptWaveform(chunk.tobytes())
            result = json.loads(decoder.FinalResult())
            if _has_words(result):
                break
        return result


def _has_words(decoded: dict[str, Any]) -> bool:
    """Whether a vosk result (one hypothesis, or an n-best list) holds a word."""
    if "alternatives" in decoded:
        return any(h.get("result") for h in decoded["alternatives"])
    return bool(decoded.get("result"))
