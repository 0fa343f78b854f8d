"""Stop and continue, said at any time: their words, their grammar, and their check.

`Commands` hears the command phrases with the recogniser's rejection strategy:
the stop phrases stand where the yes words do, the continue phrases where the
no words do, and the answers and the language's distractor words absorb
everything else where the engine has distractors (vosk's Korean).
pocketsphinx has none, so its grammar of four command words forces the answers
into commands: with a microphone's noise floor (espeak-ng's voices, 12 seeds,
white noise at -60 dBFS as in the simulated room) it took "no" as "continue"
10 times in 12, "yes please" 8, "sure" 8 (7 as stop), "ok" 5 and "not now" 5
as stop. The ear then heard a command, not the answer: the question went
unanswered, and a "no" said while paused would resume the robot.

So a command is checked (`confirms`) against a grammar of both, the commands
where the yes words stand and the answers where the no words do: an utterance
that grammar takes as an answer is no command. A stop is kept unless it is
taken as an answer (stopping is always safe); a continue only when it is
taken as a command. Measured on the same clips: 34 of those 37 answers were
given back (the other 3, "not now", stayed a stop; it is no answer any more); of the
commands, stop was confirmed 11 times in 12, wait, continue and resume 12 in
12. In Korean the check confirmed every command the grammar took (its
distractors already hold the answers; one voice's 맞아 still sounds like
멈춰). The check decodes the utterance once more (pocketsphinx: two searches,
~70 ms on an idle machine, far more on a loaded one: a stop through the audio
device then paused the arm up to 0.99 s after the word), so the ear checks a
"continue", and a stop only while an answer is awaited; a stop mid-motion,
where the 0.5 s counts and no answer is asked for, is taken at once.
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from speech.audio import RATE, Samples
from speech.heard import Heard
from speech.languages import Language, language
from speech.recognition import Decoding, Recognizer

Command = Literal["stop", "continue"]

# Stop and continue phrases per language (words of the language's speech model).
COMMAND_WORDS: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    "ko": (("멈춰", "잠깐", "정지"), ("계속", "계속해")),
    "en-us": (("stop", "wait"), ("continue", "resume")),
}


class Commands:
    """Stop and continue, heard with the rejection strategy of `Recognizer`, and the
    grammar of commands and answers that checks them (see the module)."""

    def __init__(self, language_code: str | Language, model_dir: Path | str | None = None):
        lang = language_code if isinstance(language_code, Language) else language(language_code)
        stop, go_on = COMMAND_WORDS[lang.code]
        answers = (*lang.yes_words, *lang.no_words)
        self.recognizer = Recognizer(lang, model_dir, stop, go_on, (*lang.distractors, *answers))
        self.check = Recognizer(lang, model_dir, (*stop, *go_on), answers, lang.distractors)

    def start(self) -> Decoding:
        return self.recognizer.start()

    @staticmethod
    def command_of(heard: Heard) -> Command | None:
        if heard.meaning == "yes":
            return "stop"
        return "continue" if heard.meaning == "no" else None

    def confirms(self, command: Command, samples: Samples) -> bool:
        """Whether `command`, heard in `samples` (16 kHz), is one (see the module)."""
        taken = self.check.recognize(samples, RATE).meaning
        return taken != "no" if command == "stop" else taken == "yes"
