"""Stop and continue, said at any time: their words and their grammar.

`Commands` hears the command phrases with the recogniser's rejection strategy:
the stop phrases stand where the yes words do, the continue phrases where the
no words do, and the answers and the language's distractor words absorb
everything else (where the engine has distractors: vosk's Korean).

While a question waits, the ear decodes each utterance with this grammar and
the answer grammar, and each forces what it hears into its own words. Decoded
whole (espeak-ng's voices, 12 seeds at three onsets, no pre-roll), "stop" was
taken as the answer "no" 18 times in 36, and "okay", "ok", "sure", "no" and
"nope" as a stop 3-6 times in 36; in Korean 멈춰 was taken as "yes" 12 times
in 36 and one voice's 맞아 as 멈춰. An utterance taken as both is the command:
a stop taken for an answer would move the robot on a false belief, an answer
taken for a stop only pauses it until the person says "continue". A grammar
of both (the commands where the yes words stand, the answers where the no
words do) was tried as an arbiter and dropped: through the ear (a noise floor,
the 0.3 s pre-roll) none of 72 English answers of those words was taken as a
command, and in Korean it still took 맞아 for 멈춰.
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

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
    """Stop and continue, heard with the rejection strategy of `Recognizer` (see the
    module)."""

    def __init__(self, language_code: str | Language, model_dir: Path | str | None = None):
        lang = language_code if isinstance(language_code, Language) else language(language_code)
        stop, go_on = COMMAND_WORDS[lang.code]
        distractors = (*lang.distractors, *lang.yes_words, *lang.no_words)
        self.recognizer = Recognizer(lang, model_dir, stop, go_on, distractors)

    def start(self) -> Decoding:
        return self.recognizer.start()

    @staticmethod
    def command_of(heard: Heard) -> Command | None:
        if heard.meaning == "yes":
            return "stop"
        return "continue" if heard.meaning == "no" else None
