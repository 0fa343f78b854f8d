"""The audit's own states: a fluent as a tuple of constants, parsed from a plan.

Plain tuples, not `planner.vocabulary`'s fluents: the audit re-implements the
domain from docs/domain.md (`planner.audit.domain`), and tuples make its
matching short (`("attached", "leg1", "top", "c1")`).
"""

from __future__ import annotations

import functools
import re

from planner.vocabulary import TermError, constants, parse_term

SimFluent = tuple[str, ...]
SimState = frozenset[SimFluent]

FLUENT_ARITY: dict[str, int] = {
    "attached": 3,
    "holding": 2,
    "humanFree": 0,
    "humanHolding": 0,
    "humanHoldingPart": 1,
    "wantToAttach": 2,
    "acceptToAttach": 2,
    "requestedAttach": 2,
    "reserved": 1,
    "declined": 2,
    "keepsHolding": 1,
    "initiatives": 1,  # initiatives(N): the human took the initiative N times
    "shapeIs": 2,  # planned configurations: what sensing saw (planner.audit.table)
    "lengthIs": 2,
}
TASKS = ("wantToAttach", "acceptToAttach", "requestedAttach")
HUMAN_FREE: SimFluent = ("humanFree",)
HUMAN_HOLDING: SimFluent = ("humanHolding",)


def fluent_str(f: SimFluent) -> str:
    return f[0] if len(f) == 1 else f"{f[0]}({','.join(f[1:])})"


# Fluent texts parsed without error so far, and their fluents: a state made of
# them alone is read with one lookup per fluent (U30: 187,000 states of up to 65
# fluents, 10 of the audit's 17 CPU-s read one at a time). Bounded, as the cache of
# `_parse_fluent` is: a process may audit many plans.
_KNOWN: dict[str, SimFluent] = {}
_KNOWN_MAX = 1 << 16


def parse_sim_state(items: object) -> tuple[SimState, list[str]]:
    """Parse a node's `state` list; unknown or malformed fluents are errors."""
    if not isinstance(items, list):
        return frozenset(), ["state must be a list of fluent strings"]
    try:
        return frozenset([_KNOWN[item] for item in items]), []
    except (KeyError, TypeError):  # not all read before (or not strings): one by one
        pass
    if len(_KNOWN) > _KNOWN_MAX:
        _KNOWN.clear()
    out: set[SimFluent] = set()
    errors: list[str] = []
    for item in items:
        if not isinstance(item, str):
            errors.append(f"state: {item!r} is not a string")
            continue
        fluent, error = _parse_fluent(item)
        if fluent is None:
            errors.append(error)
        else:
            out.add(fluent)
            _KNOWN[item] = fluent
    return frozenset(out), errors


@functools.lru_cache(maxsize=1 << 16)
def _parse_fluent(item: str) -> tuple[SimFluent | None, str]:
    """One fluent of a state, or the error it makes. Cached: the states of a plan
    share most of their fluents (U10: 131,705 parsed, 8.7 s of a 27 s audit)."""
    try:
        term = parse_term(item)
    except TermError as exc:
        return None, f"state: {exc}"
    args = constants(term)
    if (
        args is None
        or FLUENT_ARITY.get(term.name) != len(args)
        or (term.name == "initiatives" and not re.fullmatch(r"[1-9][0-9]*", args[0]))
    ):
        return None, f"state: unknown fluent {item}"
    return (term.name, *args), ""


class StateParts:
    """What a state says about its parts, read once: a node's checks ask it many
    times (U30: 7.7 million fluents looked at for `is_attached` alone)."""

    def __init__(self, s: SimState) -> None:
        self.state = s
        self.onto: dict[str, list[tuple[str, str]]] = {}  # part -> (part, point) below it
        self.pairs: set[tuple[str, str]] = set()  # (part, onto) attached
        self.held: dict[str, list[str]] = {}  # manipulator -> parts it holds
        self.in_hand: set[str] = set()  # parts some manipulator holds
        for x in s:
            if x[0] == "attached":
                self.onto.setdefault(x[1], []).append((x[2], x[3]))
                self.pairs.add((x[1], x[2]))
            elif x[0] == "holding":
                self.held.setdefault(x[1], []).append(x[2])
                self.in_hand.add(x[2])
