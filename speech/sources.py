"""Where answers are heard from: one `AudioSource` protocol, three sources.

- `MicrophoneSource`: the default input device (sounddevice), cut by a simple
  end-of-speech detector (energy above the noise floor, then a pause).
- `WavFolderSource`: a folder of WAV files, one per question, in name order.
- `SimulatedVoice`: the simulated human says the answer it chose through
  espeak-ng (voice variant, speed and pitch drawn from a seeded generator,
  optional white noise), and `listen()` hands that recording over, so the
  whole dialogue runs through the real recogniser without hardware.

A dialogue that listens all the time (`speech.dialogue.Ear`) reads a
`BlockStream` instead: `SimulatedRoom` is the simulated one, a stream in real
time where the human's words and the robot's own voice (its echo) overlap.

Each keeps `level`, the RMS (0..1) of the last audio it produced, for the
dashboard's input-level indicator.
"""

from __future__ import annotations

import random
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import numpy as np
import numpy.typing as npt

from speech.audio import BLOCK, RATE, Recording, Samples, as_int16, read_wav, resample, rms
from speech.devices import microphone, require_device
from speech.languages import Language, language
from speech.synthesis import espeak_samples
from speech.voice_activity import FRAME_S, EndOfSpeech, LiveUtterance, activity


class AudioSource(Protocol):
    """Anything that can hand over what the human said next."""

    @property
    def level(self) -> float: ...

    def listen(self, timeout_s: float) -> Recording | None:
        """The next utterance, or None when nothing was said within `timeout_s`."""
        ...


class WavFolderSource:
    """The WAV files of a folder, one per `listen()`, in name order."""

    def __init__(self, folder: Path | str) -> None:
        self.folder = Path(folder)
        if not self.folder.is_dir():
            raise FileNotFoundError(f"no such folder of answers: {self.folder}")
        self._files = sorted(self.folder.glob("*.wav"))
        self._next = 0
        self.level = 0.0

    @property
    def remaining(self) -> int:
        return len(self._files) - self._next

    def listen(self, timeout_s: float) -> Recording | None:
        if self._next >= len(self._files):
            return None
        recording = read_wav(self._files[self._next])
        self._next += 1
        self.level = rms(recording.samples)
        return recording


class BlockStream(Protocol):
    """Live 16 kHz audio, one block at a time, as it is recorded (a dialogue's ear)."""

    @property
    def position_s(self) -> float:
        """Stream time at the end of the last block read."""
        ...

    def read(self) -> Samples:
        """The next block (`BLOCK` samples), waiting until it has been recorded."""
        ...


@dataclass(frozen=True)
class Span:
    """Where a sound is in a room's stream: all of it, and its loud part (the words)."""

    start_s: float
    end_s: float
    speech_start_s: float
    speech_end_s: float


class SimulatedRoom:
    """The air around a simulated microphone, recorded block by block in real time.

    Sounds are `play`ed at stream times and mixed with a faint white noise
    (`noise_db` dBFS, so the microphone has a noise floor); `read` hands out the
    next 30 ms block once the clock has reached its end, as a microphone
    would. The robot's own voice comes back through its speakers
    (`play_robot`): 50 ms after it is played, attenuated by `echo_gain`, after a
    direct path of 1 ms and one reflection, and one sentence after the other.
    """

    def __init__(self, seed: int | None = None, noise_db: float = -60.0, echo_gain: float = 0.5):
        self._lock = threading.Lock()
        self._sounds: list[tuple[int, npt.NDArray[np.float64], bool]] = []  # start, audio, robot
        self._noise = np.random.default_rng(seed)
        self._sigma = 32768.0 * 10 ** (noise_db / 20)
        self._echo = np.zeros(32)
        self._echo[16], self._echo[28] = echo_gain, 0.3 * echo_gain
        self._start = time.monotonic()
        self.origin = time.time()  # the wall time of stream time 0
        self._read = 0  # samples handed out
        self.robot_until_s = 0.0  # when the robot's last sentence ends
        self.level = 0.0

    def now_s(self) -> float:
        return time.monotonic() - self._start

    def wall_s(self, stream_s: float) -> float:
        """The wall time (epoch seconds) of stream time `stream_s`."""
        return self.origin + stream_s

    @property
    def position_s(self) -> float:
        return self._read / RATE

    def play(self, samples: Samples, at_s: float | None = None) -> Span:
        """`samples` heard from stream time `at_s` (default now); where they are."""
        audio = samples.astype(np.float64)
        with self._lock:
            return self._add(audio, self.now_s() if at_s is None else at_s)

    def play_robot(
        self, samples: Samples, told: Callable[[Samples, float], None] | None = None
    ) -> Span:
        """The robot's speakers: its sentence, after the one it is saying, as the
        microphone hears it (the room's echo path). `told` learns the samples and
        where they start before the microphone can hear any of them (an ear told
        once they were placed missed the robot's first words on a loaded machine)."""
        heard = np.convolve(samples.astype(np.float64), self._echo)
        with self._lock:
            # 50 ms of output latency, as a sound card has: who plays it learns where
            # it is before the microphone hears it.
            at = max(self.now_s() + 0.05, self.robot_until_s)
            place = None if told is None else lambda start_s: told(samples, start_s)
            span = self._add(heard, at, robot=True, told=place)
            self.robot_until_s = span.end_s
        return span

    def cut_robot(self) -> None:
        """The robot falls silent now (what it had left to say is not heard)."""
        with self._lock:
            cut = int(self.now_s() * RATE)
            self._sounds = [
                (start, audio[: max(0, cut - start)] if robot else audio, robot)
                for start, audio, robot in self._sounds
            ]
            self.robot_until_s = min(self.robot_until_s, cut / RATE)

    def _add(
        self,
        audio: npt.NDArray[np.float64],
        at_s: float,
        robot: bool = False,
        told: Callable[[float], None] | None = None,
    ) -> Span:
        """Places `audio` (under the lock): `told` its start before it can be read."""
        loud = activity(np.clip(audio, -32768, 32767).astype(np.int16), RATE)
        frames = np.flatnonzero(loud.active)
        first, last = (frames[0], frames[-1] + 1) if frames.size else (0, 0)
        # A time the stream has already passed (the caller was late, on a loaded
        # machine): heard from now, whole, not with its start cut off; the span says
        # where it really is (an echo canceller told the planned time subtracted a
        # start that was never heard, and its residue was taken for speech).
        start = max(int(round(at_s * RATE)), self._read)
        if told is not None:
            told(start / RATE)
        self._sounds.append((start, audio, robot))
        return Span(
            start / RATE, (start + len(audio)) / RATE,
            start / RATE + first * FRAME_S, start / RATE + last * FRAME_S,
        )  # fmt: skip

    def read(self) -> Samples:
        end = self._read + BLOCK
        wait = end / RATE - self.now_s()
        if wait > 0:
            time.sleep(wait)
        mixed = self._noise.normal(0.0, self._sigma, BLOCK)
        with self._lock:
            self._sounds = [s for s in self._sounds if s[0] + len(s[1]) > self._read]
            for start, audio, _ in self._sounds:
                lo, hi = max(start, self._read), min(start + len(audio), end)
                if lo < hi:
                    mixed[lo - self._read : hi - self._read] += audio[lo - start : hi - start]
            self._read = end  # under the lock: a sound added now starts after this block
        block: Samples = np.clip(np.round(mixed), -32768, 32767).astype(np.int16)
        self.level = rms(block)
        return block


class SimulatedVoice:
    """A simulated human who speaks its answers with espeak-ng.

    Seeded, each `say` draws a voice variant, a speed and a pitch, so
    answers differ the way speakers do; `noise_snr_db` adds white noise at
    that signal-to-noise ratio (None: clean). With a `room` (a live simulated
    microphone) the words are also spoken into the room, where they overlap
    whatever else is heard there.
    """

    def __init__(
        self,
        language_code: str | Language = "ko",
        seed: int | None = None,
        noise_snr_db: float | None = None,
        pause_s: float = 0.3,
        room: SimulatedRoom | None = None,
        reaction_s: float = 0.4,
    ) -> None:
        self.language = (
            language_code if isinstance(language_code, Language) else language(language_code)
        )
        self.room = room
        self.reaction_s = reaction_s
        self.spoken_at: Span | None = None  # where the last words are in the room
        self.answered_at: Span | None = None  # where the last answer (`say`) is in it
        self.said: list[Span] = []  # everything said into the room, in order
        self._random = random.Random(seed) if seed is not None else None
        self._noise = np.random.default_rng(seed)
        self.noise_snr_db = noise_snr_db
        self.pause_s = pause_s
        self._pending: Recording | None = None
        self.level = 0.0

    def render(self, text: str) -> Recording:
        """`text` spoken (with the pauses and noise), without queueing it."""
        voice, speed, pitch = self.language.espeak_voice, 175, 50
        if self._random is not None:
            voice += self._random.choice(self.language.espeak_variants)
            speed = self._random.randint(140, 200)
            pitch = self._random.randint(30, 75)
        speech = espeak_samples(text, voice, speed, pitch).astype(np.float64)
        pause = np.zeros(int(self.pause_s * RATE))
        signal = np.concatenate([pause, speech, pause])
        if self.noise_snr_db is not None:
            power = float(np.mean(speech * speech)) if speech.size else 0.0
            sigma = np.sqrt(power / 10 ** (self.noise_snr_db / 10))
            signal = signal + self._noise.normal(0.0, sigma, signal.size)
        samples = np.clip(np.round(signal), -32768, 32767).astype(np.int16)
        noise = "clean" if self.noise_snr_db is None else f"snr{self.noise_snr_db:g}"
        origin = f"simulated:{voice}:s{speed}:p{pitch}:{noise}:{text}"
        return Recording(samples=samples, rate=RATE, origin=origin)

    def say(self, answer_text: str) -> Recording:
        """Speak `answer_text`; the next `listen()` returns it. In a `room`, the words
        are also spoken into it, `reaction_s` after the robot has fallen silent."""
        self._pending = self.render(answer_text)
        if self.room is not None:
            at = max(self.room.now_s(), self.room.robot_until_s) + self.reaction_s
            self.spoken_at = self.answered_at = self.room.play(self._pending.samples, at)
            self.said.append(self.spoken_at)
        return self._pending

    def say_at(self, text: str, at_s: float) -> Recording:
        """Speak `text` into the room at stream time `at_s`, whatever the robot is doing
        (a "stop" said over the robot's voice); `spoken_at` says when the words are."""
        if self.room is None:
            raise ValueError("say_at needs a room to speak into")
        recording = self.render(text)
        self.spoken_at = self.room.play(recording.samples, at_s)
        self.said.append(self.spoken_at)
        return recording

    def listen(self, timeout_s: float) -> Recording | None:
        recording, self._pending = self._pending, None
        if recording is not None:
            self.level = rms(recording.samples)
        return recording


class MicrophoneSource:
    """The default microphone, one utterance per `listen()`.

    The utterance is cut by `voice_activity.EndOfSpeech` (the noise floor of
    the first 0.3 s, an onset `start_db` above it, then `pause_s` of quiet);
    0.3 s before the onset are kept. The device is `$TANDEM_MICROPHONE` (an
    index or part of a name, see `tandem listen --devices`), else the system's
    default. `on_level`, when set, is told the RMS of every 30 ms block while
    it listens (the dashboard's input-level meter). `NoAudioDevice` (one line)
    when there is no microphone.
    """

    BLOCK_S = 0.03

    def __init__(self, start_db: float = 12.0, pause_s: float = 0.2, max_s: float = 8.0) -> None:
        self.device = microphone()
        self._sd = require_device("input", self.device)
        self.start_db = start_db
        self.pause_s = pause_s
        self.max_s = max_s
        self.level = 0.0
        self.on_level: Callable[[float], None] | None = None

    def _rate(self) -> int:
        """16 kHz when the device can record it (then blocks go to the recogniser as
        they come), else the device's own rate."""
        try:
            self._sd.check_input_settings(device=self.device, samplerate=RATE, channels=1)
        except Exception:  # PortAudioError or ValueError: the rate is not supported
            return int(self._sd.query_devices(self.device, kind="input")["default_samplerate"])
        return RATE

    def listen(
        self, timeout_s: float, feed: Callable[[Samples], None] | None = None
    ) -> Recording | None:
        """The next utterance; `feed` (a `Decoding.feed`) gets its 16 kHz audio in
        30 ms blocks, while it is spoken when the device records at 16 kHz."""
        device_rate = self._rate()
        live = feed if device_rate == RATE else None
        block = int(self.BLOCK_S * device_rate)
        cut = EndOfSpeech(self.BLOCK_S, self.start_db, self.pause_s, self.max_s)
        with self._sd.InputStream(
            device=self.device, samplerate=device_rate, channels=1, dtype="int16"
        ) as stream:

            def read() -> Samples:
                data, _ = stream.read(block)
                return as_int16(data)

            # A block is read as soon as it is recorded: it ends now on the wall clock.
            heard = cut_utterance(read, time.time, cut, timeout_s, live, self._heard_level)
        if heard is None:
            return None
        samples = resample(heard.samples, device_rate, RATE)
        if feed is not None and live is None:
            # Another rate: resampled once it is all in, then decoded.
            for start in range(0, len(samples), BLOCK):
                feed(samples[start : start + BLOCK])
        return Recording(samples, RATE, "microphone", heard.recorded_at)

    def _heard_level(self, chunk: Samples) -> None:
        self.level = rms(chunk)
        if self.on_level is not None:
            self.on_level(self.level)


@dataclass(frozen=True)
class _Cut:
    samples: Samples
    recorded_at: float  # wall time of the first sample


def cut_utterance(
    read: Callable[[], Samples],
    clock: Callable[[], float],
    cut: EndOfSpeech,
    timeout_s: float,
    feed: Callable[[Samples], None] | None = None,
    on_block: Callable[[Samples], None] | None = None,
) -> _Cut | None:
    """The next utterance of a live stream, cut by `cut` (None: nobody spoke within
    `timeout_s`): each block as `read` hands it over, `clock` the wall time at the end
    of the block just read, so the utterance's first sample has a wall time. `feed`
    gets the utterance's blocks while it is spoken; `on_block` every block."""
    utterance = LiveUtterance(cut, feed)
    deadline = time.monotonic() + timeout_s
    ends: list[float] = []  # the wall time at the end of each block
    while True:
        chunk = read()
        ends.append(clock())
        if on_block is not None:
            on_block(chunk)
        if utterance.push(chunk):
            break
        if not utterance.started and time.monotonic() > deadline:
            return None
    return _Cut(utterance.samples(), ends[utterance.first_block] - cut.block_s)


class RoomMicrophone:
    """A microphone in a `SimulatedRoom`, heard as `MicrophoneSource` hears a device:
    one utterance per `listen()`, cut and timed by the same `cut_utterance` from the
    moment it starts listening (what the room heard before is dropped, as a device
    opened then would not have it)."""

    def __init__(
        self, room: SimulatedRoom, start_db: float = 12.0, pause_s: float = 0.2, max_s: float = 8.0
    ) -> None:
        self.room = room
        self.start_db = start_db
        self.pause_s = pause_s
        self.max_s = max_s
        self.level = 0.0

    def listen(
        self, timeout_s: float, feed: Callable[[Samples], None] | None = None
    ) -> Recording | None:
        room = self.room
        while room.position_s < room.now_s() - BLOCK / RATE:
            room.read()
        cut = EndOfSpeech(BLOCK / RATE, self.start_db, self.pause_s, self.max_s)
        heard = cut_utterance(
            room.read, lambda: room.wall_s(room.position_s), cut, timeout_s, feed, self._heard
        )
        if heard is None:
            return None
        return Recording(heard.samples, RATE, "room microphone", heard.recorded_at)

    def _heard(self, chunk: Samples) -> None:
        self.level = rms(chunk)
