"""The recogniser's score on real recorded speech (`speech.real_speech`), tuning and held-out apart.

Each clip is heard as the microphone hands an utterance over: between
`PAUSE_S` of quiet before (the pre-roll) and after (the end-of-speech pause),
since the packages cut their clips tight around the voice.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from speech.audio import RATE, Recording, as_int16, resample
from speech.heard import Heard
from speech.real_speech import RealClip

PAUSE_S = 0.3
# The targets on real speech.
REAL_TARGETS = "targets: answers right >= 90 %, wrong <= 1 %, non-answers refused >= 95 %"


def as_heard(clip: RealClip) -> Recording:
    """The clip at 16 kHz between `PAUSE_S` of quiet, as the microphone's cut gives it."""
    recording = clip.recording()
    audio = resample(as_int16(recording.samples), recording.rate, RATE)
    quiet = np.zeros(int(PAUSE_S * RATE), dtype=np.int16)
    return Recording(np.concatenate([quiet, audio, quiet]), RATE, recording.origin)


@dataclass
class RealScore:
    """Counts over real clips: answers, mixed ("yes sir") and non-answers."""

    answers: int = 0
    right: int = 0
    wrong: int = 0
    mixed: int = 0
    mixed_taken: int = 0
    mixed_wrong: int = 0
    others: int = 0
    others_refused: int = 0
    # Non-answers per package: (clips, refused).
    by_package: dict[str, list[int]] = field(default_factory=dict)
    misses: list[str] = field(default_factory=list)

    @property
    def right_rate(self) -> float:
        return self.right / self.answers if self.answers else 0.0

    @property
    def wrong_rate(self) -> float:
        return self.wrong / self.answers if self.answers else 0.0

    @property
    def refused_rate(self) -> float:
        return self.others_refused / self.others if self.others else 0.0

    def add(self, clip: RealClip, heard: Heard) -> None:
        taken, meaning = heard.meaning is not None, heard.meaning
        if clip.kind == "answer":
            self.answers += 1
            self.right += meaning == clip.expected
            self.wrong += taken and meaning != clip.expected
        elif clip.kind == "mixed":
            self.mixed += 1
            self.mixed_taken += meaning == clip.expected
            self.mixed_wrong += taken and meaning != clip.expected
        else:
            self.others += 1
            self.others_refused += not taken
            row = self.by_package.setdefault(clip.package, [0, 0])
            row[0] += 1
            row[1] += not taken
        if (clip.kind == "other") == taken or (taken and meaning != clip.expected):
            words = " ".join(heard.words) or "-"
            self.misses.append(
                f"{clip.kind:<6} {clip.package}:{clip.said:<24} -> {words} "
                f"{heard.reason or heard.meaning}"
            )


def real_score(clips: list[RealClip], recognize: Callable[[Recording], Heard]) -> RealScore:
    result = RealScore()
    for clip in clips:
        result.add(clip, recognize(as_heard(clip)))
    return result


def real_scores(
    clips: list[RealClip], recognize: Callable[[Recording], Heard]
) -> tuple[RealScore, RealScore]:
    """The score on the tuning clips and, apart, on the held-out ones."""
    tuning = real_score([c for c in clips if not c.held_out], recognize)
    return tuning, real_score([c for c in clips if c.held_out], recognize)


def real_report(
    clips: list[RealClip], recognize: Callable[[Recording], Heard]
) -> tuple[str, RealScore, RealScore]:
    """The table on `clips` under a title line, and the two scores it shows."""
    tuning, held_out = real_scores(clips, recognize)
    groups = {c.group for c in clips}
    apart = {c.group for c in clips if c.held_out}
    title = (
        f"Accuracy on real recorded speech, {len(clips)} clips of {len(groups)} speaker "
        f"groups, {len(apart)} held out ({REAL_TARGETS})"
    )
    return f"{title}\n{real_table(tuning, held_out)}", tuning, held_out


def _pct(part: int, whole: int) -> str:
    return f"{100 * part / whole:6.1f} %" if whole else "     - "


def real_table(tuning: RealScore, held_out: RealScore) -> str:
    """Answers right/refused/wrong, mixed, non-answers refused: tuning and held-out apart."""
    lines = [f"{'real clips':<22} {'n':>5} {'right':>9} {'refused':>9} {'wrong':>9}"]
    for name, s in (("tuning", tuning), ("held-out", held_out)):
        refused = s.answers - s.right - s.wrong
        lines.append(
            f"{name + ' answers':<22} {s.answers:>5} {_pct(s.right, s.answers):>9} "
            f"{_pct(refused, s.answers):>9} {_pct(s.wrong, s.answers):>9}"
        )
        mixed_refused = s.mixed - s.mixed_taken - s.mixed_wrong
        lines.append(
            f"{name + ' yes sir...':<22} {s.mixed:>5} {_pct(s.mixed_taken, s.mixed):>9} "
            f"{_pct(mixed_refused, s.mixed):>9} {_pct(s.mixed_wrong, s.mixed):>9}"
        )
        taken = s.others - s.others_refused
        lines.append(
            f"{name + ' non-answers':<22} {s.others:>5} {'-':>9} "
            f"{_pct(s.others_refused, s.others):>9} {_pct(taken, s.others):>9}"
        )
    lines.append("non-answers refused per package (tuning + held-out):")
    packages = sorted({*tuning.by_package, *held_out.by_package})
    for package in packages:
        n, refused = (
            sum(s.by_package.get(package, [0, 0])[i] for s in (tuning, held_out)) for i in (0, 1)
        )
        lines.append(f"  {package:<20} {n:>5} {_pct(refused, n):>9}")
    return "\n".join(lines)
