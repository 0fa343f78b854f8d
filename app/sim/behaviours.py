"""Simulated participants' behaviour: how a study's human answers the plan.

A behaviour wraps the answer channel's source (seeded clicks, the simulated
camera or the simulated voice) and decides, seeded per participant, where the
participant departs from what the channel would give:

- `cooperative`: never departs; every answer is the channel's seeded choice.
- `hesitant`: slower, and sometimes declines. Its reactions, answers and task
  actions take longer: the scenario's [human] paces, which the simulated
  timeline draws from (app.execution.timing), with their medians multiplied by
  `slower` (react x2, answer x2.5, attach and unhold x1.5); and at each
  question (a communication node with outcomes) it declines with probability
  `decline`: it takes an outcome other than the one the planner hoped for.
- `surprising`: at each sensing node, with probability `surprise`, does what
  no branch expects (picks up a loose part within reach, or puts down the part
  it holds) as a script's `!` line does (app.execution.surprises), so the
  executor repairs the plan; at most `max_surprises` times a session.

The departures use their own seeded stream, so where a hesitant or surprising
participant does not depart it answers as the cooperative one with its seed.
"""

from __future__ import annotations

import random
import threading
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

from app.execution.events import (
    Attachable,
    ExecutionControls,
    Interruptible,
    Outcome,
    OutcomeSource,
    describe,
)
from app.execution.surprises import HumanPutDown, HumanTook, Surprise, SurpriseError
from app.execution.timing import HumanActivity
from app.sessions.studies import BEHAVIOURS, Behaviour
from planner.plan.model import PlanNode
from planner.scenario.model import Human


@dataclass(frozen=True)
class BehaviourModel:
    """A behaviour's parameters (module docstring); the defaults are the documented ones."""

    name: Behaviour
    decline: float = 0.0  # chance of declining at a question
    # each human activity's median pace multiplied by this (1 when absent)
    slower: Mapping[HumanActivity, float] = field(default_factory=dict)
    surprise: float = 0.0  # chance of a surprise at a sensing node
    max_surprises: int = 1

    def human(self, human: Human) -> Human:
        """The scenario's [human] section with this behaviour's paces, which the
        simulated timeline draws the human's times from."""
        slower = {f"{a}_s": getattr(human, f"{a}_s") * f for a, f in self.slower.items()}
        return human.model_copy(update=slower)


MODELS: dict[Behaviour, BehaviourModel] = {
    "cooperative": BehaviourModel("cooperative"),
    "hesitant": BehaviourModel(
        "hesitant",
        decline=0.3,
        slower={"react": 2.0, "answer": 2.5, "attach": 1.5, "unhold": 1.5},
    ),
    "surprising": BehaviourModel("surprising", surprise=0.25),
}
assert set(MODELS) == set(BEHAVIOURS)


class BehavingSource:
    """An `OutcomeSource`: the channel's `inner` source, departed from as `model` says.

    `reachable_parts` are the parts a surprise may pick up (those within the
    human's reach); `seed` makes the departures the same for the same participant.
    """

    def __init__(
        self,
        inner: OutcomeSource,
        model: BehaviourModel,
        seed: int,
        reachable_parts: Sequence[str] = (),
    ) -> None:
        self.inner = inner
        self.model = model
        self.reachable_parts = list(reachable_parts)
        # Its own stream: the channel's seeded choices stay those of a cooperative run.
        self._rng = random.Random(f"{model.name}:{seed}")
        self._lock = threading.Lock()
        self.surprises = 0
        self.declines = 0

    def interrupt(self) -> None:
        if isinstance(self.inner, Interruptible):
            self.inner.interrupt()

    # The channel is handed the execution as if it answered alone (the voice keeps
    # the dialogue's turns and the human's speech, a camera what it sees).
    def attach(self, controls: ExecutionControls) -> None:
        if isinstance(self.inner, Attachable):
            self.inner.attach(controls)

    def detach(self, controls: ExecutionControls) -> None:
        if isinstance(self.inner, Attachable):
            self.inner.detach(controls)

    def choose(self, node_id: str, node: PlanNode, options: Sequence[str]) -> Outcome | None:
        if node.kind == "communication" and len(options) > 1:
            declined = self._question(node, options)
            if declined is not None:
                return declined
        elif node.kind == "sensing" and options:
            surprise = self._surprise(node)
            if surprise is not None:
                return Outcome("", "scripted", 1.0, str(surprise), surprise=surprise)
        return self.inner.choose(node_id, node, options)

    def _question(self, node: PlanNode, options: Sequence[str]) -> Outcome | None:
        """A declining outcome, or None to let the channel answer."""
        with self._lock:
            declines = self._rng.random() < self.model.decline
            others = [o for o in options if o != node.expected]
            label = self._rng.choice(others) if declines and others else None
        if label is None:
            return None
        self.declines += 1
        return Outcome(label, "scripted", 1.0, describe(node.action, label))

    def _surprise(self, node: PlanNode) -> Surprise | None:
        """A surprise possible in the node's state, or None (most of the time)."""
        with self._lock:
            if self.surprises >= self.model.max_surprises:
                return None
            if self._rng.random() >= self.model.surprise:
                return None
            candidates: list[Surprise] = [HumanPutDown(p) for p in self.reachable_parts]
            candidates += [HumanTook(p) for p in self.reachable_parts]
            self._rng.shuffle(candidates)
        state = frozenset(node.state)
        for surprise in candidates:
            try:
                surprise.apply(state)
            except SurpriseError:
                continue
            self.surprises += 1
            return surprise
        return None
