"""A planned final configuration for the plan audit (docs/domain.md, "Planned table").

Plain Python like `planner.audit.domain`, which asks it: what the robot knows of
a part's shape and length in a state (a fact when the part has one option, a
`shapeIs`/`lengthIs` fluent once sensed), whether a pair may be joined now, and
whether a state is a stable table. The ASP side is `planner/asp/configuration.lp`.
"""

from __future__ import annotations

from planner.audit.facts import Facts
from planner.audit.fluents import SimState

# Sensing query -> (the fluent it adds, the facts' options it reads).
PROPERTIES = {"shapeOf": "shapeIs", "lengthOf": "lengthIs"}


class PlannedTable:
    def __init__(self, facts: Facts) -> None:
        self.f = facts
        self.top = next((p for p, c in facts.cls.items() if c == "top"), "")

    def _options(self, query: str, part: str) -> list[str]:
        return (self.f.shapes if query == "shapeOf" else self.f.lengths).get(part, [])

    def known(self, s: SimState, query: str, part: str) -> str | None:
        """The shape (`shapeOf`) or length (`lengthOf`) of `part` known in `s`, or None."""
        options = self._options(query, part)
        if len(options) == 1:
            return options[0]
        fluent = PROPERTIES[query]
        return next((x[2] for x in sorted(s) if x[0] == fluent and x[1] == part), None)

    def _may(self, s: SimState, query: str, part: str) -> list[str]:
        """What the property may still be: the known value, else every option."""
        seen = self.known(s, query, part)
        return [seen] if seen is not None else self._options(query, part)

    def unknown(self, part: str) -> list[str]:
        """The queries whose answer about `part` is open among options."""
        return [q for q in PROPERTIES if len(self._options(q, part)) > 1]

    # -- sensing what a part is
    def sense_failures(self, s: SimState, query: str, part: str) -> list[str]:
        if len(self._options(query, part)) < 2:
            return [f"{part} has options to sense"]
        if self.known(s, query, part) is not None:
            return [f"not {PROPERTIES[query]}({part},_)"]
        return []

    def sense_outcomes(self, s: SimState, query: str, part: str) -> dict[str | None, SimState]:
        fluent = PROPERTIES[query]
        return {v: s | {(fluent, part, v)} for v in self._options(query, part)}

    # -- joining the table
    def fit_failures(self, s: SimState, p: str, q: str) -> list[str]:
        """Why P may not join Q yet: a foot must be seen to fit its leg's hole; a
        leg on the top must be seen to have the length of the legs already there."""
        if (p, q) not in self.f.goal_options and not self._fit_by_shape(p, q):
            return [f"goalOption({p},{q})"]
        if q == self.top:
            length = self.known(s, "lengthOf", p)
            if length is None:
                return [f"lengthIs({p},_) known"]
            others = {self.known(s, "lengthOf", leg) for leg in self._on(s, self.top)}
            return [f"{p} as long as the legs on {q}"] if others - {length} else []
        shape, hole = self.known(s, "shapeOf", p), self.known(s, "shapeOf", q)
        if shape is None or hole is None:
            return [f"shapes of {p} and {q} known"]
        return [] if shape == hole else [f"{p} ({shape}) fits the hole of {q} ({hole})"]

    def _fit_by_shape(self, p: str, q: str) -> bool:
        # A foot and a leg whose known shapes differ are reported as a misfit below.
        return p in self.f.shapes and q in self.f.shapes and q != self.top

    def hold_failures(self, s: SimState, part: str) -> list[str]:
        """A part is grasped only once what it is is known (it may fit nowhere),
        and not while an arm holds a part attached to it (arms move one at a time)."""
        out = [
            f"{PROPERTIES[q]}({part},_) known before grasping"
            for q in self.unknown(part)
            if self.known(s, q, part) is None
        ]
        held = {x[2] for x in s if x[0] == "holding"}
        out += [
            f"not holding(_,{x[1]}) while {x[1]} is attached to {part}"
            for x in sorted(s)
            if x[0] == "attached" and x[2] == part and x[1] in held
        ]
        return out

    # -- the goal
    def _on(self, s: SimState, q: str) -> list[str]:
        return sorted(x[1] for x in s if x[0] == "attached" and x[2] == q)

    def stable_failures(self, s: SimState) -> list[str]:
        """Why `s` is not a stable table (docs/scenario.md), [] if it is."""
        out: list[str] = []
        legs = self._on(s, self.top)
        slots = len(self.f.connections.get(self.top, set()))
        if len(legs) < slots:
            out.append(f"{self.top} holds {len(legs)} legs, has {slots} slots")
        # Against what may be, not what is seen: every attach needed the fit
        # seen, but a repair may start from what the human did unasked.
        lengths = [set(self._may(s, "lengthOf", leg)) for leg in legs]
        if lengths and not set.intersection(*lengths):
            pairs = zip(legs, lengths, strict=True)
            shown = ", ".join(f"{leg} {'/'.join(sorted(x))}" for leg, x in pairs)
            out.append(f"the legs on {self.top} differ in length ({shown})")
        for part in sorted(self.f.dangerous & self.f.movable):
            # Left over, it could end up in the human's hands for good (safety).
            if not any(x[0] == "attached" and x[1] == part for x in s):
                out.append(f"the dangerous {part} is not in the table")
        for leg in legs:
            feet = self._on(s, leg)
            if not feet:
                out.append(f"{leg} has no foot")
            for foot in feet:
                if not set(self._may(s, "shapeOf", foot)) & set(self._may(s, "shapeOf", leg)):
                    out.append(f"{foot} does not fit the hole of {leg}")
        return out
