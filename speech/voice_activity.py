"""Is there speech in a clip at all? An energy gate in front of the recogniser.

The clip is cut into 20 ms frames; the noise floor is the 10th percentile of
their levels (a clip is recorded with a pause around the answer). Frames more
than `margin_db` above the floor, and above an absolute `min_db`, are active.
Steady noise (fan, hiss) raises the floor with it and stays inactive; speech
is modulated, so its frames stand out. Less than `min_speech_s` of active
frames is silence.

`EndOfSpeech` cuts a live stream into utterances, `LiveUtterance` keeps one as
it arrives, and `EchoCanceller` takes the robot's own voice out of what the
microphone hears, so that what is active is the person.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from numpy.lib.stride_tricks import sliding_window_view

from speech.audio import RATE, Samples, level_db

FRAME_S = 0.02


@dataclass(frozen=True)
class Activity:
    speech_s: float
    floor_db: float
    peak_db: float
    active: npt.NDArray[np.bool_]  # one flag per 20 ms frame

    def is_speech(self, min_speech_s: float) -> bool:
        return self.speech_s >= min_speech_s


def frame_levels(samples: Samples, rate: int) -> npt.NDArray[np.float64]:
    """dBFS level of each 20 ms frame."""
    size = max(1, int(FRAME_S * rate))
    count = len(samples) // size
    if count == 0:
        return np.full(1, -100.0)
    frames = samples[: count * size].astype(np.float64).reshape(count, size) / 32768.0
    power = np.mean(frames * frames, axis=1)
    return np.asarray(10.0 * np.log10(np.maximum(power, 1e-10)))


def activity(
    samples: Samples, rate: int, margin_db: float = 12.0, min_db: float = -50.0
) -> Activity:
    levels = frame_levels(samples, rate)
    floor = float(np.percentile(levels, 10))
    active = (levels > floor + margin_db) & (levels > min_db)
    return Activity(
        speech_s=float(active.sum()) * FRAME_S,
        floor_db=floor,
        peak_db=float(levels.max()),
        active=active,
    )


@dataclass(frozen=True)
class SpeechSpan:
    """Where the speech of a clip is: from its first loud frame to the end of its last
    (seconds from the clip's first sample)."""

    start_s: float
    end_s: float

    @property
    def duration_s(self) -> float:
        return self.end_s - self.start_s


def speech_span(samples: Samples, rate: int, min_speech_s: float = 0.12) -> SpeechSpan | None:
    """The speech in a clip (`activity`'s loud frames), or None when it has less than
    `min_speech_s` of them (silence or steady noise, as the recognisers' gate)."""
    loud = activity(samples, rate)
    if not loud.is_speech(min_speech_s):
        return None
    frames = np.flatnonzero(loud.active)
    return SpeechSpan(float(frames[0]) * FRAME_S, float(frames[-1] + 1) * FRAME_S)


class EndOfSpeech:
    """Where an utterance ends in a live stream, block by block (the microphone's cut).

    The first `floor_s` set the noise floor; speech starts at a block `start_db`
    above it and ends after `pause_s` of blocks back under half that margin (or
    after `max_s` of speech: `too_long`). The pause is the price of every answer: the
    recogniser can only start once it has passed, so it is kept short (0.2 s:
    a yes/no answer has no pause inside, the same answers were heard right at
    0.2, 0.25 and 0.35 s, and only 0.2 s brings the end of speech to the
    decision under 0.3 s; `python -m speech.bench` measures it).
    """

    def __init__(
        self,
        block_s: float,
        start_db: float = 12.0,
        pause_s: float = 0.2,
        max_s: float = 8.0,
        floor_s: float = 0.3,
    ) -> None:
        self.block_s = block_s
        self.start_db = start_db
        self.pause_s = pause_s
        self.max_s = max_s
        self.floor_s = floor_s
        self.levels: list[float] = []
        self.floor: float | None = None
        self.started_at: int | None = None  # block index of the onset
        self._quiet = 0
        self.too_long = False  # ended by `max_s`, not by a pause

    def feed(self, block: Samples) -> bool:
        """Takes the next block; True once the utterance has ended."""
        loud = level_db(block)
        self.levels.append(loud)
        if self.floor is None:
            if len(self.levels) * self.block_s >= self.floor_s:
                self.floor = float(np.median(self.levels))
            return False
        if self.started_at is None:
            if loud > self.floor + self.start_db:
                self.started_at = len(self.levels) - 1
            return False
        self._quiet = self._quiet + 1 if loud < self.floor + self.start_db / 2 else 0
        if self._quiet * self.block_s >= self.pause_s:
            return True
        self.too_long = self.spoken_s >= self.max_s
        return self.too_long

    @property
    def spoken_s(self) -> float:
        """Seconds since the onset (0 before it)."""
        if self.started_at is None:
            return 0.0
        return (len(self.levels) - self.started_at) * self.block_s

    @property
    def quiet_s(self) -> float:
        """Seconds of quiet since the last loud block of the utterance."""
        return self._quiet * self.block_s

    def restart(self) -> None:
        """Ready for the next utterance of the same stream (the noise floor is kept)."""
        self.levels, self.started_at, self._quiet, self.too_long = [], None, 0, False


class LiveUtterance:
    """The blocks of a live stream that make one utterance, as they arrive.

    `push` each block; `EndOfSpeech` says where the utterance starts and ends,
    and the `pre_roll_s` before the onset are kept (the recogniser needs the
    lead-in). `feed`, when given (a recogniser's `Decoding.feed`), gets every
    block of the utterance as soon as it is known to belong to it, so decoding
    runs while the person speaks.
    """

    def __init__(
        self,
        cut: EndOfSpeech,
        feed: Callable[[Samples], None] | None = None,
        pre_roll_s: float = 0.3,
    ) -> None:
        self.cut = cut
        self.feed = feed
        self.pre_roll = int(round(pre_roll_s / cut.block_s))
        self.blocks: list[Samples] = []

    @property
    def started(self) -> bool:
        return self.cut.started_at is not None

    def push(self, block: Samples) -> bool:
        """Takes the next block; True once the utterance has ended."""
        self.blocks.append(block)
        was_started = self.started
        ended = self.cut.feed(block)
        if self.feed is not None and self.started:
            for piece in self.blocks[self._first() :] if not was_started else [block]:
                self.feed(piece)
        return ended

    def _first(self) -> int:
        return max(0, (self.cut.started_at or 0) - self.pre_roll)

    @property
    def first_block(self) -> int:
        """The index of the first block `samples` keeps (the pre-roll's first)."""
        return self._first()

    def samples(self) -> Samples:
        """The utterance so far, from the pre-roll on."""
        kept = self.blocks[self._first() :] if self.started else []
        return np.concatenate(kept) if kept else np.zeros(0, dtype=np.int16)


class EchoCanceller:
    """Subtracts the robot's own voice from what the microphone hears.

    The robot's audio (`add`) is placed on the stream's clock; each block is
    fitted by least squares against it through a 32-tap filter (2 ms), from the
    statistics of every block so far. That covers the simulated room (a direct
    path and one reflection, sample-aligned); a real room needs a longer filter
    and the playback delay found by correlation, which this does not do.
    """

    TAPS = 32

    def __init__(self) -> None:
        self._refs: list[tuple[int, npt.NDArray[np.float64]]] = []
        self._lock = threading.Lock()
        self._r = np.zeros((self.TAPS, self.TAPS))
        self._p = np.zeros(self.TAPS)
        self._learnt = 0  # samples of the robot's voice the fit has learnt from

    def add(self, samples: Samples, start_s: float) -> None:
        with self._lock:
            self._refs.append((int(round(start_s * RATE)), samples.astype(np.float64)))

    def cut(self, at_s: float) -> None:
        """The robot fell silent at `at_s`: nothing after it is subtracted."""
        cut = int(round(at_s * RATE))
        with self._lock:
            self._refs = [(start, audio[: max(0, cut - start)]) for start, audio in self._refs]

    def cancel(self, block: Samples, end_s: float) -> Samples:
        end = int(round(end_s * RATE))
        first = end - len(block) - self.TAPS + 1
        reference = np.zeros(len(block) + self.TAPS - 1)
        with self._lock:
            self._refs = [r for r in self._refs if r[0] + len(r[1]) + self.TAPS > first]
            for start, audio in self._refs:
                lo, hi = max(start, first), min(start + len(audio), end)
                if lo < hi:
                    reference[lo - first : hi - first] += audio[lo - start : hi - start]
        if not reference.any():
            return block
        taps = sliding_window_view(reference, self.TAPS)[:, ::-1]  # row n: x(n), x(n-1), ...
        heard = block.astype(np.float64)
        left = heard - taps @ self._fit()
        # A person speaking over the robot (far louder than what is left of the echo)
        # would bend the fit: once 0.5 s of the robot's voice is learnt, the statistics
        # learn from blocks that the fit explains.
        learning = self._learnt < RATE // 2
        if learning or np.mean(left * left) < 0.1 * np.mean(heard * heard):
            self._r += taps.T @ taps
            self._p += taps.T @ heard
            self._learnt += int(np.count_nonzero(reference[self.TAPS - 1 :]))
            left = heard - taps @ self._fit()
        cleaned: Samples = np.clip(np.round(left), -32768, 32767).astype(np.int16)
        return cleaned

    def _fit(self) -> npt.NDArray[np.float64]:
        ridge = 1e-6 * float(np.trace(self._r)) + 1e-9
        fit = np.linalg.solve(self._r + ridge * np.eye(self.TAPS), self._p)
        return np.asarray(fit, dtype=np.float64)
