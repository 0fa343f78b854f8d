"""English yes/no answers on pocketsphinx's bundled US English model, and when to refuse.

The `pocketsphinx` wheel carries its acoustic model and dictionary, so English
is heard on a fresh machine with nothing to download (vosk's English model
comes from its own site). A closed grammar of the answers alone forces every
sound into "yes" or "no", so `recognize` measures how well the answer it
heard fits the sound (`Measures`) and accepts only when six checks pass:

1. **Energy gate** (`voice_activity`, as for vosk): under `min_speech_s` of
   speech frames is "silence".
2. **Answers grammar** (the yes and no phrases): every phrase heard must have
   one meaning, else "out of grammar" (nothing) or "ambiguous" (both).
3. **Word score**: the answer words' acoustic score per 10 ms frame (in the
   decoder's log units, 0 for the best senone of every frame) at least
   `min_word_score`, else "low confidence". Speech that is not an answer is
   forced into answer words that fit it badly.
4. **Phone loop**: a second decoding of the same audio with a free phone loop
   (pocketsphinx's allphone search, any sequence of English phones) scores the
   best the model can do with no grammar at all; the answers decoding may fall
   at most `min_phone_gap` per speech frame behind it, else "low confidence".
   Only where check 6 is off (`WITHOUT_RIVALS`, other words than the
   language's answers): beside check 6 it refused 0.1-0.2 % more of the real
   non-answers, cost 1-1.3 % of espeak-ng's answers and 40 ms an utterance.
5. **Coverage**: the answer words (widened by `coverage_pad_s`) must cover
   `min_coverage` of the speech frames, else "out of grammar": a sentence
   leaves most of its speech to the grammar's silence. Beside check 6,
   `min_coverage_with_rivals` (0.5): with the rival words catching sentences,
   0.6 refused answers the rivals let through (real tuning groups' answers
   87.2 % right at 0.6, 90.7 % at 0.5, non-answers refused 94.5 % and 94.0 %).
6. **Rival words** (a garbage model, `speech.sphinx_words`; on by default, off
   in `WITHOUT_RIVALS`): once the others pass, the utterance is decoded again
   in a grammar of one answer phrase or one of `rival_words` common English
   words (less the answers' sound-alikes), the words weighted `rival_weight`
   beside the answers; a common word winning is "out of grammar". Real
   people's words that are no answer ("nose", "hello", a laugh) fit some
   common word better than any answer. The rivals are for the language's own
   answer words: with other words (`tandem listen --words`, the stop and
   continue commands of `speech.commands`) check 6 is off, as it was never
   measured there.

Checks 1-5 were chosen on seeds 7, 101, 33, 55 of
`speech.evaluation.english_trials` (`TUNING_SEEDS`; 624 answers, 108
non-answers: 92.9 % right, 0 wrong, 94.4 % of non-answers refused) and then
checked, unchanged, on 202, 303, 404 (`HELD_OUT_SEEDS`: 468 answers, 81
non-answers: 91.2 %, 0 wrong, 95.1 %). The default (check 6 on, check 4 off,
coverage 0.5), on the answers left once "not now" was dropped
(`speech.languages.ENGLISH`; 576 and 432 answers): 96.0 %, 0.3 % wrong (2 of
576), 95.4 % and 93.1 %, 0.5 % (2 of 432), 97.5 %. Tried first and dropped: a second
decoding with ~80 distractor words beside the answers (the loop broke
multi-word answers into an answer and distractors, "no thanks" as "nope turn
this": 66 % of the answers taken on the tuning seeds, with the first answer
words), and the score margin between a yes-only and a no-only grammar (no
gain once the word score is checked).
Keyword spotting was not tried: its threshold per phrase would be tuned on a
few dozen clips each, where one word score serves every phrase. The answer
words were chosen by measurement too (`speech.languages.ENGLISH`).

Check 6 was chosen on real recorded speech (`speech.real_speech`, its tuning
speaker groups only; `python -m speech.bench` prints it with and without, the
held-out groups apart) and on espeak-ng's tuning seeds: over 100 to 2000 words
at weights 1e-3 to 1e-15 more words refuse more and a smaller weight keeps
more answers; 1000 words at 1e-9, leaving out words two phones from an answer
and the 26 that still took espeak-ng's answers (`SYNTHETIC_SOUND_ALIKES`). It
keeps every real answer the other checks take, takes none wrong (3 of 86
without: Hedgewars "Nooo"s heard as "go ahead" or "yeah"), and with check 4
off and coverage 0.5 the default takes 90.7 % and 90.6 % of the real answers
right on the tuning and held-out groups (87.2 % and 90.6 % with checks 1-5)
and refuses 94.7 % and 97.0 % of the real non-answers (72.6 % and 74.2 %). Before the
sound-alikes were left out, it cost 4-5 % of espeak-ng's answers, and was off
by default.

Every utterance is decoded whole at `finish` (batch normalisation of the
cepstra, noise statistics reset first), so a clip means the same whatever
was decoded before it. Without check 6, the two decodings took 74 ms median
(`speech.bench`, two shared cores), most of it the phone loop; the rival
words' decoding takes about 50 ms on an utterance the other checks accept,
and the phone loop is left out beside it. pocketsphinx
runs one search at a time on a decoder, so a lock lets threads share one
recogniser.
"""

from __future__ import annotations

import math
import threading
import time
import warnings
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt

from speech.audio import RATE, Recording, Samples, as_int16, resample
from speech.heard import Heard, Meaning, Reason, phrases_of
from speech.languages import Language, language
from speech.sphinx_words import common_words, rival_grammar
from speech.voice_activity import FRAME_S, Activity, activity

SPHINX_FRAME_S = 0.01  # pocketsphinx's frames are 10 ms
# The word score shown as a confidence: 1 for a perfect fit, 0.5 at the default
# threshold (-38 per frame), 0 at twice that.
CONFIDENCE_SCALE = 76.0


@dataclass(frozen=True)
class SphinxThresholds:
    min_speech_s: float = 0.12
    min_word_score: float = -38.0
    min_phone_gap: float = -45.0
    min_coverage: float = 0.6
    min_coverage_with_rivals: float = 0.5  # check 5 where check 6 runs too
    coverage_pad_s: float = 0.04
    rival_words: int = 1000  # common words beside the answers (0: check 6 is off)
    rival_weight: float = 1e-9  # their prior beside the answers' 1
    rival_distance: int = 2  # rivals this many phones or fewer from an answer word are left out


@dataclass(frozen=True)
class Word:
    word: str
    start_s: float
    end_s: float
    score: float  # acoustic, in the decoder's log units, summed over its frames


@dataclass(frozen=True)
class Measures:
    """What the two decodings of one utterance gave, before any threshold."""

    words: tuple[Word, ...]  # the answers grammar's words (no silences)
    speech: Activity
    word_score: float  # the answer words' acoustic score per frame
    phone_gap: float  # answers path minus the phone loop, per speech frame
    coverage: float  # share of the speech frames under the answer words


def _grammar(name: str, rule: str) -> str:
    return f"#JSGF V1.0;\ngrammar {name};\npublic <s> = {rule};\n"


# Check 6 off: what the rival words gain is measured against it (`speech.bench`).
WITHOUT_RIVALS = SphinxThresholds(rival_words=0)


class SphinxRecognizer:
    """A yes/no recogniser on pocketsphinx's bundled model (English only)."""

    def __init__(
        self,
        language_code: str | Language = "en-us",
        yes_words: tuple[str, ...] | None = None,
        no_words: tuple[str, ...] | None = None,
        thresholds: SphinxThresholds | None = None,
    ) -> None:
        import pocketsphinx  # type: ignore[import-untyped]

        self.language = (
            language_code if isinstance(language_code, Language) else language(language_code)
        )
        if not self.language.code.startswith("en"):
            raise ValueError(f"pocketsphinx's bundled model is English, not {self.language.name}")
        self.thresholds = thresholds or SphinxThresholds()
        self._decoder = pocketsphinx.Decoder(
            samprate=RATE, lm=None, jsgf=None, loglevel="FATAL", bestpath=False
        )
        # Scores come back as logbase ** score; thresholds are in those units.
        self._log_base = math.log(float(self._decoder.config["logbase"]))
        self._lock = threading.Lock()
        known = self._known
        self.yes_words = known(yes_words if yes_words is not None else self.language.yes_words)
        self.no_words = known(no_words if no_words is not None else self.language.no_words)
        if not self.yes_words or not self.no_words:
            raise ValueError("the model knows none of the yes words or none of the no words")
        answers = (*self.yes_words, *self.no_words)
        self._answer_words = {w for p in answers for w in p.split()}
        self._phrases = sorted([(p.split(), p) for p in answers], key=lambda item: -len(item[0]))
        self._decoder.add_jsgf_string("answers", _grammar("answers", " | ".join(answers)))
        # The rivals were chosen against the language's own answer words; other words
        # (`--words`, the stop and continue commands) were not measured with them.
        own = (self.yes_words, self.no_words) == (
            known(self.language.yes_words), known(self.language.no_words)
        )
        count = self.thresholds.rival_words if own else 0
        rivals = common_words(
            frozenset(self._answer_words), count, self.thresholds.rival_distance
        ) if count else ()
        if rivals:
            grammar = rival_grammar(answers, rivals, self.thresholds.rival_weight)
            self._decoder.add_jsgf_string("rivals", grammar)
        self._rivals = bool(rivals)
        # Check 4 only where check 6 is off: beside the rivals it refused almost
        # nothing more and cost 40 ms an utterance (see the module docstring).
        self._phone_loop = not self._rivals
        phones = pocketsphinx.get_model_path("en-us/en-us-phone.lm.bin")
        self._decoder.add_allphone_file("phones", phones)

    @property
    def description(self) -> str:
        return f"pocketsphinx ({self.language.code}, closed grammar)"

    def _known(self, phrases: tuple[str, ...]) -> tuple[str, ...]:
        lookup = self._decoder.lookup_word
        return tuple(p for p in phrases if all(lookup(w) for w in p.split()))

    def meaning_of(self, phrase: str) -> Meaning | None:
        if phrase in self.yes_words:
            return "yes"
        if phrase in self.no_words:
            return "no"
        return None

    def start(self) -> SphinxDecoding:
        """A decoding to feed an answer into as it is spoken (see `SphinxDecoding`)."""
        return SphinxDecoding(self)

    def recognize(self, samples: npt.NDArray[np.generic], sample_rate: int) -> Heard:
        """Decide what one recorded answer means (see the module docstring)."""
        started = time.perf_counter()
        return self.decide(resample(as_int16(samples), sample_rate, RATE), started)

    def recognize_recording(self, recording: Recording) -> Heard:
        return self.recognize(recording.samples, recording.rate)

    def _log(self, probability: float) -> float:
        return math.log(max(probability, 1e-300)) / self._log_base

    def _decode(self, search: str, audio: Samples) -> list[Word]:
        """Every segment of the best path, silences and fillers included."""
        decoder = self._decoder
        decoder.activate_search(search)
        with warnings.catch_warnings():
            # Deprecated, but it resets the noise statistics, which would
            # otherwise carry over from the utterance decoded before.
            warnings.simplefilter("ignore", DeprecationWarning)
            decoder.start_stream()
        decoder.start_utt()
        decoder.process_raw(audio.tobytes(), False, True)
        decoder.end_utt()
        return [
            Word(
                str(segment.word).split("(")[0],  # "yes(2)": a second pronunciation
                segment.start_frame * SPHINX_FRAME_S,
                (segment.end_frame + 1) * SPHINX_FRAME_S,
                self._log(float(segment.ascore)),
            )
            for segment in decoder.seg() or ()
        ]

    def _coverage(self, words: tuple[Word, ...], active: npt.NDArray[np.bool_]) -> float:
        covered = np.zeros(len(active), dtype=bool)
        pad = self.thresholds.coverage_pad_s
        for word in words:
            first = max(0, int((word.start_s - pad) / FRAME_S))
            covered[first : int(np.ceil((word.end_s + pad) / FRAME_S))] = True
        return float((covered & active).sum()) / max(1, int(active.sum()))

    def measure(self, audio: Samples) -> Measures:
        """The decodings of `audio` (16 kHz) and what the checks compare (the phone
        loop only where check 4 runs; `phone_gap` is -inf without it)."""
        speech = activity(audio, RATE)
        with self._lock:
            path = self._decode("answers", audio)
            phones = self._decode("phones", audio) if self._phone_loop else []
        words = tuple(w for w in path if w.word in self._answer_words)
        frames = sum(round((w.end_s - w.start_s) / SPHINX_FRAME_S) for w in words)
        word_score = sum(w.score for w in words) / frames if frames else -math.inf
        speech_frames = max(1.0, speech.speech_s / SPHINX_FRAME_S)
        gap = (
            (sum(w.score for w in path) - sum(p.score for p in phones)) / speech_frames
            if path and phones
            else -math.inf
        )
        return Measures(words, speech, word_score, gap, self._coverage(words, speech.active))

    def judge(self, measures: Measures, started: float) -> Heard:
        """The checks of the module docstring on what `measure` found."""
        limits = self.thresholds
        names = tuple(w.word for w in measures.words)
        confidence = min(1.0, max(0.0, 1.0 + measures.word_score / CONFIDENCE_SCALE))

        def heard(meaning: Meaning | None, reason: Reason | None) -> Heard:
            elapsed = time.perf_counter() - started
            return Heard(names, confidence if names else 0.0, meaning, reason, decode_s=elapsed)

        if not measures.speech.is_speech(limits.min_speech_s):
            return heard(None, "silence")
        meanings = {self.meaning_of(p) for p in phrases_of(list(names), self._phrases)}
        if not names or None in meanings:
            return heard(None, "out of grammar")
        if len(meanings) != 1:
            return heard(None, "ambiguous")
        meaning = next(iter(meanings))
        trails = self._phone_loop and measures.phone_gap < limits.min_phone_gap
        if measures.word_score < limits.min_word_score or trails:
            return heard(None, "low confidence")
        least = limits.min_coverage_with_rivals if self._rivals else limits.min_coverage
        if measures.coverage < least:
            return heard(None, "out of grammar")
        return heard(meaning, None)

    def rival(self, audio: Samples) -> str | None:
        """The common word that fits `audio` better than any answer (check 6), or None."""
        if not self._rivals:
            return None
        with self._lock:
            path = self._decode("rivals", audio)
        heard = [w.word for w in path if w.word.isalpha() and w.word not in self._answer_words]
        return heard[0] if heard else None

    def decide(self, audio: Samples, started: float) -> Heard:
        """What `audio` (16 kHz) means; `decode_s` counts from `started`."""
        if not activity(audio, RATE).is_speech(self.thresholds.min_speech_s):
            # Silence is refused without decoding.
            return Heard((), 0.0, None, "silence", decode_s=time.perf_counter() - started)
        heard = self.judge(self.measure(audio), started)
        if heard.accepted and self.rival(audio) is not None:
            # Decoded only once the other checks have passed: a refusal costs no more.
            return replace(heard, meaning=None, reason="out of grammar",
                           decode_s=time.perf_counter() - started)  # fmt: skip
        return heard


class SphinxDecoding:
    """One answer fed as it is spoken (16 kHz blocks), decoded at `finish`.

    The blocks are kept and both searches decode the whole utterance once the
    speaker has stopped: pocketsphinx's batch normalisation needs all of it, and
    a recording and a live stream are then decoded alike.
    """

    def __init__(self, recognizer: SphinxRecognizer) -> None:
        self.recognizer = recognizer
        self._chunks: list[Samples] = []

    def feed(self, block: npt.NDArray[np.generic]) -> None:
        self._chunks.append(as_int16(block))

    def finish(self, started: float | None = None) -> Heard:
        """What the answer fed so far means; `decode_s` counts from `started` (default: now)."""
        begun = time.perf_counter() if started is None else started
        audio = np.concatenate(self._chunks) if self._chunks else np.zeros(0, dtype=np.int16)
        return self.recognizer.decide(audio, begun)
