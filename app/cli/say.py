"""`tandem say TEXT`: the robot's voice, to a file or the speakers.

gTTS needs Google's service; when it cannot be reached the offline voice
(espeak-ng) speaks instead, within a second, with one line saying so. The file
is written whole or not at all (a temporary file, then a rename).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from app.cli.exit_codes import BadInput
from speech.audio import write_atomically
from speech.devices import NoAudioDevice, play_local
from speech.languages import LANGUAGES, UnknownLanguage
from speech.synthesis import SynthesisError, Utterance, synthesize


def register(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("text", help="what to say")
    parser.add_argument(
        "-o", "--output", metavar="FILE", help="write the audio here (.wav; gTTS gives .mp3)"
    )
    parser.add_argument(
        "--engine",
        choices=["auto", "gtts", "espeak"],
        default="auto",
        help="gtts (Google, online), espeak (espeak-ng, offline) or auto (gTTS when it "
        "answers, else espeak-ng); default auto",
    )
    parser.add_argument("--language", choices=sorted(LANGUAGES), default="en-us")
    parser.set_defaults(run=run)


def speak(text: str, language: str, engine: str) -> Utterance:
    """The utterance; a failed gTTS falls back to espeak-ng with a line on stderr."""
    try:
        if engine == "gtts":
            try:
                return synthesize(text, language, "gtts")
            except SynthesisError as error:
                print(f"{error}; espeak-ng speaks instead", file=sys.stderr)
                return synthesize(text, language, "espeak")
        return synthesize(text, language, "espeak" if engine == "espeak" else "auto")
    except (SynthesisError, UnknownLanguage) as error:
        raise BadInput(str(error)) from error


def run(args: argparse.Namespace) -> int:
    started = time.perf_counter()
    utterance = speak(args.text, args.language, args.engine)
    elapsed = time.perf_counter() - started
    where = f"{utterance.engine} ({utterance.voice}), {utterance.duration_s:.2f} s of audio"
    if args.output:
        target = Path(args.output)
        if target.suffix.lower() != f".{utterance.format}":
            # No MP3 decoder here: gTTS's audio keeps its format and its suffix says so.
            target = target.with_suffix(f".{utterance.format}")
        write_atomically(target, utterance.path.read_bytes())
        print(f"{target}: {where}, made in {1000 * elapsed:.0f} ms")
        return 0
    print(f"{where}, made in {1000 * elapsed:.0f} ms")
    try:
        play_local(utterance)
    except (NoAudioDevice, ValueError) as error:
        raise BadInput(f"cannot play it here: {error}; write it with -o FILE.wav") from error
    return 0
