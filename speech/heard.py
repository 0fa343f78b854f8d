"""What a recogniser made of one answer, whichever engine heard it."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

Meaning = Literal["yes", "no"]
Reason = Literal["silence", "low confidence", "out of grammar", "ambiguous"]


@dataclass(frozen=True)
class Heard:
    """What the recogniser made of one answer.

    `meaning` is "yes"/"no" only when accepted; otherwise `reason` says why
    it was refused and `words` still shows what the grammar decoding heard.
    """

    words: tuple[str, ...]
    confidence: float
    meaning: Meaning | None
    reason: Reason | None
    word_confidences: tuple[float, ...] = ()
    decode_s: float = 0.0

    @property
    def accepted(self) -> bool:
        return self.meaning is not None


def phrases_of(words: list[str], phrases: list[tuple[list[str], str]]) -> list[str]:
    """`words` read back into `phrases` (longest first), an unknown word standing alone."""
    found: list[str] = []
    index = 0
    while index < len(words):
        for parts, phrase in phrases:
            if words[index : index + len(parts)] == parts:
                found.append(phrase)
                index += len(parts)
                break
        else:
            found.append(words[index])
            index += 1
    return found
