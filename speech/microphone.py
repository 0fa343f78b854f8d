"""A microphone that listens all the time, and speakers the ear knows about.

`MicrophoneStream` is the `BlockStream` of a real input device (PortAudio,
through sounddevice): opened once, it hands out 30 ms blocks of 16 kHz audio
as they are recorded, for `speech.dialogue.Ear`. A device that cannot record
16 kHz is read at its own rate and each block resampled. A device that
disappears (unplugged, its sound server gone) raises `DeviceLost` from `read`,
one line; `close` releases the device and is safe to call twice.

`DeviceSpeakers` plays the robot's lines on an output device, one after the
other, and can be cut at once (`stop`): the ear is told where each line is on
the microphone's clock (`on_playing`), so it never takes the robot's own voice
for an answer.
"""

from __future__ import annotations

import threading
import time
import weakref
from collections.abc import Callable
from typing import Any

import numpy as np

from speech.audio import BLOCK, RATE, Recording, Samples, as_int16, resample, rms
from speech.devices import NoAudioDevice, microphone, require_device
from speech.sources import cut_utterance
from speech.voice_activity import EndOfSpeech

# Told each line as it starts to play: its 16 kHz samples and where, on the
# microphone's clock, the speakers begin to sound.
PlayingListener = Callable[[Samples, float], None]
INPUT_BUFFER_S = 0.2  # the input's buffer (see `MicrophoneStream._open`)
WRITE_S = 0.05  # the robot's line is written to the speakers in pieces this long
EARLY_S = 0.15  # how much earlier than the speakers' start a line may reach the microphone
OPEN: weakref.WeakSet[MicrophoneStream] = weakref.WeakSet()  # streams not yet closed


class DeviceLost(NoAudioDevice):
    """The sound device went away while it was in use."""


class MicrophoneStream:
    """The input device `$TANDEM_MICROPHONE` names (else the default), read live.

    `position_s` is the stream time at the end of the last block read; `wall_s`
    maps a stream time to the wall clock (from the earliest arrival of a block,
    less its stream time). `on_level` is told the RMS of each block (the
    dashboard's meter).
    """

    def __init__(self) -> None:
        self.device = microphone()
        self._sd = require_device("input", self.device)
        self.rate = self._device_rate()
        self.level = 0.0
        self.on_level: Callable[[float], None] | None = None
        self.overflows = 0  # blocks read after audio was lost (the reader was late)
        self._read = 0
        self._origin: float | None = None  # the wall time of stream time 0
        self._lock = threading.Lock()
        self._stream: Any = None
        self._closed = False
        self._open()
        OPEN.add(self)

    def _device_rate(self) -> int:
        try:
            self._sd.check_input_settings(device=self.device, samplerate=RATE, channels=1)
        except Exception:  # PortAudioError or ValueError: 16 kHz is not supported
            info = self._sd.query_devices(self.device, kind="input")
            return int(info["default_samplerate"])
        return RATE

    def _open(self) -> None:
        block = round(BLOCK * self.rate / RATE)
        try:
            # A buffer of 0.2 s, not PortAudio's 35 ms: a reader held up longer (the GIL, a
            # loaded machine) lost audio, and a word so cut was not heard.
            stream = self._sd.InputStream(
                device=self.device, samplerate=self.rate, channels=1, dtype="int16",
                blocksize=block, latency=INPUT_BUFFER_S,
            )  # fmt: skip
            stream.start()
        except self._sd.PortAudioError as error:
            raise NoAudioDevice(f"the microphone cannot be opened: {_one_line(error)}") from None
        self._stream, self._block = stream, block

    @property
    def name(self) -> str:
        info = self._sd.query_devices(self.device, kind="input")
        return str(info["name"])

    @property
    def position_s(self) -> float:
        return self._read / RATE

    @property
    def latency_s(self) -> float:
        stream = self._stream
        return float(stream.latency) if stream is not None else 0.0

    def wall_s(self, stream_s: float) -> float:
        """The wall time (epoch seconds) of stream time `stream_s`."""
        origin = self._origin if self._origin is not None else time.time() - self.position_s
        return origin + stream_s

    def now_s(self) -> float:
        """Stream time now, on the wall clock (what the device records at this moment)."""
        return time.time() - self.wall_s(0.0)

    def read(self) -> Samples:
        with self._lock:
            stream = self._stream
            if stream is None:
                raise DeviceLost("the microphone is closed")
            try:
                data, overflowed = stream.read(self._block)
            except Exception as error:  # PortAudioError: the device is gone
                raise DeviceLost(f"the microphone stopped: {_one_line(error)}") from None
        if overflowed:
            self.overflows += 1  # audio was lost before this block
        block = as_int16(data)
        if self.rate != RATE:
            block = resample(block, self.rate, RATE)
        block = _exact(block)
        self._read += BLOCK
        # A block arrives once recorded, often later (the device hands them over in
        # bursts): the earliest arrival less its stream time is the clock's origin.
        arrived = time.time() - self.position_s
        self._origin = arrived if self._origin is None else min(self._origin, arrived)
        self.level = rms(block)
        if self.on_level is not None:
            self.on_level(self.level)
        return block

    def listen(self, timeout_s: float) -> Recording | None:
        """One utterance, cut as `MicrophoneSource` cuts it (an `AudioSource`; not while an
        ear reads the stream: the blocks would be shared)."""
        cut = EndOfSpeech(BLOCK / RATE)
        heard = cut_utterance(self.read, lambda: self.wall_s(self.position_s), cut, timeout_s)
        if heard is None:
            return None
        return Recording(heard.samples, RATE, "microphone", heard.recorded_at)

    def close(self) -> None:
        """Releases the device (any thread; a read under way ends first)."""
        with self._lock:
            stream, self._stream = self._stream, None
            self._closed = True
        OPEN.discard(self)
        if stream is not None:
            try:
                stream.abort()
                stream.close()
            except Exception:  # already gone with its device
                pass

    @property
    def closed(self) -> bool:
        return self._closed


def close_all() -> None:
    """Closes every microphone still open (before PortAudio is restarted, which would
    pull a device from under its reader)."""
    for stream in list(OPEN):
        stream.close()


def _exact(block: Samples) -> Samples:
    """`BLOCK` samples (a resampled block may be one short or long)."""
    if len(block) == BLOCK:
        return block
    if len(block) > BLOCK:
        return block[:BLOCK]
    return np.concatenate([block, np.zeros(BLOCK - len(block), dtype=np.int16)])


def _one_line(error: BaseException) -> str:
    """The error's message on one line, without PortAudio's bracketed host details."""
    text = " ".join(str(error).split("[")[0].split()).rstrip(":")
    return text or type(error).__name__


class DeviceSpeakers:
    """The default output device, one line at a time (see the module).

    `clock` gives the microphone's stream time now; `on_playing` is told each
    line with where it may start on that clock: now, its audio led by the output
    latency (it sounds somewhere between).
    `failed` holds the first playback error (one line); later lines are not played.
    """

    def __init__(self, clock: Callable[[], float], on_playing: PlayingListener) -> None:
        self.clock = clock
        self.on_playing = on_playing
        self.failed: str | None = None
        self._turn = threading.Lock()  # one line at a time
        self._stopped = threading.Event()
        self._closed = False

    def play(self, samples: Samples, rate: int) -> None:
        """Plays `samples` to their end, or until `stop`; returns when done."""
        with self._turn:
            if self.failed is not None or self._closed:
                return
            self._stopped.clear()
            try:
                self._play(samples, rate)
            except (NoAudioDevice, Exception) as error:
                self.failed = f"the speakers failed: {_one_line(error)}"

    def _play(self, line: Samples, rate: int) -> None:
        sd = require_device("output")
        # Silence after the line: the last buffers were dropped when the stream closed.
        samples = np.concatenate([line, np.zeros(int(0.5 * rate), dtype=np.int16)])
        # Written, not played from a callback: PortAudio's callback thread, aborted on a
        # "stop", once failed to join ('pthread_join failed'), and a test run on a
        # machine at load 15 crashed in native code (not pinned down); a written stream
        # has no thread. A buffer of 0.3 s: a smaller one ran dry on a loaded machine,
        # and each gap made the line sound longer than its audio.
        stream = sd.OutputStream(samplerate=rate, channels=1, dtype="int16", latency=0.3)
        try:
            stream.start()
            latency = float(stream.latency)
            # Heard from a little before now (the stream started a moment ago, and the
            # sound server may pass it on at once) to its end after the output latency
            # (it may hold it that long): the lead is silence.
            lead = np.zeros(int((EARLY_S + latency) * RATE), dtype=np.int16)
            heard = np.concatenate([lead, resample(line, rate, RATE)])
            self.on_playing(heard, self.clock() - EARLY_S)
            step = int(WRITE_S * rate)
            for start in range(0, len(samples), step):
                if self._stopped.is_set():
                    stream.abort()  # what is buffered is dropped: silent at once
                    return
                stream.write(samples[start : start + step].reshape(-1, 1))
            stream.stop()  # returns once the buffered audio has been played
        finally:
            stream.close()

    def stop(self) -> None:
        """The line being played ends now."""
        self._stopped.set()

    def close(self, wait_s: float = 2.0) -> None:
        """The line being played ends and no other is played; returns once its output
        stream is closed (within `wait_s`): PortAudio restarted (or the process ending)
        with a stream still playing in another thread waited on it for ever."""
        self._closed = True
        self._stopped.set()
        if self._turn.acquire(timeout=wait_s):
            self._turn.release()
