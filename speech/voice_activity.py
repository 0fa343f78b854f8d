"""Is there speech in a clip at all? An energy gate in front of the recogniser.

The clip is cut into 20 ms frames; the noise floor is the 10th percentile of
their levels (a clip is recorded with a pause around the answer). Frames more
than `margin_db` above the floor, and above an absolute `min_db`, are active.
Steady noise (fan, hiss) raises the floor with it and stays inactive; speech
is modulated, so its frames stand out. Less than `min_speech_s` of active
frames is silence.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from speech.audio import Samples

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
