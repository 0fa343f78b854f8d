"""The audit's own actions: their kinds and argument types, parsed from a plan.

Written out from docs/domain.md like the rest of the audit, not taken from
`planner.vocabulary`, so that a mistake there shows up as a violation here.
"""

from __future__ import annotations

from dataclasses import dataclass

from planner.audit.facts import Facts
from planner.vocabulary import TermError, constants, parse_term

ACTUATION, SENSING, COMMUNICATION, GOAL = "actuation", "sensing", "communication", "goal"
KINDS = (ACTUATION, SENSING, COMMUNICATION, GOAL)

# The conversation (docs/domain.md, "Conversation"): deterministic communication
# that changes nothing in the world; when it is due is `planner.audit.talk`'s.
CONVERSATION: dict[str, tuple[str, ...]] = {
    "greet": (),
    "farewell": (),
    "warnWorking": ("region",),
    "warnDanger": ("part",),
    "explainAsk": ("part",),
    "explainOwnTask": ("part",),
}
# name -> (kind, argument types, deterministic). Sensing actions are keyed by
# the inner term's name (`sense(humanUnholding(P))` -> "humanUnholding").
_ACTIONS: dict[str, tuple[str, tuple[str, ...], bool]] = {
    "hold": (ACTUATION, ("manipulator", "part"), True),
    "attach": (ACTUATION, ("manipulator", "part", "point"), True),
    "unhold": (ACTUATION, ("manipulator",), True),
    "humanHolding": (SENSING, (), False),
    "humanHoldingWhichPart": (SENSING, (), False),
    "humanUnholding": (SENSING, ("part",), False),
    "humanAttachingWhere": (SENSING, ("part", "part"), False),
    "shapeOf": (SENSING, ("part",), False),
    "lengthOf": (SENSING, ("part",), False),
    "confirmAttach": (COMMUNICATION, ("part", "part"), False),
    "askHelp": (COMMUNICATION, ("part", "part"), False),
    "offerHelp": (COMMUNICATION, ("part", "part"), False),
    "requestToUnhold": (COMMUNICATION, ("part",), True),
    "requestToAttach": (COMMUNICATION, ("part", "part"), True),
    **{name: (COMMUNICATION, types, True) for name, types in CONVERSATION.items()},
}
_SENSED = {k for k, v in _ACTIONS.items() if v[0] == SENSING}


@dataclass(frozen=True)
class SimAction:
    name: str
    args: tuple[str, ...]
    text: str  # canonical rendering, for messages

    @property
    def kind(self) -> str:
        return _ACTIONS[self.name][0]

    @property
    def deterministic(self) -> bool:
        return _ACTIONS[self.name][2]


def parse_sim_action(text: str, facts: Facts) -> SimAction | str:
    """The action, or an error message (unknown action, arity, unknown ids)."""
    try:
        term = parse_term(text)
    except TermError as exc:
        return str(exc)
    shown = str(term)
    inner = term
    if term.name == "sense":
        if len(term.args) != 1 or term.args[0].name not in _SENSED:
            return f"unknown action {shown}"
        inner = term.args[0]
    elif term.name not in _ACTIONS or term.name in _SENSED:
        return f"unknown action {shown}"
    _, types, _ = _ACTIONS[inner.name]
    args = constants(inner)
    if args is None or len(args) != len(types):
        return f"{shown}: {inner.name} takes {len(types)} constant argument(s)"
    for arg, typ in zip(args, types, strict=True):
        if typ == "manipulator" and arg not in facts.manipulators:
            return f"{shown}: unknown manipulator {arg}"
        if typ == "part" and arg not in facts.parts:
            return f"{shown}: unknown part {arg}"
        if typ == "region" and arg not in facts.regions:
            return f"{shown}: unknown region {arg}"
    return SimAction(inner.name, args, shown)
