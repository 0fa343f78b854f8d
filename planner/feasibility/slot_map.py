"""Slots that match the world: the plan's connection points mapped onto the real ones.

A plan names connection points canonically (the first free one), so its `c1`
means "whichever free slot". Outcomes, scripts and surprises speak the plan's
names; a `SlotMap` says, per part, which real point each name stands for, one to
one. It changes when the human attaches at another free point than the branch
names (the two free points swap, so the branch's later `c2` is the real point
that is still free), and when the robot's arm cannot reach the free point its
attach names (`robot_choice`: it takes the first free one it reaches). The plan
stores, per node, the map its motion assumes (`PlanNode.slots`) and the robot's
choice (`PlanNode.robot_slot`); the executor (app.execution.slots) keeps the
world's map and re-targets a motion where the two differ.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping

from planner.feasibility.scene import Site, site_of
from planner.plan.model import RobotSlot
from planner.vocabulary import Action, Attach, Attached, Hands, parse_fluent


class SlotError(ValueError):
    """An observed slot that the part does not have, or that is taken; one line."""


def connection_points(facts: Iterable[str]) -> dict[str, list[str]]:
    """Each part's connection points, from a plan's `connection(Q,C)` facts."""
    out: dict[str, list[str]] = {}
    for fact in facts:
        if fact.startswith("connection(") and fact.endswith(")"):
            part, _, point = fact[len("connection(") : -1].partition(",")
            out.setdefault(part, []).append(point)
    return out


class SlotMap:
    """Plan name -> real point, per part; the identity until someone deviates."""

    def __init__(
        self, facts: Iterable[str], real: Mapping[str, Mapping[str, str]] | None = None
    ) -> None:
        self.points = connection_points(facts)
        # part -> {plan name: real point}, only the names that differ
        self._real: dict[str, dict[str, str]] = {
            part: {b: r for b, r in m.items() if b != r} for part, m in (real or {}).items()
        }
        self._real = {part: m for part, m in self._real.items() if m}

    def copy(self) -> SlotMap:
        out = SlotMap(())
        out.points = self.points
        out._real = {part: dict(m) for part, m in self._real.items()}
        return out

    def __eq__(self, other: object) -> bool:
        return isinstance(other, SlotMap) and self._real == other._real

    def __hash__(self) -> int:
        return hash(str(self.to_json()))

    def problems(self) -> list[str]:
        """What makes this map not one to one over each part's points, in words."""
        out = []
        for part, m in self._real.items():
            points = set(self.points.get(part, []))
            full = {p: self.real(part, p) for p in points}
            if not set(m) <= points or set(full.values()) != points:
                out.append(f"the slot map of {part} is not one to one over its points")
        return out

    @property
    def identity(self) -> bool:
        return not self._real

    def real(self, part: str, point: str) -> str:
        return self._real.get(part, {}).get(point, point)

    def state(self, state: Iterable[str]) -> list[str]:
        """`state` as the world holds it: every attachment at its real point."""
        if not self._real:
            return list(state)  # the identity: most nodes, no fluent to parse
        out = []
        for text in state:
            fluent = parse_fluent(text)
            if isinstance(fluent, Attached):
                text = str(Attached(fluent.part, fluent.onto, self.real(fluent.onto, fluent.slot)))
            out.append(text)
        return out

    def action(self, action: Action) -> Action:
        """`action` as the robot must do it: an attach at the real point."""
        if isinstance(action, Attach):
            return Attach(action.arm, action.onto, self.real(action.onto, action.slot))
        return action

    def follow(self, onto: str, branch: str, real: str, state: Iterable[str]) -> None:
        """Someone attached at real point `real` where the branch (in `state`) says `branch`."""
        points = self.points.get(onto, [])
        if real not in points:
            raise SlotError(f"{onto} has no connection point {real} (it has {', '.join(points)})")
        if real not in self.free(onto, state):
            raise SlotError(f"{onto}'s {real} is taken already")
        mapping = {p: self.real(onto, p) for p in points}
        before = mapping[branch]
        other = next(p for p, r in mapping.items() if r == real)
        mapping[branch], mapping[other] = real, before
        changed = {p: r for p, r in mapping.items() if p != r}
        if changed:
            self._real[onto] = changed
        else:
            self._real.pop(onto, None)

    def branch(self, part: str, real: str) -> str:
        """The branch's name of `part`'s real point `real`."""
        return next((b for b, r in self._real.get(part, {}).items() if r == real), real)

    def free(self, onto: str, state: Iterable[str]) -> list[str]:
        """`onto`'s points free in the world, where the branch is in `state`."""
        taken = {
            f.slot
            for f in map(parse_fluent, self.state(state))
            if isinstance(f, Attached) and f.onto == onto
        }
        return [p for p in self.points.get(onto, []) if p not in taken]

    def to_json(self) -> dict[str, dict[str, str]]:
        return {part: dict(sorted(m.items())) for part, m in sorted(self._real.items())}


Reaches = Callable[[str, Site], bool]  # can this arm work at this site?


def robot_choice(
    slots: SlotMap, action: Action, state: list[str], reaches: Reaches
) -> RobotSlot | None:
    """The plan's slot means "whichever free slot": when the acting arm cannot reach the
    real point an attach names, the robot attaches at the first free one it reaches, and
    `slots` follows (what it chose, or None). Only onto a part attached to nothing, whose
    points lie apart, and not held by the other arm (which brings it over)."""
    if not isinstance(action, Attach):
        return None
    real_state = slots.state(state)
    hands = Hands.of(real_state)
    if action.onto in hands.attached or action.onto in hands.holding.values():
        return None
    real = slots.real(action.onto, action.slot)
    if reaches(action.arm, site_of(hands.attached, action.onto, real)):
        return None
    for point in slots.free(action.onto, state):
        if reaches(action.arm, site_of(hands.attached, action.onto, point)):
            slots.follow(action.onto, action.slot, point, state)
            why = f"{action.arm} cannot reach {real}"
            return RobotSlot(onto=action.onto, branch=action.slot, real=point, why=why)
    return None
