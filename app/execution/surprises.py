"""Surprises: what a person did that no branch of the plan expects.

A surprise is observed at a node (a scripted line `!attach leg2 top c2`, or a
camera view that fits none of the node's outcomes). It turns the node's state
into the observed state; the executor then plans again from there (through the
repair it is given) and goes on with the new plan. Each kind is a typed value
that changes the state's fluents (`planner.vocabulary`) as the domain
(docs/domain.md) would after the human's action:

- `HumanTook(P)` (`take P`): the human picked P up; their hands hold P.
- `HumanPutDown(P)` (`putdown P`): the human put P (which they held) back on the bench.
- `HumanAttached(P, Q, C)` (`attach P Q C`): the human attached P to Q at point C.
- `HumanHandedBack(P, M)` (`handback P M`): the human put P into the robot's free hand M.
- `HumanDetached(P)` (`detach P`): the human took P off what it was attached to.

The words in brackets are the script's form: `parse_surprise` reads it and
`str()` writes it, the one place surprises are text.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import astuple, dataclass, fields
from typing import ClassVar

from planner.vocabulary import (
    AcceptToAttach,
    Attached,
    Declined,
    Fluent,
    Holding,
    HumanFree,
    HumanHolding,
    HumanHoldingPart,
    KeepsHolding,
    RequestedAttach,
    State,
    WantToAttach,
    parse_fluent,
)

# The human's tasks on a part: a surprise that moves the part makes them moot.
_TASKS = (WantToAttach, AcceptToAttach, RequestedAttach, Declined, KeepsHolding)


class SurpriseError(ValueError):
    """A surprise that is not well formed, or impossible in the node's state; one line."""


@dataclass(frozen=True)
class _Surprise:
    word: ClassVar[str]  # the script's word for it
    part: str

    def __str__(self) -> str:
        return " ".join((self.word, *(str(v) for v in astuple(self))))

    def words(self) -> str:
        """What the robot says it saw, before it adapts."""
        return f"I see {self._seen()}; I'll adapt."

    def _seen(self) -> str:
        raise NotImplementedError

    def apply(self, state: State) -> State:
        """The state after the surprise; `SurpriseError` when it cannot have happened."""
        world = _World({parse_fluent(text) for text in state})
        self._change(world)
        # The human's tasks on the part are done or moot (its own, not those onto it).
        kept = {f for f in world.fluents if not (isinstance(f, _TASKS) and f.part == self.part)}
        return frozenset(str(f) for f in kept)

    def _change(self, world: _World) -> None:
        raise NotImplementedError


@dataclass
class _World:
    """A state's fluents while a surprise changes them."""

    fluents: set[Fluent]

    def human_holds(self) -> str | None:
        return next((f.part for f in self.fluents if isinstance(f, HumanHoldingPart)), None)

    def drop_human_part(self, part: str) -> None:
        self.fluents -= {HumanHoldingPart(part), HumanHolding()}
        self.fluents.add(HumanFree())

    def require_loose(self, part: str, surprise: _Surprise) -> None:
        if any(isinstance(f, Attached) and f.part == part for f in self.fluents):
            raise SurpriseError(f"{surprise}: {part} is attached")
        if any(isinstance(f, Holding) and f.part == part for f in self.fluents):
            raise SurpriseError(f"{surprise}: the robot holds {part}")


@dataclass(frozen=True)
class HumanTook(_Surprise):
    word: ClassVar[str] = "take"

    def _seen(self) -> str:
        return f"you picked up the {self.part}"

    def _change(self, world: _World) -> None:
        held = world.human_holds()
        if held is not None:
            raise SurpriseError(f"{self}: the human already holds {held}")
        world.require_loose(self.part, self)
        world.fluents -= {HumanFree(), HumanHolding()}
        world.fluents |= {HumanHolding(), HumanHoldingPart(self.part)}


@dataclass(frozen=True)
class HumanPutDown(_Surprise):
    word: ClassVar[str] = "putdown"

    def _seen(self) -> str:
        return f"you put the {self.part} down"

    def _change(self, world: _World) -> None:
        if world.human_holds() != self.part:
            raise SurpriseError(f"{self}: the human does not hold {self.part}")
        world.drop_human_part(self.part)


@dataclass(frozen=True)
class HumanHandedBack(_Surprise):
    word: ClassVar[str] = "handback"
    arm: str

    def _seen(self) -> str:
        return f"you gave me the {self.part} in my {self.arm} hand"

    def _change(self, world: _World) -> None:
        if world.human_holds() != self.part:
            raise SurpriseError(f"{self}: the human does not hold {self.part}")
        world.drop_human_part(self.part)
        if any(isinstance(f, Holding) and f.arm == self.arm for f in world.fluents):
            raise SurpriseError(f"{self}: the {self.arm} hand is not free")
        world.fluents.add(Holding(self.arm, self.part))


@dataclass(frozen=True)
class HumanAttached(_Surprise):
    word: ClassVar[str] = "attach"
    onto: str
    slot: str

    def _seen(self) -> str:
        return f"you attached the {self.part} to the {self.onto} at {self.slot}"

    def _change(self, world: _World) -> None:
        taken = any(
            isinstance(f, Attached) and (f.onto, f.slot) == (self.onto, self.slot)
            for f in world.fluents
        )
        if taken:
            raise SurpriseError(f"{self}: {self.onto} has a part at {self.slot} already")
        if world.human_holds() == self.part:
            world.drop_human_part(self.part)
        else:
            world.require_loose(self.part, self)
        world.fluents.add(Attached(self.part, self.onto, self.slot))


@dataclass(frozen=True)
class HumanDetached(_Surprise):
    word: ClassVar[str] = "detach"

    def _seen(self) -> str:
        return f"you took the {self.part} off"

    def _change(self, world: _World) -> None:
        attached = {f for f in world.fluents if isinstance(f, Attached) and f.part == self.part}
        if not attached:
            raise SurpriseError(f"{self}: {self.part} is not attached")
        world.fluents -= attached


Surprise = HumanTook | HumanPutDown | HumanHandedBack | HumanAttached | HumanDetached
KINDS: dict[str, Callable[..., Surprise]] = {
    c.word: c for c in (HumanTook, HumanPutDown, HumanAttached, HumanHandedBack, HumanDetached)
}


def parse_surprise(text: str) -> Surprise:
    """`attach leg2 top c2` (without the script's `!`); `SurpriseError` if malformed."""
    words = text.split()
    if not words or words[0] not in KINDS:
        raise SurpriseError(
            f"'{text}': a surprise is one of {', '.join(KINDS)} followed by its parts"
        )
    kind, args = KINDS[words[0]], words[1:]
    wanted = len(fields(kind))  # type: ignore[arg-type]
    if len(args) != wanted:
        raise SurpriseError(f"'{text}': {words[0]} takes {wanted} name(s), got {len(args)}")
    return kind(*args)
