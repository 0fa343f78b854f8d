"""The stable table of a planned configuration, in plain Python (docs/scenario.md).

A stable table (the paper's real-world task): every slot of the top holds a
leg, the legs on the top share one length, and every leg on the top carries a
foot whose shape matches its hole. The planner chooses such a table per branch
in ASP (`planner/asp/configuration.lp`); this module only answers the questions
asked before planning (which pairs are possible, whether every sensing outcome
leaves a stable table) and is shared with the audit (`planner.audit.table`).
"""

from __future__ import annotations

import itertools
from collections import Counter
from collections.abc import Iterator, Mapping
from dataclasses import dataclass


@dataclass(frozen=True)
class Leg:
    lengths: tuple[str, ...]  # one entry when known
    shapes: tuple[str, ...]  # the hole's shape; one entry when known
    dangerous: bool = False


@dataclass(frozen=True)
class Table:
    """What a scenario says of the parts of a table (options where unknown)."""

    top: str
    slots: int
    legs: Mapping[str, Leg]
    feet: Mapping[str, tuple[str, ...]]
    dangerous_feet: frozenset[str] = frozenset()  # every table must use them


def options(t: Table) -> list[tuple[str, str]]:
    """(P, Q) pairs some stable table may contain, legs first, in file order."""
    pairs = [(leg, t.top) for leg in t.legs]
    pairs += [
        (foot, leg)
        for foot, shapes in t.feet.items()
        for leg, spec in t.legs.items()
        if set(shapes) & set(spec.shapes)
    ]
    return pairs


def stable_exists(
    slots: int,
    lengths: Mapping[str, str],
    leg_shapes: Mapping[str, str],
    foot_shapes: Mapping[str, str],
    required: frozenset[str] = frozenset(),
) -> bool:
    """Whether known parts make a stable table that uses every `required` part:
    for some length, legs of it matched to distinct feet of their hole's shape
    fill every slot."""
    feet = Counter(foot_shapes.values())
    for length in set(lengths.values()):
        if any(lengths[p] != length for p in required if p in lengths):
            continue  # a required leg of another length cannot be on this table
        legs = Counter(leg_shapes[leg] for leg, x in lengths.items() if x == length)
        # Per shape, k legs (each with its foot) go on the table: at most what
        # matches, at least what is required (feet of it, or legs of it).
        most = {shape: min(n, feet[shape]) for shape, n in legs.items()}
        need_feet = Counter(foot_shapes[p] for p in required if p in foot_shapes)
        need_legs = Counter(leg_shapes[p] for p in required if p in leg_shapes)
        least = {s: max(need_feet[s], need_legs[s]) for s in need_feet | need_legs}
        if any(least[shape] > most.get(shape, 0) for shape in least):
            continue
        if sum(least.values()) <= slots <= sum(most.values()):
            return True
    return False


def outcomes(t: Table) -> Iterator[list[tuple[str, str]]]:
    """Every combination of what sensing may reveal, as (part, value) choices."""
    open_ = [(f"{leg}.length", spec.lengths) for leg, spec in t.legs.items()]
    open_ += [(f"{leg}.shape", spec.shapes) for leg, spec in t.legs.items()]
    open_ += [(f"{foot}.shape", shapes) for foot, shapes in t.feet.items()]
    for values in itertools.product(*(opts for _, opts in open_)):
        yield [(name, v) for (name, _), v in zip(open_, values, strict=True)]


def unstable_outcome(t: Table) -> list[tuple[str, str]] | None:
    """The first outcome with no stable table (only its unknown choices; [] when
    no outcome has one), or None when every outcome has one."""
    unknown = {f"{leg}.length" for leg, spec in t.legs.items() if len(spec.lengths) > 1}
    unknown |= {f"{leg}.shape" for leg, spec in t.legs.items() if len(spec.shapes) > 1}
    unknown |= {f"{foot}.shape" for foot, shapes in t.feet.items() if len(shapes) > 1}
    failed = [choice for choice in outcomes(t) if not _stable(t, dict(choice))]
    if not failed:
        return None
    if len(failed) == sum(1 for _ in outcomes(t)):
        return []
    return [(name.split(".")[0], v) for name, v in failed[0] if name in unknown]


def _stable(t: Table, got: dict[str, str]) -> bool:
    lengths = {leg: got[f"{leg}.length"] for leg in t.legs}
    leg_shapes = {leg: got[f"{leg}.shape"] for leg in t.legs}
    foot_shapes = {foot: got[f"{foot}.shape"] for foot in t.feet}
    required = frozenset(leg for leg, spec in t.legs.items() if spec.dangerous) | t.dangerous_feet
    return stable_exists(t.slots, lengths, leg_shapes, foot_shapes, required)
