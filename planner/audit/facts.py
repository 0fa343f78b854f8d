"""The static facts of a plan file, indexed for the plan audit (docs/domain.md).

Plain Python, like `planner.audit.domain`, which simulates the domain over them.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

from planner.scenario.sections import DEFAULT_INITIATIVE
from planner.vocabulary import TermError, constants, parse_term

_FACT_ARITY: dict[str, int] = {
    "part": 1, "movable": 1, "class": 2, "attachable": 2, "connection": 2,
    "dangerous": 1, "region": 1, "humanReach": 1, "loc": 2, "manipulator": 1,
    "reachable": 2, "goal": 2, "safety": 1, "verbosity": 1, "initiative": 1,
    "resumed": 0, "pointsChecked": 1, "pointReach": 3,
    "plannedConfiguration": 0, "goalOption": 2, "shapeOption": 2, "lengthOption": 2,
}  # fmt: skip


@dataclass
class Facts:
    """The static facts of a plan file, indexed."""

    parts: set[str] = field(default_factory=set)
    movable: set[str] = field(default_factory=set)
    cls: dict[str, str] = field(default_factory=dict)
    attachable: set[tuple[str, str]] = field(default_factory=set)
    connections: dict[str, set[str]] = field(default_factory=dict)
    dangerous: set[str] = field(default_factory=set)
    regions: set[str] = field(default_factory=set)
    human_reach: set[str] = field(default_factory=set)
    loc: dict[str, str] = field(default_factory=dict)
    manipulators: list[str] = field(default_factory=list)
    reachable: set[tuple[str, str]] = field(default_factory=set)
    goals: list[tuple[str, str]] = field(default_factory=list)
    safety: str = "normal"
    verbosity: str = "normal"
    initiative: int = DEFAULT_INITIATIVE  # how often the human may pick a part up unasked
    resumed: bool = False  # planned from a later state (a repair): no greeting again
    # Fixed parts whose points geometry checked, and (arm, part, point) each arm reaches.
    points_checked: set[str] = field(default_factory=set)
    point_reach: set[tuple[str, str, str]] = field(default_factory=set)
    # A planned configuration (planner.audit.table): the pairs a table may
    # use, and what each part's shape and length may be (one option: known).
    planned: bool = False
    goal_options: list[tuple[str, str]] = field(default_factory=list)
    shapes: dict[str, list[str]] = field(default_factory=dict)
    lengths: dict[str, list[str]] = field(default_factory=dict)


def parse_facts(items: object) -> tuple[Facts, list[str]]:
    """Index the fact strings. Unknown predicates are ignored (planner helpers)."""
    facts = Facts()
    if not isinstance(items, list):
        return facts, ["facts must be a list of strings"]
    errors: list[str] = []
    for item in items:
        try:
            term = parse_term(item) if isinstance(item, str) else None
        except TermError as exc:
            errors.append(f"facts: {exc}")
            continue
        if term is None:
            errors.append(f"facts: {item!r} is not a string")
            continue
        args = constants(term)
        arity = _FACT_ARITY.get(term.name)
        if arity is None:
            continue
        if args is None or len(args) != arity:
            errors.append(f"facts: {item} should have {arity} constant argument(s)")
            continue
        error = _add_fact(facts, term.name, args)
        if error:
            errors.append(f"facts: {item}: {error}")
    return facts, errors


def _add_fact(f: Facts, name: str, a: tuple[str, ...]) -> str | None:
    simple: dict[str, set[str]] = {
        "part": f.parts, "movable": f.movable, "dangerous": f.dangerous,
        "region": f.regions, "humanReach": f.human_reach,
    }  # fmt: skip
    if name in simple:
        simple[name].add(a[0])
    elif name == "class":
        # class(Cl,P): the class comes first.
        if f.cls.setdefault(a[1], a[0]) != a[0]:
            return f"{a[1]} already has class {f.cls[a[1]]}"
    elif name == "loc":
        if f.loc.setdefault(a[0], a[1]) != a[1]:
            return f"{a[0]} already lies in {f.loc[a[0]]}"
    elif name == "attachable":
        f.attachable.add((a[0], a[1]))
    elif name == "connection":
        f.connections.setdefault(a[0], set()).add(a[1])
    elif name == "manipulator":
        if a[0] not in f.manipulators:
            f.manipulators.append(a[0])
    elif name == "reachable":
        f.reachable.add((a[0], a[1]))
    elif name == "pointsChecked":
        f.points_checked.add(a[0])
    elif name == "pointReach":
        f.point_reach.add((a[0], a[1], a[2]))
    elif name == "goal":
        if (a[0], a[1]) not in f.goals:
            f.goals.append((a[0], a[1]))
    elif name == "plannedConfiguration":
        f.planned = True
    elif name == "goalOption":
        if (a[0], a[1]) not in f.goal_options:
            f.goal_options.append((a[0], a[1]))
    elif name in ("shapeOption", "lengthOption"):
        options = (f.shapes if name == "shapeOption" else f.lengths).setdefault(a[0], [])
        if a[1] not in options:
            options.append(a[1])
    elif name == "safety":
        f.safety = a[0]
    elif name == "verbosity":
        f.verbosity = a[0]
    elif name == "resumed":
        f.resumed = True
    elif name == "initiative":
        if not re.fullmatch(r"[0-9]+", a[0]):
            return "the budget must be a non-negative integer"
        f.initiative = int(a[0])
    return None


def term_order(arg: str) -> tuple[int, int, str]:
    """Sort key of a constant argument in ASP term order (what `#min` uses):
    integers by value, then plain constants by their bytes, then strings."""
    if re.fullmatch(r"-?[0-9]+", arg):
        return (0, int(arg), "")
    return (2 if arg.startswith('"') else 1, 0, arg)
