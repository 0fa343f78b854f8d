"""`tandem listen`: one answer from the microphone (or a WAV file), and what was heard.

Prints the words, their confidence and the meaning taken, or why the answer
was refused. English is heard by pocketsphinx (its model installs with the
project), Korean by vosk; `--vosk-model` makes vosk hear any language. Exit 0
when an answer was taken, 1 when it was refused, 2 when there is no model, no
microphone or no such file.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from app.cli.exit_codes import BadInput
from speech.audio import read_wav
from speech.devices import MICROPHONE_ENV, NoAudioDevice, input_devices
from speech.languages import LANGUAGES, UnknownLanguage, language
from speech.models import NoSpeechModel
from speech.recognition import Recognizer
from speech.sources import MicrophoneSource


def register(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--wav", metavar="FILE", help="a recorded answer instead of the microphone")
    parser.add_argument(
        "--words",
        metavar="YES,NO",
        help="the yes word(s) and the no word(s), a comma between the two and + between "
        "alternatives (default: the language's answer words)",
    )
    parser.add_argument("--language", choices=sorted(LANGUAGES), default="en-us")
    parser.add_argument(
        "--vosk-model",
        metavar="DIR",
        help="a vosk model directory (default: pocketsphinx's bundled model for English, "
        "the packaged vosk model for Korean)",
    )
    parser.add_argument(
        "--timeout", type=float, default=8.0, help="seconds to wait for speech (default 8)"
    )
    parser.add_argument(
        "--devices",
        action="store_true",
        help=f"list the microphones (choose one: ${MICROPHONE_ENV}=INDEX or part of a name)",
    )
    parser.set_defaults(run=run)


def _words(spec: str | None) -> tuple[tuple[str, ...] | None, tuple[str, ...] | None]:
    if spec is None:
        return None, None
    sides = spec.split(",")
    if len(sides) != 2 or not all(side.strip() for side in sides):
        raise BadInput(f"--words {spec}: expected YES,NO (e.g. 네+좋아요,아니요)")
    yes, no = (tuple(w.strip() for w in side.split("+") if w.strip()) for side in sides)
    return yes, no


def run(args: argparse.Namespace) -> int:
    if args.devices:
        devices = input_devices()
        for index, name in devices:
            print(f"{index}: {name}")
        if not devices:
            print("no microphone on this machine")
        return 0
    yes, no = _words(args.words)
    try:
        recognizer = Recognizer(language(args.language), args.vosk_model, yes, no)
    except (NoSpeechModel, UnknownLanguage, ValueError) as error:
        raise BadInput(str(error)) from error
    if args.wav:
        path = Path(args.wav)
        if not path.is_file():
            raise BadInput(f"--wav {path}: no such file")
        try:
            recording = read_wav(path)
        except Exception as error:  # wave.Error, EOFError: not a WAV file
            raise BadInput(f"--wav {path}: not a readable WAV file ({error})") from error
        heard = recognizer.recognize_recording(recording)
    else:
        try:
            microphone = MicrophoneSource()
        except NoAudioDevice as error:
            raise BadInput(f"{error}; give a recording with --wav FILE") from error
        print(f"listening ({recognizer.language.name}: {', '.join(recognizer.yes_words)} "
              f"/ {', '.join(recognizer.no_words)})...", flush=True)  # fmt: skip
        decoding = recognizer.start()  # decoded while it is spoken
        if microphone.listen(args.timeout, decoding.feed) is None:
            print("heard nothing")
            return 1
        heard = decoding.finish()
    words = " ".join(heard.words) or "-"
    if heard.accepted:
        print(f"heard '{words}' confidence {heard.confidence:.2f}: {heard.meaning}")
        return 0
    print(f"refused ({heard.reason}): heard '{words}' confidence {heard.confidence:.2f}")
    return 1
