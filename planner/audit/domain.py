"""A plain-Python model of the Tandem domain (docs/domain.md) for the plan audit.

Deliberately independent of clingo and of `planner/asp/`: the audit exists to
catch mistakes in the encodings, so it re-implements the semantics from the
document instead of reusing the solver.
"""

from __future__ import annotations

import functools
import re
from dataclasses import dataclass

from planner.audit.facts import Facts, parse_facts, term_order
from planner.audit.table import PROPERTIES, PlannedTable
from planner.vocabulary import Term, TermError, constants, parse_term

__all__ = ["Facts", "Term", "TermError", "constants", "parse_facts", "parse_term", "term_order"]

# ---------------------------------------------------------------- state

# A fluent is ("attached", "leg1", "top", "c1"); tuples make matching easy.
Fluent = tuple[str, ...]
State = frozenset[Fluent]

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
HUMAN_FREE: Fluent = ("humanFree",)
HUMAN_HOLDING: Fluent = ("humanHolding",)


def fluent_str(f: Fluent) -> str:
    return f[0] if len(f) == 1 else f"{f[0]}({','.join(f[1:])})"


def parse_state(items: object) -> tuple[State, list[str]]:
    """Parse a node's `state` list; unknown or malformed fluents are errors."""
    if not isinstance(items, list):
        return frozenset(), ["state must be a list of fluent strings"]
    out: set[Fluent] = set()
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
    return frozenset(out), errors


@functools.lru_cache(maxsize=1 << 16)
def _parse_fluent(item: str) -> tuple[Fluent | None, str]:
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


# ---------------------------------------------------------------- actions

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
class Action:
    name: str
    args: tuple[str, ...]
    text: str  # canonical rendering, for messages

    @property
    def kind(self) -> str:
        return _ACTIONS[self.name][0]

    @property
    def deterministic(self) -> bool:
        return _ACTIONS[self.name][2]


def parse_action(text: str, facts: Facts) -> Action | str:
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
    return Action(inner.name, args, shown)


# ---------------------------------------------------------------- semantics


class Domain:
    """Derived notions, preconditions and outcomes over a state (docs/domain.md)."""

    def __init__(self, facts: Facts) -> None:
        self.f = facts
        self.table = PlannedTable(facts) if facts.planned else None

    def join_failures(self, s: State, p: str, q: str) -> list[str]:
        """Why the final configuration may not attach P to Q in `s`: not a goal
        fact, or (planned) not seen to fit (which also rules out every pair no
        stable table contains)."""
        if self.table is not None:
            return self.table.fit_failures(s, p, q)
        return [] if (p, q) in self.f.goals else [f"goal({p},{q})"]

    def goal_onto(self, p: str) -> list[str]:
        pairs = self.f.goal_options if self.table is not None else self.f.goals
        return [q for gp, q in pairs if gp == p]

    # -- derived notions, evaluated in the state before the action
    def held_by(self, s: State, m: str) -> list[str]:
        return sorted(x[2] for x in s if x[0] == "holding" and x[1] == m)

    def free(self, s: State, m: str) -> bool:
        return not self.held_by(s, m)

    def is_attached(self, s: State, p: str) -> bool:
        return any(x[0] == "attached" and x[1] == p for x in s)

    def loose(self, s: State, p: str) -> bool:
        return not self.is_attached(s, p) and not any(x[0] == "holding" and x[2] == p for x in s)

    def chain(self, s: State, q: str) -> list[tuple[str, str]]:
        """(part, point) of each attachment down from Q to the part attached to nothing."""
        steps: list[tuple[str, str]] = []
        seen = {q}
        while True:
            up = sorted((x[2], x[3]) for x in s if x[0] == "attached" and x[1] == q)
            # The visited set guards against attachment cycles in a bad state.
            if not up or up[0][0] in seen:
                return steps
            steps.append(up[0])
            q = up[0][0]
            seen.add(q)

    def root(self, s: State, q: str) -> str:
        steps = self.chain(s, q)
        return steps[-1][0] if steps else q

    def in_reach(self, p: str) -> bool:
        return self.f.loc.get(p) in self.f.human_reach

    def spent(self, s: State) -> int:
        """How often the human took the initiative: the largest `initiatives(N)`, or 0."""
        return max((int(x[1]) for x in s if x[0] == "initiatives"), default=0)

    def initiative_left(self, s: State) -> bool:
        return self.spent(s) < self.f.initiative

    def took_initiative(self, s: State) -> State:
        """Count one more initiative; which part it was is not remembered."""
        n = self.spent(s)
        return (s - {("initiatives", str(n))}) | {("initiatives", str(n + 1))}

    def candidates(self, s: State) -> list[str]:
        if not self.initiative_left(s):
            return []
        return sorted(
            p
            for p in self.f.parts
            if p in self.f.movable
            and self.loose(s, p)
            and self.in_reach(p)
            and ("reserved", p) not in s
        )

    def open_points(self, s: State, p: str, q: str) -> list[str]:
        """Q's unoccupied points that P could take, in ASP term order."""
        if p == q or (self.f.cls.get(p), self.f.cls.get(q)) not in self.f.attachable:
            return []
        taken = {x[3] for x in s if x[0] == "attached" and x[2] == q}
        return sorted(self.f.connections.get(q, set()) - taken, key=term_order)

    def free_point(self, s: State, p: str, q: str) -> str | None:
        """The first open point: points are interchangeable, plans name this one."""
        points = self.open_points(s, p, q)
        return points[0] if points else None

    def arms_at(self, q: str, c: str) -> int:
        return sum((m, q, c) in self.f.point_reach for m in self.f.manipulators)

    def arm_point(self, s: State, m: str, p: str, q: str) -> str | None:
        """Onto a fixed part whose points were checked: the open point M reaches that
        the fewest arms reach (then in term order)."""
        points = [c for c in self.open_points(s, p, q) if (m, q, c) in self.f.point_reach]
        return min(points, key=lambda c: (self.arms_at(q, c), term_order(c)), default=None)

    def human_point(self, s: State, p: str, q: str) -> str | None:
        """Where the plan expects the human to attach P onto Q: the first open point,
        or onto a fixed part whose points were checked the one the most arms reach."""
        if q not in self.f.points_checked:
            return self.free_point(s, p, q)
        points = self.open_points(s, p, q)
        return min(points, key=lambda c: (-self.arms_at(q, c), term_order(c)), default=None)

    def point_failures(self, s: State, m: str, q: str) -> list[str]:
        """Why M cannot work on Q where it stands: Q attached, down its chain, at
        point C of a fixed part R whose points were checked, which M does not reach."""
        stands = next((st for st in self.chain(s, q) if st[0] in self.f.points_checked), None)
        if stands is None or (m, *stands) in self.f.point_reach:
            return []
        return [f"pointReach({m},{stands[0]},{stands[1]})"]

    def still_needed(self, s: State, p: str) -> bool:
        if self.table is not None:
            # Which table the planner chose is its own; any part a table may use
            # and not yet in place may be needed.
            return bool(self.goal_onto(p)) and not self.is_attached(s, p)
        return any(
            gp == p and not any(x[0] == "attached" and x[1:3] == (p, q) for x in s)
            for gp, q in self.f.goals
        )

    def human_workable(self, s: State, q: str) -> bool:
        r = self.root(s, q)
        return self.loose(s, r) and self.in_reach(r)

    def unsafe_region(self, s: State, r: str) -> bool:
        return r in self.f.human_reach and any(
            self.f.loc.get(p) == r and self.loose(s, p) for p in self.f.dangerous
        )

    def tasks(self, s: State) -> list[Fluent]:
        return sorted(x for x in s if x[0] in TASKS)

    def human_knows_not(self, s: State, x: str) -> bool:
        return HUMAN_FREE in s or any(f[0] == "humanHoldingPart" and f[1] != x for f in s)

    def settled(self, p: str) -> set[Fluent]:
        """What is forgotten about P once it is attached."""
        return {
            ("reserved", p),
            ("keepsHolding", p),
            *(("declined", p, q) for q in self.goal_onto(p)),
        }

    def lapse(self, s: State) -> State:
        # The human may have picked up any candidate meanwhile.
        return s - {HUMAN_FREE} if self.candidates(s) else s

    # -- preconditions
    def preconditions(self, s: State, a: Action) -> tuple[list[str], list[str]]:
        """(failed preconditions by name, safety messages) of `a` in `s`."""
        f = self.f
        fails: list[str] = []
        safety: list[str] = []

        def need(ok: bool, name: str) -> None:
            if not ok:
                fails.append(name)

        n, x = a.name, a.args
        p = x[0] if x else ""
        q = x[1] if len(x) > 1 else ""
        if n in ("askHelp", "requestToAttach", "requestToUnhold", "confirmAttach"):
            if p in f.dangerous:
                safety.append(f"safety: {a.text} involves the dangerous part {p}")
        if n in ("askHelp", "requestToAttach") and f.safety == "strict":
            r = f.loc.get(p, "")
            if self.unsafe_region(s, r):
                safety.append(
                    f"safety: {a.text} under strict safety: {p} lies in unsafeRegion({r})"
                )
        if n in ("confirmAttach", "askHelp", "offerHelp", "requestToAttach"):
            # The shared tail of every "the human attaches P to Q" action.
            fails.extend(self.join_failures(s, p, q))
            need(self.free_point(s, p, q) is not None, f"freePoint({p},{q},_)")
            need(self.human_workable(s, q), f"humanWorkable({q})")
        if n in ("askHelp", "requestToAttach"):
            need(HUMAN_FREE in s, "humanFree")
            need(p in f.movable, f"movable({p})")
            need(self.loose(s, p), f"loose({p})")
            need(self.in_reach(p), f"humanReach({f.loc.get(p, '_')})")
        if n in ("confirmAttach", "askHelp", "offerHelp", "requestToAttach",
                 "requestToUnhold", "humanUnholding"):  # fmt: skip
            need(not self.tasks(s), "noTask")
        if n in ("confirmAttach", "offerHelp", "requestToUnhold", "humanUnholding"):
            need(("humanHoldingPart", p) in s, f"humanHoldingPart({p})")

        if n == "hold":
            m, p = x
            need(self.free(s, m), f"free({m})")
            need(p in f.movable, f"movable({p})")
            need(self.loose(s, p), f"loose({p})")
            need((m, p) in f.reachable, f"reachable({m},{p})")
            if self.in_reach(p):
                need(self.human_knows_not(s, p), f"humanKnowsNot({p})")
            need(self.still_needed(s, p), f"stillNeeded({p})")
            bound = [q for q in self.goal_onto(p) if q in f.points_checked]
            if bound and all(self.arm_point(s, m, p, q) is None for q in bound):
                fails.append(f"an open point of {bound[0]} that {m} reaches")
            if self.table is not None:
                fails.extend(self.table.hold_failures(s, p))
        elif n in PROPERTIES:
            if self.table is None:
                fails.append("plannedConfiguration")
            else:
                fails.extend(self.table.sense_failures(s, n, p))
        elif n == "attach":
            fails.extend(self._attach_preconditions(s, a))
        elif n == "unhold":
            held = self.held_by(s, x[0])
            need(bool(held), f"holding({x[0]},_)")
            if held:
                h = held[0]
                carries = any(y[0] == "attached" and y[2] == h for y in s)
                fails.extend(self.point_failures(s, x[0], h))
                if f.points_checked:
                    need(self.is_attached(s, h), f"attached({h},_,_)")
                else:
                    need(
                        self.is_attached(s, h) or carries,
                        f"attached({h},_,_) or attached(_,{h},_)",
                    )
        elif n == "humanHolding":
            need(HUMAN_FREE not in s, "not humanFree")
            need(HUMAN_HOLDING not in s, "not humanHolding")
        elif n == "humanHoldingWhichPart":
            need(HUMAN_HOLDING in s, "humanHolding")
            need(not any(y[0] == "humanHoldingPart" for y in s), "not humanHoldingPart(_)")
        elif n == "humanUnholding":
            need(("reserved", p) in s, f"reserved({p})")
            need(("keepsHolding", p) not in s, f"not keepsHolding({p})")
        elif n == "humanAttachingWhere":
            need(any(y[1:] == (p, q) for y in self.tasks(s)), f"a pending task on ({p},{q})")
        elif n == "confirmAttach":
            need(("reserved", p) not in s, f"not reserved({p})")
        elif n == "askHelp":
            for m in f.manipulators:
                need((m, p) not in f.reachable, f"not reachable({m},{p})")
            need(("declined", p, q) not in s, f"not declined({p},{q})")
        elif n == "offerHelp":
            need(p in f.dangerous, f"dangerous({p})")
            need(any((m, p) in f.reachable for m in f.manipulators), f"reachable(_,{p})")
        elif n == "requestToAttach":
            need(("declined", p, q) in s, f"declined({p},{q})")
        if n in CONVERSATION:
            need(f.verbosity in ("normal", "chatty"), "verbosity normal or chatty")
            if n.startswith("explain"):
                need(f.verbosity == "chatty", "verbosity chatty")
        return fails, safety

    def _attach_preconditions(self, s: State, a: Action) -> list[str]:
        m, q, c = a.args
        held = self.held_by(s, m)
        if not held:
            return [f"holding({m},_)"]
        p = held[0]
        fails: list[str] = []
        if p == q:
            fails.append(f"{p} != {q}")
        if self.is_attached(s, p):
            fails.append(f"not attached({p},_,_)")
        fails.extend(self.join_failures(s, p, q))
        if q in self.f.points_checked:
            if self.arm_point(s, m, p, q) != c:
                fails.append(f"armPoint({m},{p},{q},{c})")
        elif self.free_point(s, p, q) != c:
            fails.append(f"freePoint({p},{q},{c})")
        fails.extend(self.point_failures(s, m, q))
        if any(t[2] == q for t in self.tasks(s)):
            fails.append(f"no pending task with second argument {q}")
        if any(y[0] == "holding" and y[1] != m and y[2] == q for y in s):
            return fails  # Q is held by the other manipulator.
        r = self.root(s, q)
        alt = f"{q} held by the other manipulator, or"
        if not self.loose(s, r):
            fails.append(f"{alt} loose({r})")
        elif (m, r) not in self.f.reachable:
            fails.append(f"{alt} reachable({m},{r})")
        elif r in self.f.movable and self.in_reach(r) and not self.human_knows_not(s, r):
            fails.append(f"{alt} humanKnowsNot({r})")
        return fails

    # -- outcomes
    def outcomes(self, s: State, a: Action) -> dict[str | None, State] | None:
        """Successor state per outcome label (None: deterministic), or None if
        the action cannot be simulated at all (attach/unhold of nothing held)."""
        n, x = a.name, a.args
        p = x[0] if x else ""
        q = x[1] if len(x) > 1 else ""
        hand = {HUMAN_HOLDING, ("humanHoldingPart", p)}
        if n in CONVERSATION:
            return {None: s}  # talk moves no part
        if n == "hold":
            return {None: self.lapse(s | {("holding", x[0], x[1])})}
        if n == "attach":
            held = self.held_by(s, x[0])
            if not held:
                return None
            settled = (s - self.settled(held[0])) | {("attached", held[0], x[1], x[2])}
            return {None: self.lapse(settled)}
        if n == "unhold":
            if not self.held_by(s, x[0]):
                return None
            return {None: self.lapse(frozenset(y for y in s if y[:2] != ("holding", x[0])))}
        if n == "humanHolding":
            cands = self.candidates(s)
            no = s | {HUMAN_FREE}
            if not cands:
                return {"no": no}  # nothing the human could have picked up
            if len(cands) > 1:
                return {"yes": s | {HUMAN_HOLDING}, "no": no}
            yes = self.took_initiative(s) | {HUMAN_HOLDING, ("humanHoldingPart", cands[0])}
            return {"yes": yes, "no": no}
        if n == "humanHoldingWhichPart":
            counted = self.took_initiative(s)
            return {c: counted | {("humanHoldingPart", c)} for c in self.candidates(s)}
        if n == "humanUnholding":
            return {"yes": (s - hand) | {HUMAN_FREE}, "no": s | {("keepsHolding", p)}}
        if n in PROPERTIES:
            return {} if self.table is None else self.table.sense_outcomes(s, n, p)
        if n == "humanAttachingWhere":
            done = {(t, p, q) for t in TASKS} | hand | self.settled(p)
            c = self.human_point(s, p, q)
            return {} if c is None else {c: (s - done) | {("attached", p, q, c), HUMAN_FREE}}
        if n == "confirmAttach":
            return {"yes": s | {("wantToAttach", p, q)}, "no": s | {("reserved", p)}}
        if n == "askHelp":
            took = {("acceptToAttach", p, q), *hand}
            return {"yes": (s - {HUMAN_FREE}) | took, "no": s | {("declined", p, q)}}
        if n == "offerHelp":
            return {
                "yes": (s - hand) | {HUMAN_FREE, ("reserved", p)},
                "no": s | {("wantToAttach", p, q)},
            }
        if n == "requestToUnhold":
            return {None: (s - hand - {("keepsHolding", p)}) | {HUMAN_FREE, ("reserved", p)}}
        if n == "requestToAttach":
            return {None: (s - {HUMAN_FREE}) | {("requestedAttach", p, q), *hand}}
        raise AssertionError(f"unhandled action {a.text}")  # parse_action admits no other

    # -- goal and consistency
    def goal_failures(self, s: State) -> list[str]:
        out = [] if self.table is None else self.table.stable_failures(s)
        out += [
            f"{p} is not attached to {q}"
            for p, q in self.f.goals
            if not any(y[0] == "attached" and y[1:3] == (p, q) for y in s)
        ]
        out += [f"{y[1]} still holds {y[2]}" for y in sorted(s) if y[0] == "holding"]
        out += [f"pending task {fluent_str(t)}" for t in self.tasks(s)]
        return out
