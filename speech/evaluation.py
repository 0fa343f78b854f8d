"""A synthetic yes/no test set and its score, shared by the tests and the benchmark.

Answers: every answer phrase of a language (`speech.languages.KOREAN` or
`ENGLISH`; 12 each by default) spoken by seeded `SimulatedVoice`s (voice
variant, speed and pitch drawn per clip), half of them with white noise at
15-25 dB SNR. Non-answers: silence, noise of several kinds and levels, and
other words and sentences of the language, none of them a phrase of the
recogniser's distractor list (so the score is not that of a grammar that
already knows the test).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from speech.audio import RATE, Recording
from speech.languages import ENGLISH, KOREAN, Language
from speech.recognition import Heard, Meaning
from speech.sources import SimulatedVoice

# The seeds each language's thresholds were chosen on, and the seeds they were
# checked on afterwards without a change (Korean: `speech.vosk_recognition`,
# English: `speech.sphinx`).
TUNING_SEEDS = (7, 101, 33, 55)
HELD_OUT_SEEDS = (202, 303, 404)

KOREAN_YES = KOREAN.yes_words
KOREAN_NO = KOREAN.no_words
KOREAN_OTHER = (
    "안녕하세요", "다리를 잡아 주세요", "잠깐만요", "모르겠어요", "오늘 날씨가 좋네요",
    "나사를 주세요", "왼쪽으로", "다시 말해 주세요", "글쎄요", "뭐라고요",
    "상판을 올려요", "천천히 해 주세요", "고맙습니다", "여기 있어요",
)
ENGLISH_OTHER = (
    "hello there", "can you hold the leg", "just a second", "I am not certain",
    "the weather is lovely", "pass me the screw", "to the left", "say that again",
    "perhaps later", "what was that", "lift the top up", "carefully please",
    "excuse me", "where is it", "I need a break", "it looks fine", "hmm",
    "let me think", "which one", "how about the other leg",
)


@dataclass(frozen=True)
class Trial:
    recording: Recording
    expected: Meaning | None  # None: not an answer, must be refused
    label: str


@dataclass(frozen=True)
class Score:
    answers: int
    correct: int
    rejected: int
    wrong: int
    others: int
    others_rejected: int
    others_accepted: int
    # Per answer phrase: (clips, correct, rejected, wrong).
    by_phrase: dict[str, tuple[int, int, int, int]] = field(default_factory=dict)

    @property
    def correct_rate(self) -> float:
        return self.correct / self.answers if self.answers else 0.0

    @property
    def wrong_rate(self) -> float:
        return self.wrong / self.answers if self.answers else 0.0

    @property
    def others_rejected_rate(self) -> float:
        return self.others_rejected / self.others if self.others else 0.0

    def table(self) -> str:
        rows = [
            ("answers", self.answers, self.correct, self.rejected, self.wrong),
            ("non-answers", self.others, 0, self.others_rejected, self.others_accepted),
        ]
        lines = [f"{'clips':<12} {'n':>4} {'correct':>9} {'rejected':>9} {'wrong-acc':>9}"]
        for name, n, ok, refused, wrong in rows:
            def pct(k: int, total: int = n) -> str:
                return f"{100 * k / total:6.1f} %" if total else "     - "

            correct = pct(ok) if name == "answers" else "      - "
            lines.append(f"{name:<12} {n:>4} {correct:>9} {pct(refused):>9} {pct(wrong):>9}")
        return "\n".join(lines)

    def phrase_table(self) -> str:
        """Correct, rejected and wrong per answer phrase."""
        lines = [f"{'phrase':<12} {'n':>4} {'correct':>8} {'rejected':>9} {'wrong':>6}"]
        for phrase, (n, ok, refused, wrong) in self.by_phrase.items():
            lines.append(f"{phrase:<12} {n:>4} {ok:>8} {refused:>9} {wrong:>6}")
        return "\n".join(lines)


def total(scores: list[Score]) -> Score:
    """The scores of several seeds as one."""
    by_phrase: dict[str, tuple[int, int, int, int]] = {}
    for part in scores:
        for phrase, row in part.by_phrase.items():
            old = by_phrase.get(phrase, (0, 0, 0, 0))
            by_phrase[phrase] = (old[0] + row[0], old[1] + row[1], old[2] + row[2], old[3] + row[3])
    return Score(
        answers=sum(s.answers for s in scores),
        correct=sum(s.correct for s in scores),
        rejected=sum(s.rejected for s in scores),
        wrong=sum(s.wrong for s in scores),
        others=sum(s.others for s in scores),
        others_rejected=sum(s.others_rejected for s in scores),
        others_accepted=sum(s.others_accepted for s in scores),
        by_phrase=by_phrase,
    )


def _noise_clips(seed: int) -> list[Trial]:
    rng = np.random.default_rng(seed)
    second = np.arange(RATE) / RATE
    clips: list[tuple[str, np.ndarray]] = [
        ("digital silence", np.zeros(RATE)),
        ("room silence", rng.normal(0, 30, RATE)),
        ("quiet hiss", rng.normal(0, 300, RATE)),
        ("loud hiss", rng.normal(0, 3000, int(1.5 * RATE))),
        ("mains hum", 2000 * np.sin(2 * np.pi * 50 * second) + rng.normal(0, 100, RATE)),
        ("brown noise", np.cumsum(rng.normal(0, 60, RATE)) % 8000 - 4000),
    ]
    # A knock: one short burst in a quiet second.
    knock = rng.normal(0, 30, RATE)
    knock[8000:8400] += rng.normal(0, 8000, 400)
    clips.append(("knock", knock))
    trials = []
    for label, signal in clips:
        samples = np.clip(signal, -32768, 32767).astype(np.int16)
        trials.append(Trial(Recording(samples, RATE, f"noise:{label}"), None, label))
    return trials


def korean_trials(per_phrase: int = 12, seed: int = 7) -> list[Trial]:
    """Answers (`per_phrase` renderings of each, half noisy) and non-answers."""
    return trials_of(KOREAN, KOREAN_OTHER, per_phrase, seed)


def english_trials(per_phrase: int = 12, seed: int = 7) -> list[Trial]:
    """The English answers and non-answers (see `korean_trials`)."""
    return trials_of(ENGLISH, ENGLISH_OTHER, per_phrase, seed)


def trials_of(
    lang: Language, others: tuple[str, ...], per_phrase: int, seed: int
) -> list[Trial]:
    """Answers of `lang` (`per_phrase` renderings of each, half noisy) and non-answers."""
    clean = SimulatedVoice(lang, seed=seed)
    noisy = [SimulatedVoice(lang, seed=seed + snr, noise_snr_db=snr) for snr in (15, 20, 25)]
    trials: list[Trial] = []
    for meaning, phrases in (("yes", lang.yes_words), ("no", lang.no_words)):
        for phrase in phrases:
            for index in range(per_phrase):
                voice = clean if index % 2 == 0 else noisy[index // 2 % len(noisy)]
                expected: Meaning = "yes" if meaning == "yes" else "no"
                trials.append(Trial(voice.render(phrase), expected, phrase))
    for index, sentence in enumerate(others):
        voice = clean if index % 2 == 0 else noisy[index % len(noisy)]
        trials.append(Trial(voice.render(sentence), None, sentence))
    trials.extend(_noise_clips(seed))
    return trials


def score(trials: list[Trial], recognize: Callable[[Recording], Heard]) -> tuple[Score, list[str]]:
    """The score, and one line per clip that was not handled right."""
    counts = {"correct": 0, "rejected": 0, "wrong": 0, "others_rejected": 0, "others_accepted": 0}
    misses: list[str] = []
    by_phrase: dict[str, list[int]] = {}
    for trial in trials:
        heard = recognize(trial.recording)
        if trial.expected is None:
            key = "others_rejected" if heard.meaning is None else "others_accepted"
        elif heard.meaning is None:
            key = "rejected"
        else:
            key = "correct" if heard.meaning == trial.expected else "wrong"
        counts[key] += 1
        if trial.expected is not None:
            row = by_phrase.setdefault(trial.label, [0, 0, 0, 0])
            row[0] += 1
            row[("correct", "rejected", "wrong").index(key) + 1] += 1
        if key not in ("correct", "others_rejected"):
            misses.append(
                f"{key:<15} {trial.recording.origin:<45} -> {' '.join(heard.words) or '-'} "
                f"conf={heard.confidence:.2f} {heard.reason or heard.meaning}"
            )
    answers = sum(1 for t in trials if t.expected is not None)
    return Score(
        answers=answers,
        correct=counts["correct"],
        rejected=counts["rejected"],
        wrong=counts["wrong"],
        others=len(trials) - answers,
        others_rejected=counts["others_rejected"],
        others_accepted=counts["others_accepted"],
        by_phrase={phrase: (row[0], row[1], row[2], row[3]) for phrase, row in by_phrase.items()},
    ), misses
