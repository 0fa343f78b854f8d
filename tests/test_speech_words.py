"""Every answer word of both languages, said by several voices, is heard as an answer.

The live ear decodes each utterance with the command grammar as well as the
answer grammar. pocketsphinx's grammar of four command words took English
answers said over a microphone's noise floor for commands, and the question
went unanswered: through this test before `Commands.confirms`, "no" was taken
as "continue" by 5 voices of 6, "yes please" by 5, "nope" by 2, and "okay",
"ok", "sure" and "not now" as a stop now and then (56 of 78 English answers
right; then 76). Each word of the grammar, said by six seeded espeak-ng voices
(variant, speed, pitch) into a -60 dBFS noise floor, goes through the live ear
while a question waits, block by block as a device hands it over (without
waiting for the clock).

Two words were dropped from the answers by what this test heard (and a simulated
room's human, whose "not now" was refused as out of grammar): English "not now"
(pocketsphinx hears its "not" as silence and "now" as "no"; two voices' were a
stop) and Korean 됐어 (refused for 3 voices of 6, once as out of grammar). Now
every English word is right by all six voices (72 of 72). Not yet held, and so
not asserted as right (the recognisers', measured here): Korean 맞아 for 5 (one
voice's sounds like 멈춰 in every grammar, a stop, which only pauses) and 아니야
for 5 (one refused for low confidence); no word of either language is refused
as out of grammar.
"""

from __future__ import annotations

import threading
from collections import Counter

import numpy as np
import pytest

from speech.audio import BLOCK, RATE, Samples
from speech.dialogue import Answer, Commands, DialogueTimes, Ear, Hearing
from speech.languages import language
from speech.recognition import Recognizer
from speech.sources import SimulatedVoice

VOICES = range(6)
NOISE = 32768 * 10 ** (-60 / 20)  # the simulated room's noise floor


class Utterance:
    """One utterance in the noise floor, handed out block by block once `armed` (the
    ear waits for an answer), then the noise floor for ever."""

    def __init__(self, speech: Samples, seed: int) -> None:
        noise = np.random.default_rng(seed).normal(0, NOISE, RATE + len(speech))
        noise[RATE // 2 : RATE // 2 + len(speech)] += speech
        self.audio = np.clip(np.round(noise), -32768, 32767).astype(np.int16)
        self.armed = threading.Event()
        self._quiet = np.random.default_rng(seed + 1)
        self._read = 0

    @property
    def position_s(self) -> float:
        return self._read / RATE

    def read(self) -> Samples:
        self.armed.wait()
        start = self._read
        self._read += BLOCK
        if start + BLOCK <= len(self.audio):
            return self.audio[start : start + BLOCK]
        threading.Event().wait(0.002)  # the noise floor, a little slower than it comes
        return np.round(self._quiet.normal(0, NOISE, BLOCK)).astype(np.int16)


def heard(words: str, code: str, seed: int, recognizer: Recognizer, commands: Commands) -> str:
    """What the live ear made of `words` in voice `seed` while a question waited: the
    meaning, the command, or the refusal's reason."""
    utterance = Utterance(SimulatedVoice(code, seed=seed).render(words).samples, seed)
    ear = Ear(utterance, DialogueTimes(no_speech_s=1.0), commands, cancel_echo=False).start()
    got: list[Answer] = []
    waiting = threading.Thread(target=lambda: got.append(ear.answer(recognizer)))
    waiting.start()
    while ear._awaiting is None and waiting.is_alive():  # the wait has begun
        threading.Event().wait(0.001)
    utterance.armed.set()
    waiting.join(30)
    ear.close(1.0)
    assert got, "the answer wait never ended"
    commands_heard = [h.command for h in ear.heard if h.command is not None]
    if commands_heard:
        return f"command {commands_heard[0]}"
    hearing: Hearing | None = got[0].hearing
    if hearing is None:
        return str(got[0].reason)
    return hearing.meaning or str(hearing.reason)


def outcomes_of(code: str) -> dict[str, Counter[str]]:
    """Per answer word, what the live ear made of it by each voice ("right" for its
    own meaning)."""
    lang = language(code)
    recognizer, commands = Recognizer(code), Commands(code)
    outcomes: dict[str, Counter[str]] = {}
    for words in (*lang.yes_words, *lang.no_words):
        meaning = lang.meaning_of(words)
        for seed in VOICES:
            taken = heard(words, code, seed, recognizer, commands)
            outcomes.setdefault(words, Counter())[taken if taken != meaning else "right"] += 1
    print(f"\n{code}: { {words: dict(counts) for words, counts in outcomes.items()} }")
    return outcomes


@pytest.mark.parametrize(("code", "always"), [
    ("en-us", (*language("en-us").yes_words, *language("en-us").no_words)),
    ("ko", ("네", "좋아요", "아니요")),
])  # fmt: skip
def test_every_answer_word_is_heard_as_an_answer_by_several_voices(
    code: str, always: tuple[str, ...]
) -> None:
    outcomes = outcomes_of(code)
    table = {words: dict(counts) for words, counts in outcomes.items()}
    # No answer is ever the other answer, nor a "continue" (which would resume a pause).
    dangerous = {"yes", "no", "command continue"}
    assert not [w for w, counts in outcomes.items() if dangerous & set(counts)], table
    # "no" (the word once refused in a live run) and the words the recogniser holds: by
    # every voice.
    assert all(outcomes[words]["right"] == len(VOICES) for words in always), table
    # No answer word of either language is refused as out of grammar by any voice.
    assert not [w for w, counts in outcomes.items() if "out of grammar" in counts], table
