"""Cross-field rules of a scenario: ids, references, classes and the goal.

Each rule names the field to fix: it raises `FieldProblem(path, message)`,
which the loader turns into a one-line `ScenarioError`. `FieldProblem` is not
a `ValueError` on purpose, so pydantic lets it through with its path intact
instead of folding it into a root-level validation error.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Sequence
from typing import Protocol

from planner.scenario import configuration
from planner.scenario.sections import Feasibility, Goal, Part, Region, Robot


class ScenarioSections(Protocol):
    """What the rules read of a scenario (`scenario_model.Scenario` is one)."""

    @property
    def regions(self) -> Sequence[Region]: ...
    @property
    def robot(self) -> Robot: ...
    @property
    def feasibility(self) -> Feasibility: ...
    @property
    def parts(self) -> Sequence[Part]: ...
    @property
    def goal(self) -> Goal: ...
    def part(self, part_id: str) -> Part: ...


class FieldProblem(Exception):
    """A scenario mistake at `path` (e.g. `parts[2].region`)."""

    def __init__(self, path: str, message: str) -> None:
        super().__init__(f"{path}: {message}")
        self.path = path
        self.message = message


# Fields that only make sense for some kinds; elsewhere they would be ignored
# silently, which hides typos such as `shape` on a top.
_KIND_FIELDS: dict[str, tuple[str, ...]] = {
    "length": ("leg",),
    "shape": ("leg", "foot"),
    "class": ("other",),
    "attaches_to": ("other",),
}
_REQUIRED: dict[str, tuple[str, ...]] = {"leg": ("length", "shape"), "foot": ("shape",)}


def check(s: ScenarioSections) -> None:
    """Raise `FieldProblem` for the first rule `s` breaks."""
    _unique("regions", [r.id for r in s.regions], "region", field="id")
    _unique("robot.manipulators", s.robot.manipulators, "manipulator")
    _unique("parts", [p.id for p in s.parts], "part", field="id")
    markers = [(i, p.marker) for i, p in enumerate(s.parts) if p.marker is not None]
    _unique_at([(f"parts[{i}].marker", m) for i, m in markers], "marker")
    regions = [r.id for r in s.regions]
    for i, p in enumerate(s.parts):
        _check_part(i, p, regions)
    _check_poses(s)
    if not s.goal.planned:
        _check_known(s)
    _check_classes(s)
    _check_feasibility(s, regions)
    if s.goal.planned:
        _check_planned(s)
    else:
        goal_pairs(s)  # derives (and so checks) the final configuration


def goal_pairs(s: ScenarioSections) -> list[tuple[str, str]]:
    """The final configuration as (P, Q) pairs; raises `FieldProblem` if impossible.

    Empty when the configuration is planned: the planner chooses it per branch
    (`goal_options` lists the pairs it chooses from).
    """
    if s.goal.planned:
        return []
    if s.goal.table is not None:
        return _stable_table(s)
    pairs = [(p, q) for p, q in s.goal.attachments or []]
    _check_attachments(s, pairs)
    return pairs


def goal_options(s: ScenarioSections) -> list[tuple[str, str]]:
    """(P, Q) pairs a planned stable table may contain: every leg on the top, and
    every foot on a leg whose hole it may fit."""
    return configuration.options(_table_of(s))


def _table_of(s: ScenarioSections) -> configuration.Table:
    top = next(p for p in s.parts if p.kind == "top")
    return configuration.Table(
        top=top.id,
        slots=len(top.connection_points),
        legs={p.id: configuration.Leg(tuple(p.length_options), tuple(p.shape_options),
                                      p.dangerous)
              for p in s.parts if p.kind == "leg"},
        feet={p.id: tuple(p.shape_options) for p in s.parts if p.kind == "foot"},
        dangerous_feet=frozenset(p.id for p in s.parts if p.kind == "foot" and p.dangerous),
    )  # fmt: skip


def _check_planned(s: ScenarioSections) -> None:
    """A planned table: one top, legs and feet only, and a stable table whatever
    the sensing reveals (an outcome without one would be a dead end)."""
    if s.goal.table is None:
        raise FieldProblem(
            "goal.configuration",
            'only with table = "stable": explicit attachments fix the configuration',
        )
    tops = [p for p in s.parts if p.kind == "top"]
    if len(tops) != 1:
        found = ", ".join(p.id for p in tops) or "none"
        raise FieldProblem("goal.table", f"a stable table needs exactly one top (found: {found})")
    for i, p in enumerate(s.parts):
        if p.kind == "other":
            raise FieldProblem(
                f"parts[{i}].kind", "a planned table is made of a top, legs and feet only"
            )
        if p.kind == "leg" and not p.connection_points:
            raise FieldProblem(
                f"parts[{i}].connections", f"leg {p.id!r} needs a connection point for its foot"
            )
    if not tops[0].connection_points:
        raise FieldProblem(f"parts[{_index(s, tops[0].id)}].connections", "the top has no slots")
    missing = configuration.unstable_outcome(_table_of(s))
    if missing is not None:
        told = ", ".join(f"{p} is {v}" for p, v in missing)
        why = f"no stable table when {told}" if told else "no stable table from these parts"
        raise FieldProblem("goal.configuration", why)


def attachable_classes(s: ScenarioSections) -> list[tuple[str, str]]:
    """(Cl, Cl2): a part of class Cl may be attached to a part of class Cl2."""
    if s.goal.planned:
        # Classes are the kinds; which foot fits which leg is decided by shape, in ASP.
        return [("foot", "leg"), ("leg", "top")]
    pairs: set[tuple[str, str]] = set()
    for p in s.parts:
        if p.kind == "leg":
            pairs.add((p.class_name, "top"))
        elif p.kind == "foot":
            pairs.add((p.class_name, f"leg_{p.shape}"))
        elif p.kind == "other":
            pairs.update((p.class_name, c) for c in p.attaches_to or [])
    return sorted(pairs)


def _unique(path: str, ids: list[str], what: str, field: str | None = None) -> None:
    suffix = f".{field}" if field else ""
    _unique_at([(f"{path}[{i}]{suffix}", v) for i, v in enumerate(ids)], what)


def _unique_at(items: Iterable[tuple[str, object]], what: str) -> None:
    seen: dict[object, str] = {}
    for path, value in items:
        if value in seen:
            raise FieldProblem(path, f"duplicate {what} {value!r} (already at {seen[value]})")
        seen[value] = path


def _known(path: str, value: str, known: list[str], what: str) -> None:
    if value not in known:
        raise FieldProblem(path, f"unknown {what} {value!r} (known: {', '.join(known)})")


def _check_part(i: int, p: Part, regions: list[str]) -> None:
    at = f"parts[{i}]"
    _known(f"{at}.region", p.region, regions, "region")
    given = p.model_dump(by_alias=True, exclude_unset=True)
    for name, kinds in _KIND_FIELDS.items():
        if name in given and p.kind not in kinds:
            raise FieldProblem(
                f"{at}.{name}", f"not allowed for kind {p.kind!r} (only {', '.join(kinds)})"
            )
    for name in _REQUIRED.get(p.kind, ()):
        if name not in given:
            raise FieldProblem(f"{at}.{name}", f"missing: a {p.kind} needs a {name}")
    for name in ("shape", "length"):
        options = given.get(name)
        if isinstance(options, list):
            _check_options(f"{at}.{name}", name, options)
    if p.kind == "other" and p.class_ is None:
        raise FieldProblem(f"{at}.class", "missing: an 'other' part needs a class")
    _unique_at(
        ((f"{at}.connections[{j}]", c) for j, c in enumerate(p.connection_points)),
        "connection point",
    )


def _check_poses(s: ScenarioSections) -> None:
    """A region's parts all have a pose, or none has. The layout lays out the parts
    without one on a grid of their region, blind to the parts placed by pose
    (planner.feasibility.scene), so a part left without one among placed parts can
    be laid over them: the planner then reads a bench nobody meant (a leg lying
    across the top puts the top out of every arm's reach)."""
    for region in s.regions:
        inside = [(i, p) for i, p in enumerate(s.parts) if p.region == region.id]
        posed = [p.id for _, p in inside if p.pose is not None]
        loose = [(i, p) for i, p in inside if p.pose is None]
        if posed and loose:
            i, p = loose[0]
            raise FieldProblem(
                f"parts[{i}].pose",
                f"missing: {p.id} has no pose but {', '.join(posed)} in {region.id} have "
                f"one, and the layout could lay {p.id} over them; give {p.id} a pose "
                f"(or none of {region.id}'s parts one)",
            )


def _check_known(s: ScenarioSections) -> None:
    write = 'configuration = "planned"'
    if s.goal.table is None:
        write = f'table = "stable" and {write}'
    for i, p in enumerate(s.parts):
        for name, value in (("shape", p.shape), ("length", p.length)):
            if isinstance(value, list):
                raise FieldProblem(
                    f"parts[{i}].{name}",
                    f"an unknown {name} ({' or '.join(value)}) needs the planner to choose the "
                    f"table: write {write} under [goal]",
                )


def _check_options(at: str, name: str, options: list[str]) -> None:
    if len(options) < 2:
        raise FieldProblem(
            at, f"an unknown {name} lists at least two options (a known one is a plain word)"
        )
    _unique_at(((f"{at}[{j}]", o) for j, o in enumerate(options)), "option")


def _check_classes(s: ScenarioSections) -> None:
    known = sorted({p.class_name for p in s.parts})
    for i, p in enumerate(s.parts):
        for j, c in enumerate(p.attaches_to or []):
            _known(f"parts[{i}].attaches_to[{j}]", c, known, "class")


def _check_feasibility(s: ScenarioSections, regions: list[str]) -> None:
    arms = s.robot.manipulators
    parts = [p.id for p in s.parts]
    for arm, listed in s.feasibility.reachable.items():
        _known(f"feasibility.reachable.{arm}", arm, arms, "manipulator")
        for j, r in enumerate(listed):
            _known(f"feasibility.reachable.{arm}[{j}]", r, regions, "region")
    for arm, listed in s.feasibility.unreachable_parts.items():
        _known(f"feasibility.unreachable_parts.{arm}", arm, arms, "manipulator")
        for j, p in enumerate(listed):
            _known(f"feasibility.unreachable_parts.{arm}[{j}]", p, parts, "part")


def _count(n: int, noun: str) -> str:
    return f"{n} {noun}" if n == 1 else f"{n} {noun}s"


def _index(s: ScenarioSections, part_id: str) -> int:
    return next(i for i, p in enumerate(s.parts) if p.id == part_id)


def _stable_table(s: ScenarioSections) -> list[tuple[str, str]]:
    """docs/scenario.md: the most common leg length on the top, a foot under each."""
    tops = [p for p in s.parts if p.kind == "top"]
    legs = [p for p in s.parts if p.kind == "leg"]
    if len(tops) != 1:
        found = ", ".join(p.id for p in tops) or "none"
        raise FieldProblem("goal.table", f"a stable table needs exactly one top (found: {found})")
    if not legs:
        raise FieldProblem("goal.table", "a stable table needs at least one leg (found none)")
    top = tops[0]
    counts = Counter(leg.length for leg in legs)
    most = max(counts.values())
    # Ties go to the length of the first leg in file order.
    length = next(leg.length for leg in legs if counts[leg.length] == most)
    chosen = [leg for leg in legs if leg.length == length]
    points = len(top.connection_points)
    if points < len(chosen):
        raise FieldProblem(
            f"parts[{_index(s, top.id)}].connections",
            f"the top needs at least {len(chosen)} connection points for the "
            f"{len(chosen)} {length!r} legs ({', '.join(leg.id for leg in chosen)}), has {points}",
        )
    for leg in chosen:
        if not leg.connection_points:
            raise FieldProblem(
                f"parts[{_index(s, leg.id)}].connections",
                f"leg {leg.id!r} needs a connection point for its foot",
            )
    feet = [p for p in s.parts if p.kind == "foot"]
    foot_of: dict[str, str] = {}
    for leg in chosen:
        foot = next((f for f in feet if f.shape == leg.shape and f.id not in foot_of), None)
        if foot is not None:
            foot_of[foot.id] = leg.id
    for foot in feet:
        if foot.id not in foot_of:
            raise FieldProblem(
                f"parts[{_index(s, foot.id)}].shape",
                f"foot {foot.id!r} has no matching leg: none of the {length!r} legs on the "
                f"top ({', '.join(leg.id for leg in chosen)}) has a free {foot.shape!r} hole",
            )
    with_foot = set(foot_of.values())
    for leg in chosen:
        if leg.id not in with_foot:
            raise FieldProblem(
                f"parts[{_index(s, leg.id)}].shape",
                f"leg {leg.id!r} has no matching foot: no spare foot of shape {leg.shape!r}",
            )
    pairs = [(leg.id, top.id) for leg in chosen]
    pairs += [(foot.id, foot_of[foot.id]) for foot in feet]
    return pairs


def _check_attachments(s: ScenarioSections, pairs: list[tuple[str, str]]) -> None:
    known = [p.id for p in s.parts]
    attachable = set(attachable_classes(s))
    parent: dict[str, tuple[str, int]] = {}
    for i, (p, q) in enumerate(pairs):
        at = f"goal.attachments[{i}]"
        _known(f"{at}[0]", p, known, "part")
        _known(f"{at}[1]", q, known, "part")
        if p == q:
            raise FieldProblem(at, f"a part cannot be attached to itself ({p!r})")
        part, onto = s.part(p), s.part(q)
        if not part.movable:
            raise FieldProblem(
                f"{at}[0]", f"{p!r} is a table top: it cannot be attached to another part"
            )
        if (part.class_name, onto.class_name) not in attachable:
            raise FieldProblem(
                at,
                f"{p!r} (class {part.class_name}) cannot be attached to {q!r} "
                f"(class {onto.class_name})",
            )
        if p in parent:
            before, j = parent[p]
            raise FieldProblem(
                f"{at}[0]", f"{p!r} is already attached to {before!r} in goal.attachments[{j}]"
            )
        parent[p] = (q, i)
    for i, (p, _) in enumerate(pairs):
        _no_cycle(p, parent, f"goal.attachments[{i}]")
    load = Counter(q for _, q in pairs)
    for q, n in load.items():
        points = len(s.part(q).connection_points)
        if n > points:
            has = _count(points, "connection point")
            raise FieldProblem(
                f"parts[{_index(s, q)}].connections",
                f"the goal attaches {n} parts to {q!r} but it has {has}",
            )


def _no_cycle(start: str, parent: dict[str, tuple[str, int]], at: str) -> None:
    # Each part has at most one parent, so following parents either ends or loops.
    seen = [start]
    node = start
    while node in parent:
        node = parent[node][0]
        if node == start:
            raise FieldProblem(at, f"attachments form a cycle: {' -> '.join([*seen, start])}")
        if node in seen:
            return  # a loop that does not pass through start; reported from its own member
        seen.append(node)
