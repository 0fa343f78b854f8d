"""Sound devices through PortAudio (sounddevice): local playback and the check for them.

A machine without a sound card (a server, CI) has no default device; every
entry point here turns that into one `NoAudioDevice` whose message is a
single line, instead of PortAudio's "Error querying device -1".
"""

from __future__ import annotations

from typing import Any, Literal

from speech.audio import read_wav
from speech.synthesis import Utterance


class NoAudioDevice(RuntimeError):
    """There is no sound device of the kind needed (or PortAudio is missing)."""


def sounddevice_module() -> Any:
    """The sounddevice module, or `NoAudioDevice` when PortAudio cannot be loaded."""
    try:
        import sounddevice  # type: ignore[import-untyped]
    except OSError as error:  # libportaudio2 missing
        raise NoAudioDevice(f"no audio: PortAudio is not available ({error})") from None
    return sounddevice


def require_device(kind: Literal["input", "output"]) -> Any:
    """sounddevice, after checking that a default device of `kind` exists."""
    sd = sounddevice_module()
    what = "microphone (input)" if kind == "input" else "speaker (output)"
    try:
        info = sd.query_devices(kind=kind)
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
