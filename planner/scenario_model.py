"""Pydantic models of a scenario file (docs/scenario.md).

The models check types and per-field syntax; the checks that look across
fields live in `scenario_rules` and run from `Scenario`'s after-validator, so
a `Scenario` object is always a consistent scenario.
"""

from __future__ import annotations

import re
from collections.abc import Set
from typing import Annotated, Literal

from pydantic import AfterValidator, BaseModel, ConfigDict, Field, PrivateAttr, model_validator

from planner import scenario_rules

_CONST = re.compile(r"[a-z][A-Za-z0-9_]*")
_WORD = re.compile(r"[A-Za-z0-9_]+")


def _const_id(value: str) -> str:
    # Ids become ASP constants verbatim, so anything else would break the encoding.
    if not _CONST.fullmatch(value):
        raise ValueError(
            f"bad id {value!r}: expected a lowercase letter followed by letters, digits or _"
        )
    if value == "not":  # the one bare keyword of clingo's input language
        raise ValueError("bad id 'not': it is a keyword of ASP")
    return value


def _word(value: str) -> str:
    # Shapes end up inside class constants (`leg_<shape>`), so they must be one word.
    if not _WORD.fullmatch(value):
        raise ValueError(f"bad word {value!r}: expected letters, digits or _ only")
    return value


def _one_line(value: str) -> str:
    # The name is echoed in one-line reports and plan headers.
    if not value.strip() or any(c in value for c in "\r\n"):
        raise ValueError("expected one non-empty line of text")
    return value


ConstId = Annotated[str, AfterValidator(_const_id)]
OneLine = Annotated[str, AfterValidator(_one_line)]
Word = Annotated[str, AfterValidator(_word)]
Extent = Annotated[list[float], Field(min_length=2, max_length=2)]
Pose = Annotated[list[float], Field(min_length=3, max_length=3)]
Pair = Annotated[list[ConstId], Field(min_length=2, max_length=2)]
PartKind = Literal["top", "leg", "foot", "other"]


class _Strict(BaseModel):
    # strict: TOML has real types, so "yes" for a boolean is a mistake, not a
    # value to coerce; forbid: a misspelt optional key must not pass silently.
    model_config = ConfigDict(strict=True, extra="forbid", frozen=True)


class Preferences(_Strict):
    safety: Literal["relaxed", "normal", "strict"] = "normal"
    verbosity: Literal["terse", "normal", "chatty"] = "normal"


class Region(_Strict):
    id: ConstId
    x: Extent | None = None
    # Required on purpose: guessing "out of reach" would hide the human from safety.
    human_reach: bool


class Robot(_Strict):
    manipulators: Annotated[list[ConstId], Field(min_length=1)] = ["left", "right"]
    base_pose: Pose = [0.0, 0.0, 0.0]


class Human(_Strict):
    name: str = "teammate"
    # How many times the human may pick a part up unasked in one execution.
    initiative: int = Field(default=1, ge=0, le=3)


class Feasibility(_Strict):
    source: Literal["declared", "geometry"] = "geometry"
    reachable: dict[str, list[str]] = {}
    unreachable_parts: dict[str, list[str]] = {}

    @model_validator(mode="before")
    @classmethod
    def _declared_when_tabled(cls, data: object) -> object:
        # Geometry is the default; a file that writes a table means that table.
        if isinstance(data, dict) and "source" not in data:
            tabled = "reachable" in data or "unreachable_parts" in data
            return {**data, "source": "declared" if tabled else "geometry"}
        return data


class Part(_Strict):
    id: ConstId
    kind: PartKind
    region: str
    connections: list[ConstId] | None = None
    pose: Pose | None = None
    size: Pose | None = None
    marker: Annotated[int, Field(ge=0)] | None = None
    length: Word | None = None
    shape: Word | None = None
    dangerous: bool = False
    class_: ConstId | None = Field(default=None, alias="class")
    attaches_to: list[ConstId] | None = None

    @property
    def class_name(self) -> str:
        """The ASP class; only meaningful once the scenario checks have passed."""
        if self.kind == "top":
            return "top"
        if self.kind in ("leg", "foot"):
            return f"{self.kind}_{self.shape}"
        return self.class_ or ""

    @property
    def connection_points(self) -> list[str]:
        if self.connections is not None:
            return list(self.connections)
        return ["foot"] if self.kind == "leg" else []

    @property
    def movable(self) -> bool:
        return self.kind != "top"


class Goal(_Strict):
    table: Literal["stable"] | None = None
    attachments: Annotated[list[Pair], Field(min_length=1)] | None = None

    @model_validator(mode="after")
    def _exactly_one(self) -> Goal:
        if (self.table is None) == (self.attachments is None):
            raise ValueError("expected exactly one of `table` or `attachments`")
        return self


class Scenario(_Strict):
    name: OneLine
    description: str | None = None
    preferences: Preferences = Preferences()
    regions: Annotated[list[Region], Field(min_length=1)]
    robot: Robot = Robot()
    human: Human = Human()
    feasibility: Feasibility = Feasibility()
    parts: Annotated[list[Part], Field(min_length=1)]
    goal: Goal

    # Not part of the file format: set by the loader, so extra="forbid" keeps
    # a `sha256 = ...` key in the file from spoofing it.
    _sha256: str = PrivateAttr(default="")

    @model_validator(mode="after")
    def _cross_check(self) -> Scenario:
        scenario_rules.check(self)
        return self

    @property
    def sha256(self) -> str:
        """Hex SHA-256 of the scenario file's bytes (empty if built in memory)."""
        return self._sha256

    def part(self, part_id: str) -> Part:
        return next(p for p in self.parts if p.id == part_id)

    def goal_pairs(self) -> list[tuple[str, str]]:
        """The final configuration as (P, Q): P attached to Q."""
        return scenario_rules.goal_pairs(self)

    def reachable_pairs(self) -> set[tuple[str, str]]:
        """Declared feasibility as (manipulator, part) pairs."""
        pairs: set[tuple[str, str]] = set()
        for arm, regions in self.feasibility.reachable.items():
            blocked = set(self.feasibility.unreachable_parts.get(arm, []))
            pairs.update((arm, p.id) for p in self.parts if p.region in regions)
            pairs.difference_update((arm, p) for p in blocked)
        return pairs

    def facts(self, reachable: Set[tuple[str, str]] | None = None) -> list[str]:
        """The static facts of docs/domain.md, sorted, without the final period.

        `reachable` replaces the declared feasibility table, e.g. with pairs
        computed from geometry when `feasibility.source = "geometry"`.
        """
        if reachable is None:
            reach = self.reachable_pairs()
        else:
            reach = set(reachable)
            self._check_reach_override(reach)
        facts = {f"region({r.id})" for r in self.regions}
        facts |= {f"humanReach({r.id})" for r in self.regions if r.human_reach}
        facts |= {f"manipulator({m})" for m in self.robot.manipulators}
        for p in self.parts:
            facts |= {f"part({p.id})", f"class({p.class_name},{p.id})", f"loc({p.id},{p.region})"}
            facts |= {f"connection({p.id},{c})" for c in p.connection_points}
            if p.movable:
                facts.add(f"movable({p.id})")
            if p.dangerous:
                facts.add(f"dangerous({p.id})")
        facts |= {f"attachable({a},{b})" for a, b in scenario_rules.attachable_classes(self)}
        facts |= {f"reachable({m},{p})" for m, p in reach}
        facts |= {f"goal({p},{q})" for p, q in self.goal_pairs()}
        facts.add(f"safety({self.preferences.safety})")
        facts.add(f"initiative({self.human.initiative})")
        facts.add(f"verbosity({self.preferences.verbosity})")
        return sorted(facts)

    def _check_reach_override(self, reach: set[tuple[str, str]]) -> None:
        # A typo here would silently make a part unreachable; fail loudly instead.
        arms = set(self.robot.manipulators)
        parts = {p.id for p in self.parts}
        bad = sorted((m, p) for m, p in reach if m not in arms or p not in parts)
        if bad:
            raise ValueError(f"reachable names unknown manipulators or parts: {bad}")
