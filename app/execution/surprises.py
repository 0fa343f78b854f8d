"""Surprises: what a person did that no branch of the plan expects.

A surprise is observed at a node (a scripted line `!attach leg2 top c2`, or,
later, a camera view that fits none of the node's outcomes). It turns the
node's state into the observed state; the executor then plans again from
there (`app.execution.repair`) and goes on with the new plan. Each kind changes the
state as the domain (docs/domain.md) would after the human's action:

- `take P`: the human picked P up; their hands hold P.
- `putdown P`: the human put P (which they held) back on the bench.
- `attach P Q C`: the human attached P to Q at connection point C.
- `handback P M`: the human put P into the robot's free hand M.
- `detach P`: the human took P off what it was attached to and laid it down.
"""

from __future__ import annotations

from dataclasses import dataclass

from planner.vocabulary import State

KINDS = {"take": 1, "putdown": 1, "attach": 3, "handback": 2, "detach": 1}
# Fluents about the human's hands and the tasks on a part: a surprise makes them stale.
_HANDS = ("humanFree", "humanHolding")
_TASKS = ("wantToAttach(", "acceptToAttach(", "requestedAttach(", "declined(", "keepsHolding(")


class SurpriseError(ValueError):
    """A surprise that is not well formed, or impossible in the node's state; one line."""


@dataclass(frozen=True)
class Surprise:
    kind: str
    args: tuple[str, ...]

    def __str__(self) -> str:
        return " ".join((self.kind, *self.args))

    def words(self) -> str:
        """What the robot says it saw, before it adapts."""
        match self.kind, self.args:
            case "take", (part,):
                return f"I see you picked up the {part}; I'll adapt."
            case "putdown", (part,):
                return f"I see you put the {part} down; I'll adapt."
            case "attach", (part, onto, point):
                return f"I see you attached the {part} to the {onto} at {point}; I'll adapt."
            case "handback", (part, arm):
                return f"I see you gave me the {part} in my {arm} hand; I'll adapt."
            case "detach", (part,):
                return f"I see you took the {part} off; I'll adapt."
        return f"I see something I did not expect ({self}); I'll adapt."

    def apply(self, state: State) -> State:
        """The state after the surprise; `SurpriseError` when it cannot have happened."""
        s = set(state)
        held = _human_holds(s)
        part = self.args[0]
        if self.kind == "take":
            if held is not None:
                raise SurpriseError(f"{self}: the human already holds {held}")
            _require_loose(s, part, self)
            s -= set(_HANDS)
            s |= {"humanHolding", f"humanHoldingPart({part})"}
        elif self.kind in ("putdown", "handback"):
            if held != part:
                raise SurpriseError(f"{self}: the human does not hold {part}")
            _drop_human_part(s, part)
            if self.kind == "handback":
                arm = self.args[1]
                if any(f.startswith(f"holding({arm},") for f in s):
                    raise SurpriseError(f"{self}: the {arm} hand is not free")
                s.add(f"holding({arm},{part})")
        elif self.kind == "attach":
            onto, point = self.args[1], self.args[2]
            if any(f.startswith("attached(") and f.endswith(f",{onto},{point})") for f in s):
                raise SurpriseError(f"{self}: {onto} has a part at {point} already")
            if held == part:
                _drop_human_part(s, part)
            else:
                _require_loose(s, part, self)
            s.add(f"attached({part},{onto},{point})")
        elif self.kind == "detach":
            attached = [f for f in s if f.startswith(f"attached({part},")]
            if not attached:
                raise SurpriseError(f"{self}: {part} is not attached")
            s -= set(attached)
        # The human's tasks on the part are done or moot (its own, not those onto it).
        s = {f for f in s if not (f.startswith(_TASKS) and (f"({part}," in f or f"({part})" in f))}
        return frozenset(s)


def parse_surprise(text: str) -> Surprise:
    """`attach leg2 top c2` (without the script's `!`); `SurpriseError` if malformed."""
    words = text.split()
    if not words or words[0] not in KINDS:
        raise SurpriseError(
            f"'{text}': a surprise is one of {', '.join(KINDS)} followed by its parts"
        )
    kind, args = words[0], tuple(words[1:])
    if len(args) != KINDS[kind]:
        raise SurpriseError(f"'{text}': {kind} takes {KINDS[kind]} name(s), got {len(args)}")
    return Surprise(kind, args)


def _human_holds(s: set[str]) -> str | None:
    for f in s:
        if f.startswith("humanHoldingPart("):
            return f[len("humanHoldingPart(") : -1]
    return None


def _drop_human_part(s: set[str], part: str) -> None:
    s.discard(f"humanHoldingPart({part})")
    s.discard("humanHolding")
    s.add("humanFree")


def _require_loose(s: set[str], part: str, surprise: Surprise) -> None:
    if any(f.startswith(f"attached({part},") for f in s):
        raise SurpriseError(f"{surprise}: {part} is attached")
    if any(f.startswith("holding(") and f.endswith(f",{part})") for f in s):
        raise SurpriseError(f"{surprise}: the robot holds {part}")
