"""Audio as numbers: recordings, WAV files, resampling and the input level.

Everything the recogniser sees is 16 kHz mono int16 (vosk's models are
trained on 16 kHz); espeak-ng speaks at 22,050 Hz, so audio is resampled here
in numpy (windowed-sinc low-pass, then linear interpolation), not with sox.
"""

from __future__ import annotations

import io
import os
import tempfile
import wave
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

RATE = 16_000
BLOCK = int(0.03 * RATE)  # 30 ms: what the microphone hands over, and a recogniser is fed

Samples = npt.NDArray[np.int16]


@dataclass(frozen=True)
class Recording:
    """Mono audio and where it came from ("microphone", a file path, "simulated:...").

    `recorded_at` is the wall time (epoch seconds) of its first sample when it was
    recorded live (a microphone); None for a file or a simulated voice, which have no
    time of their own.
    """

    samples: Samples
    rate: int
    origin: str
    recorded_at: float | None = None

    @property
    def duration_s(self) -> float:
        return len(self.samples) / self.rate if self.rate else 0.0


def as_int16(samples: npt.NDArray[np.generic]) -> Samples:
    """int16 samples from int16 or float (-1..1) input, mixed down to mono."""
    array = np.asarray(samples)
    if array.ndim == 2:  # frames x channels, as a device records them
        mixed = array.mean(axis=1)
        # The mean of integer samples is a float in their own scale, not -1..1: it
        # stays integer (a recording of 1 channel was once clipped to full scale).
        integer = not np.issubdtype(array.dtype, np.floating)
        array = np.round(mixed).astype(np.int64) if integer else mixed
    if np.issubdtype(array.dtype, np.floating):
        return (np.clip(array, -1.0, 1.0) * 32767).astype(np.int16)
    if array.dtype == np.int16:
        return array
    return np.clip(array, -32768, 32767).astype(np.int16)


def _low_pass(signal: npt.NDArray[np.float64], cutoff: float) -> npt.NDArray[np.float64]:
    """FIR low-pass at `cutoff` (fraction of the input rate), against aliasing."""
    taps = 63
    n = np.arange(taps) - (taps - 1) / 2
    kernel = 2 * cutoff * np.sinc(2 * cutoff * n) * np.hamming(taps)
    kernel /= kernel.sum()
    return np.convolve(signal, kernel, mode="same")


def resample(samples: Samples, rate: int, target: int = RATE) -> Samples:
    """`samples` at `rate` resampled to `target` Hz."""
    if rate == target or len(samples) == 0:
        return samples
    signal = samples.astype(np.float64)
    if target < rate:
        signal = _low_pass(signal, 0.5 * 0.9 * target / rate)
    count = int(round(len(signal) * target / rate))
    positions = np.arange(count) * (rate / target)
    out = np.interp(positions, np.arange(len(signal)), signal)
    resampled: Samples = np.clip(np.round(out), -32768, 32767).astype(np.int16)
    return resampled


def decode_wav(data: bytes) -> tuple[Samples, int]:
    """Mono int16 samples and rate from WAV bytes (8/16-bit PCM, any channels)."""
    with wave.open(io.BytesIO(data)) as reader:
        width, channels, rate = reader.getsampwidth(), reader.getnchannels(), reader.getframerate()
        frames = reader.readframes(reader.getnframes())
    if width == 2:
        array = np.frombuffer(frames, dtype="<i2").astype(np.int16)
    elif width == 1:
        array = ((np.frombuffer(frames, dtype=np.uint8).astype(np.int16) - 128) * 256).astype(
            np.int16
        )
    else:
        raise ValueError(f"unsupported WAV sample width: {width * 8} bits")
    if channels > 1:
        array = array.reshape(-1, channels).mean(axis=1).astype(np.int16)
    return array, rate


def read_wav(path: Path) -> Recording:
    samples, rate = decode_wav(path.read_bytes())
    return Recording(samples=samples, rate=rate, origin=str(path))


def encode_wav(samples: Samples, rate: int) -> bytes:
    buffer = io.BytesIO()
    with wave.open(buffer, "wb") as writer:
        writer.setnchannels(1)
        writer.setsampwidth(2)
        writer.setframerate(rate)
        writer.writeframes(samples.astype("<i2").tobytes())
    return buffer.getvalue()


def write_atomically(path: Path, data: bytes) -> None:
    """Write through a temporary file and a rename, so no reader sees half a file."""
    path.parent.mkdir(parents=True, exist_ok=True)
    handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=".", suffix=".part")
    try:
        with os.fdopen(handle, "wb") as stream:
            stream.write(data)
        os.replace(temporary, path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise


def rms(samples: npt.NDArray[np.generic]) -> float:
    """Root-mean-square level, 0..1 of full scale (for the input-level indicator)."""
    array = np.asarray(samples)
    if array.size == 0:
        return 0.0
    if np.issubdtype(array.dtype, np.floating):
        scaled = array.astype(np.float64)
    else:
        scaled = array.astype(np.float64) / 32768.0
    return float(np.sqrt(np.mean(scaled * scaled)))


def level_db(samples: npt.NDArray[np.generic]) -> float:
    """The RMS level in dBFS (-100 for digital silence)."""
    value = rms(samples)
    return max(-100.0, 20.0 * float(np.log10(value))) if value > 0 else -100.0
