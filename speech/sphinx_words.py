"""Common English words that compete with the answers: pocketsphinx's garbage model.

A grammar of the answers alone hears every sound as an answer. Put the
commonest words of English beside them, one phrase per utterance (`rival_grammar`),
and a word that is not an answer ("nose", "ball", a cough) is decoded as the
common word it sounds most like, while a real answer is still decoded as
itself. The words are the most probable unigrams of the language model in
pocketsphinx's wheel that its dictionary spells, less two kinds that would take
the answers' own sound: the answer words and their homophones ("know"), and
words one phone away from an answer word ("yet" from "yes", "oh" from "no",
"show" from "sure"), which espeak-ng's and real speakers' answers were decoded
as. With rivals two phones away left out too (`distance` 2), 26 words still took
espeak-ng's answers (`SYNTHETIC_SOUND_ALIKES`: "sure" heard as "love" or "john",
"go ahead" as "noticed" or "gotta", or live in the room's noise as "student");
they are left out as well, found by rounds of leaving out what took an answer
until none did (three of them, "gotta", "john" and "lot", once "not now" was no
longer an answer to keep its neighbours out). The list is made from the model once per process.
"""

from __future__ import annotations

import functools
from collections.abc import Iterable

Pronunciation = tuple[str, ...]

# Common words that won over espeak-ng's answers on `speech.evaluation.TUNING_SEEDS`
# and over the answer words of tests/test_speech_words.py's six voices, heard live
# (1000 rivals at 1e-9, more than two phones from every answer word); the held-out
# seeds had no say.
SYNTHETIC_SOUND_ALIKES = frozenset({
    "alone", "although", "began", "done", "gotta", "gotten", "hello", "john", "listen",
    "little", "london", "lot", "love", "loved", "notice", "noticed", "open", "playing",
    "saying", "somehow", "student", "students", "today", "total", "until", "within",
})  # fmt: skip


def _phone_distance(a: Pronunciation, b: Pronunciation) -> int:
    """Edits (phone insertions, deletions, substitutions) from `a` to `b`."""
    row = list(range(len(b) + 1))
    for i, phone in enumerate(a, 1):
        diagonal, row[0] = row[0], i
        for j, other in enumerate(b, 1):
            diagonal, row[j] = row[j], min(row[j] + 1, row[j - 1] + 1, diagonal + (phone != other))
    return row[-1]


def _dictionary() -> dict[str, set[Pronunciation]]:
    """pocketsphinx's US English dictionary: each word's pronunciations."""
    import pocketsphinx  # type: ignore[import-untyped]

    words: dict[str, set[Pronunciation]] = {}
    with open(pocketsphinx.get_model_path("en-us/cmudict-en-us.dict"), encoding="utf-8") as lines:
        for line in lines:
            word, *phones = line.split()
            words.setdefault(word.split("(")[0], set()).add(tuple(phones))
    return words


@functools.cache
def common_words(
    answer_words: frozenset[str], count: int, distance: int = 1
) -> tuple[str, ...]:
    """The `count` likeliest words of the language model, less the answers' sound-alikes
    (words `distance` phones or fewer from an answer word, and `SYNTHETIC_SOUND_ALIKES`)."""
    import pocketsphinx

    dictionary = _dictionary()
    model = pocketsphinx.NGramModel(
        pocketsphinx.Config(), pocketsphinx.LogMath(),
        pocketsphinx.get_model_path("en-us/en-us.lm.bin"),
    )  # fmt: skip
    answers = set().union(*(dictionary.get(word, set()) for word in answer_words))
    ranked = sorted(
        (
            word for word in dictionary
            if word.isalpha() and word not in answer_words
            and word not in SYNTHETIC_SOUND_ALIKES
        ),
        key=lambda word: (-model.prob([word]), word),
    )
    kept: list[str] = []
    for word in ranked:
        if not any(_phone_distance(p, a) <= distance for p in dictionary[word] for a in answers):
            kept.append(word)
            if len(kept) == count:
                break
    return tuple(kept)


def rival_grammar(answers: Iterable[str], rivals: Iterable[str], rival_weight: float) -> str:
    """JSGF: one answer phrase or one rival word; `rival_weight` is the rivals'
    prior beside the answers' 1 (under 1 favours the answers)."""
    return (
        "#JSGF V1.0;\ngrammar rivals;\n"
        f"public <s> = /1/ <answer> | /{rival_weight:g}/ <rival>;\n"
        f"<answer> = {' | '.join(answers)};\n"
        f"<rival> = {' | '.join(rivals)};\n"
    )
