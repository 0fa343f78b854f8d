"""`tandem execute ... --responses voice:SOURCE`: the voice wired from the options.

Everything the user can get wrong (no speech model, no microphone, no such
folder, a bad script) becomes one `BadInput` line, exit code 2. Each line the
robot says is printed as it is spoken, and each question's outcome says
whether the voice or the fallback answered.
"""

from __future__ import annotations

import argparse
import sys

from app.cli.exit_codes import BadInput
from app.execution.narration import Line, plan_language
from app.responses.voice import (
    DEFAULT_TIMES,
    Conversation,
    SpeechModels,
    VoiceListeners,
    VoiceResponses,
    dialogue_times,
    voice_responses,
)
from app.sources.outcomes import ConsoleSource, FallbackSource, RandomSource, ScriptError
from app.sources.voice import Attempt
from planner.plan.model import Plan
from planner.scenario.model import Human
from speech.devices import NoAudioDevice, play_local
from speech.languages import UnknownLanguage
from speech.models import NoSpeechModel


def print_line(line: Line) -> None:
    if line.utterance is None:
        print(f'      robot says (not spoken: {line.error}): "{line.text}"', file=sys.stderr)
    else:
        print(f'      robot says ({line.engine}): "{line.text}"', file=sys.stderr, flush=True)


class LocalSpeakers:
    """Plays each line on this machine's speakers before the robot listens (so a
    microphone does not hear the robot); without speakers, says so once."""

    def __init__(self) -> None:
        self.failed: str | None = None

    def __call__(self, line: Line) -> None:
        print_line(line)
        if line.utterance is None or self.failed is not None:
            return
        try:
            play_local(line.utterance)
        except (NoAudioDevice, ValueError) as error:
            self.failed = str(error)
            print(f"      (not played: {error})", file=sys.stderr)


def print_attempt(attempt: Attempt) -> None:
    verdict = attempt.meaning if attempt.accepted else f"refused: {attempt.reason}"
    print(
        f"      heard '{attempt.heard or '-'}' (confidence {attempt.confidence:.2f}, "
        f"try {attempt.number}): {verdict}",
        file=sys.stderr,
        flush=True,
    )


def print_fallback(node_id: str, reason: str) -> None:
    print(f"{node_id}: no voice answer ({reason}); a seeded choice", file=sys.stderr)


def print_mic_fallback(node_id: str, reason: str) -> None:
    print(f"{node_id}: no voice answer ({reason}); answer here", file=sys.stderr)


def print_lost(why: str) -> None:
    print(f"the voice has ended ({why}): the questions are answered here", file=sys.stderr,
          flush=True)  # fmt: skip


def print_unplayed(why: str) -> None:
    print(f"      (not played: {why})", file=sys.stderr)


def voice_from_args(
    args: argparse.Namespace, plan: Plan, seed: int | None, human: Human | None = None
) -> VoiceResponses:
    """The voice of `--responses voice:...`; the dialogue's times come from the
    scenario's `[human]` section (`human`; None for a plan file: the defaults)."""
    spec = args.responses[len("voice:") :]
    if not spec:
        raise BadInput("--responses voice:SOURCE: SOURCE is sim, mic or a folder of WAV files")
    code = args.language or plan_language(plan)
    speak = args.speak or ("local" if spec == "mic" else "none")
    mic = spec == "mic"
    # A microphone means a person: what the voice does not answer is theirs to type;
    # at the end of the input, a seeded choice.
    fallback = FallbackSource(ConsoleSource(sys.stdin, sys.stderr), RandomSource(seed)) if mic \
        else RandomSource(seed)  # fmt: skip
    conversation = Conversation(
        times=dialogue_times(human) if human is not None else DEFAULT_TIMES,
        seed=seed,
        human=args.human,
        speakers="local" if speak == "local" else "none",
    )
    # espeak-ng when played here: local playback takes WAV, gTTS gives MP3.
    speech = SpeechModels(model_dir=args.vosk_model,
                          engine="espeak" if speak == "local" else "auto")  # fmt: skip
    told = VoiceListeners(
        # The microphone's dialogue plays its lines itself (its ear must know when).
        on_line=LocalSpeakers() if speak == "local" and not mic else print_line,
        on_attempt=print_attempt,
        on_fallback=print_mic_fallback if mic else print_fallback,
        on_lost=print_lost,
        on_unplayed=print_unplayed,
    )
    try:
        return voice_responses(spec, code, fallback, conversation=conversation, speech=speech,
                               told=told)  # fmt: skip
    except (NoSpeechModel, NoAudioDevice, UnknownLanguage, ScriptError) as error:
        raise BadInput(f"--responses {args.responses}: {error}") from error
    except (FileNotFoundError, ValueError) as error:
        raise BadInput(f"--responses {args.responses}: {error}") from error
