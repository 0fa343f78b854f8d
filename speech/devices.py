"""Sound devices through PortAudio (sounddevice): local playback and the check for them.

A machine without a sound card (a server, CI) has no default device; every
entry point here turns that into one `NoAudioDevice` whose message is a
single line, instead of PortAudio's "Error querying device -1".
"""

from __future__ import annotations

import os
from typing import Any, Literal

from speech.audio import read_wav
from speech.synthesis import Utterance

MICROPHONE_ENV = "TANDEM_MICROPHONE"


class NoAudioDevice(RuntimeError):
    """There is no sound device of the kind needed (or PortAudio is missing)."""


def input_devices() -> list[tuple[int, str]]:
    """(index, name) of every device with an input channel; empty without PortAudio."""
    try:
        sd = sounddevice_module()
        devices = sd.query_devices()
    except (NoAudioDevice, Exception):  # PortAudioError: no host API at all
        return []
    return [(i, str(d["name"])) for i, d in enumerate(devices) if d["max_input_channels"] > 0]


def microphone() -> int | None:
    """The input device `$TANDEM_MICROPHONE` names (an index or part of a name), else
    None for the system's default; `NoAudioDevice` when it names none."""
    wanted = os.environ.get(MICROPHONE_ENV, "").strip()
    if not wanted:
        return None
    devices = input_devices()
    for index, name in devices:
        if wanted == str(index) or wanted.lower() in name.lower():
            return index
    known = "; ".join(f"{i}: {n}" for i, n in devices) or "none"
    raise NoAudioDevice(f"${MICROPHONE_ENV}={wanted} names no input device (known: {known})")


def sounddevice_module() -> Any:
    """The sounddevice module, or `NoAudioDevice` when PortAudio cannot be loaded."""
    try:
        import sounddevice  # type: ignore[import-untyped]
    except OSError as error:  # libportaudio2 missing
        raise NoAudioDevice(f"no audio: PortAudio is not available ({error})") from None
    return sounddevice


def rescan() -> None:
    """PortAudio lists the devices once, when it starts: a device that appears later (a
    microphone plugged in, a sound server started) is seen after a rescan. Streams
    still open are closed by it."""
    sd = sounddevice_module()
    sd._terminate()
    sd._initialize()


def require_device(kind: Literal["input", "output"], device: int | None = None) -> Any:
    """sounddevice, after checking that `device` (else the default one of `kind`) exists."""
    sd = sounddevice_module()
    what = "microphone (input)" if kind == "input" else "speaker (output)"
    try:
        info = sd.query_devices(device, kind=kind)
    except sd.PortAudioError:
        raise NoAudioDevice(f"no {what} device on this machine") from None
    channels = info.get(f"max_{kind}_channels", 0) if isinstance(info, dict) else 0
    if not channels:
        raise NoAudioDevice(f"no {what} device on this machine")
    return sd


def play_local(utterance: Utterance, wait: bool = True) -> None:
    """Play a WAV utterance on this machine's speakers.

    MP3 utterances (gTTS) are for the browser; `ValueError` says so.
    """
    if utterance.format != "wav":
        raise ValueError(
            f"cannot play {utterance.format} locally (no decoder): play it in the browser "
            "or synthesize with engine='espeak'"
        )
    recording = read_wav(utterance.path)
    sd = require_device("output")
    try:
        sd.play(recording.samples, recording.rate)
        if wait:
            sd.wait()
    except sd.PortAudioError as error:
        raise NoAudioDevice(f"playback failed: {error}") from None
