"""Slots that match the world: the branch's connection points mapped onto the real ones.

A plan names connection points canonically (the first free one), so its `c1`
means "whichever free slot". When the human attaches a part at another free slot
than the branch names, the executor follows the branch and keeps a `SlotMap`:
per part, a one-to-one map from the branch's points to the real ones. Swapping
the two free points keeps it one-to-one, so the branch's later `c2` is the real
`c1` that is still free. The real state and action (the branch's, renamed) are
what the robot's motions must target (`planner.feasibility.plan_motions`).
"""

from __future__ import annotations

from collections.abc import Iterable

from planner.vocabulary import Action, Attach, Attached, parse_fluent


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
    """Branch point -> real point, per part; the identity until the human deviates."""

    def __init__(self, facts: Iterable[str]) -> None:
        self.points = connection_points(facts)
        self._real: dict[str, dict[str, str]] = {}  # part -> {branch point: real point}

    @property
    def identity(self) -> bool:
        return not self._real

    def real(self, part: str, point: str) -> str:
        return self._real.get(part, {}).get(point, point)

    def state(self, state: Iterable[str]) -> list[str]:
        """`state` as the world holds it: every attachment at its real point."""
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
        """The human attached at `real` where the branch (in `state`) says `branch`."""
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
