"""The scenario: a file's validated sections and the facts they give.

The sections (`scenario_sections`) check types and per-field syntax; the
checks that look across fields live in `scenario_rules` and run from
`Scenario`'s after-validator, so a `Scenario` object is always a consistent
scenario.
"""

from __future__ import annotations

from collections.abc import Set
from typing import Annotated

from pydantic import Field, PrivateAttr, model_validator

from planner.scenario import rules as scenario_rules
from planner.scenario.sections import (
    DEFAULT_LANGUAGE,
    Camera,
    Feasibility,
    Goal,
    Human,
    OneLine,
    Part,
    Preferences,
    Region,
    Robot,
    StrictModel,
)

__all__ = [
    "Camera", "Feasibility", "Goal", "Human", "Part", "Preferences", "Region", "Robot", "Scenario",
]


class Scenario(StrictModel):
    name: OneLine
    description: str | None = None
    preferences: Preferences = Preferences()
    regions: Annotated[list[Region], Field(min_length=1)]
    robot: Robot = Robot()
    human: Human = Human()
    feasibility: Feasibility = Feasibility()
    camera: Camera = Camera()
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

    def goal_options(self) -> list[tuple[str, str]]:
        """The (P, Q) pairs a planned configuration chooses from (docs/scenario.md)."""
        return scenario_rules.goal_options(self)

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
            cls = p.kind if self.goal.planned and p.kind != "top" else p.class_name
            facts |= {f"part({p.id})", f"class({cls},{p.id})", f"loc({p.id},{p.region})"}
            facts |= {f"connection({p.id},{c})" for c in p.connection_points}
            if p.movable:
                facts.add(f"movable({p.id})")
            if p.dangerous:
                facts.add(f"dangerous({p.id})")
        facts |= {f"attachable({a},{b})" for a, b in scenario_rules.attachable_classes(self)}
        facts |= {f"reachable({m},{p})" for m, p in reach}
        facts |= {f"goal({p},{q})" for p, q in self.goal_pairs()}
        if self.goal.planned:
            facts |= self._configuration_facts()
        facts.add(f"safety({self.preferences.safety})")
        facts.add(f"initiative({self.human.initiative})")
        facts.add(f"verbosity({self.preferences.verbosity})")
        if self.human.language != DEFAULT_LANGUAGE:
            # Only when not the default, so English plans keep their facts and hashes.
            facts.add(f'language("{self.human.language}")')
        return sorted(facts)

    def _configuration_facts(self) -> set[str]:
        # Only for a planned configuration, so fixed scenarios keep their facts and hashes.
        facts = {"plannedConfiguration"}
        facts |= {f"goalOption({p},{q})" for p, q in self.goal_options()}
        for p in self.parts:
            facts |= {f"shapeOption({p.id},{v})" for v in p.shape_options}
            facts |= {f"lengthOption({p.id},{v})" for v in p.length_options}
        return facts

    def _check_reach_override(self, reach: set[tuple[str, str]]) -> None:
        # A typo here would silently make a part unreachable; fail loudly instead.
        arms = set(self.robot.manipulators)
        parts = {p.id for p in self.parts}
        bad = sorted((m, p) for m, p in reach if m not in arms or p not in parts)
        if bad:
            raise ValueError(f"reachable names unknown manipulators or parts: {bad}")
