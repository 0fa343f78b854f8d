"""The simulated human's mouth: it answers the robot's questions aloud.

`SimulatedSpeaker`, told that the robot asked (the voice source's
`on_question`), chooses an answer among the node's options (seeded random, or
a script) and says one of the language's phrases for it through
`SimulatedVoice`. It never answers the node itself: the recogniser decides
what it said. `truth` tells the evidence what it really answered.
"""

from __future__ import annotations

import random
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field

from app.execution.evidence import Truth
from app.sources.voice import ANSWERS
from planner.plan.model import PlanNode
from speech.sources import SimulatedVoice


@dataclass(frozen=True)
class Said:
    """What the simulated human chose to answer at a node, and the words it used."""

    node_id: str
    label: str
    phrase: str


@dataclass
class SimulatedSpeaker:
    """The simulated human answering the robot's questions aloud.

    Seeded: at a question it chooses among the node's yes/no options at
    random, or takes the next label of `script` while it lasts, and says one
    of the language's phrases for that answer (chosen at random) into
    `voice`. Asked again at the same node, it keeps its answer and may word
    it differently, as a person repeating themselves would. `choices` keeps
    its answer per node, so agreement with what was recognised can be counted.
    """

    voice: SimulatedVoice
    seed: int | None = None
    script: Sequence[str] = ()
    choices: dict[str, str] = field(default_factory=dict)
    said: list[Said] = field(default_factory=list)

    def __post_init__(self) -> None:
        self._random = random.Random(self.seed)
        self._script: Iterator[str] = iter(self.script)

    def __call__(self, node_id: str, node: PlanNode, options: Sequence[str]) -> None:
        self.hear(node_id, node, options)

    def hear(self, node_id: str, node: PlanNode, options: Sequence[str]) -> Said:
        """The robot asked at `node_id`: choose (once per node) and say the answer."""
        label = self.choices.get(node_id)
        if label is None:
            label = self._choose(options)
            self.choices[node_id] = label
        words = self.voice.language.yes_words if label == "yes" else self.voice.language.no_words
        phrase = self._random.choice(words)
        self.voice.say(phrase)
        said = Said(node_id, label, phrase)
        self.said.append(said)
        return said

    def truth(self, node_id: str) -> Truth | None:
        """What it really answered at `node_id` and the words it used, if it was asked."""
        if node_id not in self.choices:
            return None
        words = tuple(s.phrase for s in self.said if s.node_id == node_id)
        return Truth(self.choices[node_id], words)

    def _choose(self, options: Sequence[str]) -> str:
        answers = [o for o in options if o in ANSWERS]
        if not answers:
            raise ValueError(f"no yes/no answer among {', '.join(options)}")
        scripted = next(self._script, None)
        if scripted is not None:
            if scripted not in answers:
                raise ValueError(f"scripted answer '{scripted}' is not one of {', '.join(answers)}")
            return scripted
        return self._random.choice(answers)
