"""A plain-Python model of the Tandem domain (docs/domain.md) for the plan audit.

Deliberately independent of clingo and of `planner/asp/`: the audit exists to
catch mistakes in the encodings, so it re-implements the semantics from the
document instead of reusing the solver. Its states and actions are its own too
(`planner.audit.fluents`, `planner.audit.actions`).
"""

from __future__ import annotations

from collections.abc import Callable

from planner.audit import fluents
from planner.audit.actions import CONVERSATION, SimAction, parse_sim_action
from planner.audit.facts import Facts, term_order
from planner.audit.fluents import HUMAN_FREE, HUMAN_HOLDING, TASKS, SimFluent, SimState, fluent_str
from planner.audit.table import PROPERTIES, PlannedTable

# ---------------------------------------------------------------- semantics


class Domain:
    """Derived notions, preconditions and outcomes over a state (docs/domain.md)."""

    def __init__(self, facts: Facts) -> None:
        self.f = facts
        self.table = PlannedTable(facts) if facts.planned else None
        self._hands = fluents.StateParts(frozenset())
        self._actions: dict[str, SimAction | str] = {}

    def action(self, text: str) -> SimAction | str:
        """`parse_sim_action` of `text`, once per text (a plan has few actions)."""
        found = self._actions.get(text)
        if found is None:
            found = self._actions[text] = parse_sim_action(text, self.f)
        return found

    def hands(self, s: SimState) -> fluents.StateParts:
        """What `s` says about its parts (the last state asked about is kept)."""
        if self._hands.state is not s:
            self._hands = fluents.StateParts(s)
        return self._hands

    def join_failures(self, s: SimState, p: str, q: str) -> list[str]:
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
    def held_by(self, s: SimState, m: str) -> list[str]:
        return sorted(self.hands(s).held.get(m, ()))

    def free(self, s: SimState, m: str) -> bool:
        return m not in self.hands(s).held

    def is_attached(self, s: SimState, p: str) -> bool:
        return p in self.hands(s).onto

    def loose(self, s: SimState, p: str) -> bool:
        hands = self.hands(s)
        return p not in hands.onto and p not in hands.in_hand

    def chain(self, s: SimState, q: str) -> list[tuple[str, str]]:
        """(part, point) of each attachment down from Q to the part attached to nothing."""
        steps: list[tuple[str, str]] = []
        seen = {q}
        onto = self.hands(s).onto
        while True:
            up = sorted(onto.get(q, ()))
            # The visited set guards against attachment cycles in a bad state.
            if not up or up[0][0] in seen:
                return steps
            steps.append(up[0])
            q = up[0][0]
            seen.add(q)

    def root(self, s: SimState, q: str) -> str:
        steps = self.chain(s, q)
        return steps[-1][0] if steps else q

    def in_reach(self, p: str) -> bool:
        return self.f.loc.get(p) in self.f.human_reach

    def spent(self, s: SimState) -> int:
        """How often the human took the initiative: the largest `initiatives(N)`, or 0."""
        return max((int(x[1]) for x in s if x[0] == "initiatives"), default=0)

    def initiative_left(self, s: SimState) -> bool:
        return self.spent(s) < self.f.initiative

    def took_initiative(self, s: SimState) -> SimState:
        """Count one more initiative; which part it was is not remembered."""
        n = self.spent(s)
        return (s - {("initiatives", str(n))}) | {("initiatives", str(n + 1))}

    def candidates(self, s: SimState) -> list[str]:
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

    def open_points(self, s: SimState, p: str, q: str) -> list[str]:
        """Q's unoccupied points that P could take, in ASP term order."""
        if p == q or (self.f.cls.get(p), self.f.cls.get(q)) not in self.f.attachable:
            return []
        taken = {x[3] for x in s if x[0] == "attached" and x[2] == q}
        return sorted(self.f.connections.get(q, set()) - taken, key=term_order)

    def free_point(self, s: SimState, p: str, q: str) -> str | None:
        """The first open point: points are interchangeable, plans name this one."""
        points = self.open_points(s, p, q)
        return points[0] if points else None

    def arms_at(self, q: str, c: str) -> int:
        return sum((m, q, c) in self.f.point_reach for m in self.f.manipulators)

    def arm_point(self, s: SimState, m: str, p: str, q: str) -> str | None:
        """Onto a fixed part whose points were checked: the open point M reaches that
        the fewest arms reach (then in term order)."""
        points = [c for c in self.open_points(s, p, q) if (m, q, c) in self.f.point_reach]
        return min(points, key=lambda c: (self.arms_at(q, c), term_order(c)), default=None)

    def human_point(self, s: SimState, p: str, q: str) -> str | None:
        """Where the plan expects the human to attach P onto Q: the first open point,
        or onto a fixed part whose points were checked the one the most arms reach."""
        if q not in self.f.points_checked:
            return self.free_point(s, p, q)
        points = self.open_points(s, p, q)
        return min(points, key=lambda c: (-self.arms_at(q, c), term_order(c)), default=None)

    def point_failures(self, s: SimState, m: str, q: str) -> list[str]:
        """Why M cannot work on Q where it stands: Q attached, down its chain, at
        point C of a fixed part R whose points were checked, which M does not reach."""
        stands = next((st for st in self.chain(s, q) if st[0] in self.f.points_checked), None)
        if stands is None or (m, *stands) in self.f.point_reach:
            return []
        return [f"pointReach({m},{stands[0]},{stands[1]})"]

    def still_needed(self, s: SimState, p: str) -> bool:
        if self.table is not None:
            # Which table the planner chose is its own; any part a table may use
            # and not yet in place may be needed.
            return bool(self.goal_onto(p)) and not self.is_attached(s, p)
        pairs = self.hands(s).pairs
        return any(gp == p and (p, q) not in pairs for gp, q in self.f.goals)

    def human_workable(self, s: SimState, q: str) -> bool:
        r = self.root(s, q)
        return self.loose(s, r) and self.in_reach(r)

    def unsafe_region(self, s: SimState, r: str) -> bool:
        return r in self.f.human_reach and any(
            self.f.loc.get(p) == r and self.loose(s, p) for p in self.f.dangerous
        )

    def tasks(self, s: SimState) -> list[SimFluent]:
        return sorted(x for x in s if x[0] in TASKS)

    def human_knows_not(self, s: SimState, x: str) -> bool:
        return HUMAN_FREE in s or any(f[0] == "humanHoldingPart" and f[1] != x for f in s)

    def settled(self, p: str) -> set[SimFluent]:
        """What is forgotten about P once it is attached."""
        return {
            ("reserved", p),
            ("keepsHolding", p),
            *(("declined", p, q) for q in self.goal_onto(p)),
        }

    def lapse(self, s: SimState) -> SimState:
        # The human may have picked up any candidate meanwhile.
        return s - {HUMAN_FREE} if self.candidates(s) else s

    # -- preconditions
    def preconditions(self, s: SimState, a: SimAction) -> tuple[list[str], list[str]]:
        """(failed preconditions by name, safety messages) of `a` in `s`: the
        preconditions shared by a family of actions first, then the action's own."""
        fails = self._shared_preconditions(s, a)
        own = _OWN_PRECONDITIONS.get(a.name)
        if own is not None:
            fails += own(self, s, a)
        elif a.name in PROPERTIES:
            fails += self._sense_property_preconditions(s, a)
        if a.name in CONVERSATION:
            fails += self._talk_preconditions(a)
        return fails, self._safety(s, a)

    def _safety(self, s: SimState, a: SimAction) -> list[str]:
        """What `a` would do against the scenario's safety: a dangerous part handed
        to the human, or (strict safety) a part to fetch near a loose dangerous one."""
        p = a.args[0] if a.args else ""
        out: list[str] = []
        if a.name in _INVOLVE_HUMAN and p in self.f.dangerous:
            out.append(f"safety: {a.text} involves the dangerous part {p}")
        if a.name in _HUMAN_FETCHES and self.f.safety == "strict":
            r = self.f.loc.get(p, "")
            if self.unsafe_region(s, r):
                out.append(f"safety: {a.text} under strict safety: {p} lies in unsafeRegion({r})")
        return out

    def _shared_preconditions(self, s: SimState, a: SimAction) -> list[str]:
        n, x = a.name, a.args
        p = x[0] if x else ""
        q = x[1] if len(x) > 1 else ""
        fails: list[str] = []
        if n in _HUMAN_ATTACHES:
            # The shared tail of every "the human attaches P to Q" action.
            fails += self.join_failures(s, p, q)
            fails += _unmet(
                (self.free_point(s, p, q) is not None, f"freePoint({p},{q},_)"),
                (self.human_workable(s, q), f"humanWorkable({q})"),
            )
        if n in _HUMAN_FETCHES:
            fails += _unmet(
                (HUMAN_FREE in s, "humanFree"),
                (p in self.f.movable, f"movable({p})"),
                (self.loose(s, p), f"loose({p})"),
                (self.in_reach(p), f"humanReach({self.f.loc.get(p, '_')})"),
            )
        if n in _NO_TASK:
            fails += _unmet((not self.tasks(s), "noTask"))
        if n in _ABOUT_HELD_PART:
            fails += _unmet((("humanHoldingPart", p) in s, f"humanHoldingPart({p})"))
        return fails

    def _hold_preconditions(self, s: SimState, a: SimAction) -> list[str]:
        f = self.f
        m, p = a.args
        fails = _unmet(
            (self.free(s, m), f"free({m})"),
            (p in f.movable, f"movable({p})"),
            (self.loose(s, p), f"loose({p})"),
            ((m, p) in f.reachable, f"reachable({m},{p})"),
        )
        if self.in_reach(p):
            fails += _unmet((self.human_knows_not(s, p), f"humanKnowsNot({p})"))
        fails += _unmet((self.still_needed(s, p), f"stillNeeded({p})"))
        bound = [q for q in self.goal_onto(p) if q in f.points_checked]
        if bound and all(self.arm_point(s, m, p, q) is None for q in bound):
            fails.append(f"an open point of {bound[0]} that {m} reaches")
        if self.table is not None:
            fails += self.table.hold_failures(s, p)
        return fails

    def _sense_property_preconditions(self, s: SimState, a: SimAction) -> list[str]:
        if self.table is None:
            return ["plannedConfiguration"]
        return self.table.sense_failures(s, a.name, a.args[0])

    def _unhold_preconditions(self, s: SimState, a: SimAction) -> list[str]:
        m = a.args[0]
        held = self.held_by(s, m)
        if not held:
            return [f"holding({m},_)"]
        h = held[0]
        fails = self.point_failures(s, m, h)
        if self.f.points_checked:
            return fails + _unmet((self.is_attached(s, h), f"attached({h},_,_)"))
        carries = any(y[0] == "attached" and y[2] == h for y in s)
        return fails + _unmet(
            (self.is_attached(s, h) or carries, f"attached({h},_,_) or attached(_,{h},_)")
        )

    def _human_holding_preconditions(self, s: SimState, a: SimAction) -> list[str]:
        return _unmet(
            (HUMAN_FREE not in s, "not humanFree"),
            (HUMAN_HOLDING not in s, "not humanHolding"),
        )

    def _which_part_preconditions(self, s: SimState, a: SimAction) -> list[str]:
        return _unmet(
            (HUMAN_HOLDING in s, "humanHolding"),
            (not any(y[0] == "humanHoldingPart" for y in s), "not humanHoldingPart(_)"),
        )

    def _unholding_preconditions(self, s: SimState, a: SimAction) -> list[str]:
        p = a.args[0]
        return _unmet(
            (("reserved", p) in s, f"reserved({p})"),
            (("keepsHolding", p) not in s, f"not keepsHolding({p})"),
        )

    def _attaching_where_preconditions(self, s: SimState, a: SimAction) -> list[str]:
        p, q = a.args
        return _unmet((any(y[1:] == (p, q) for y in self.tasks(s)), f"a pending task on ({p},{q})"))

    def _confirm_preconditions(self, s: SimState, a: SimAction) -> list[str]:
        p = a.args[0]
        return _unmet((("reserved", p) not in s, f"not reserved({p})"))

    def _ask_help_preconditions(self, s: SimState, a: SimAction) -> list[str]:
        p, q = a.args
        robot = [
            ((m, p) not in self.f.reachable, f"not reachable({m},{p})") for m in self.f.manipulators
        ]
        return _unmet(*robot, (("declined", p, q) not in s, f"not declined({p},{q})"))

    def _offer_help_preconditions(self, s: SimState, a: SimAction) -> list[str]:
        p = a.args[0]
        return _unmet(
            (p in self.f.dangerous, f"dangerous({p})"),
            (any((m, p) in self.f.reachable for m in self.f.manipulators), f"reachable(_,{p})"),
        )

    def _request_attach_preconditions(self, s: SimState, a: SimAction) -> list[str]:
        p, q = a.args
        return _unmet((("declined", p, q) in s, f"declined({p},{q})"))

    def _talk_preconditions(self, a: SimAction) -> list[str]:
        verbosity = self.f.verbosity
        fails = _unmet((verbosity in ("normal", "chatty"), "verbosity normal or chatty"))
        if a.name.startswith("explain"):
            fails += _unmet((verbosity == "chatty", "verbosity chatty"))
        return fails

    def _attach_preconditions(self, s: SimState, a: SimAction) -> list[str]:
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
    def outcomes(self, s: SimState, a: SimAction) -> dict[str | None, SimState] | None:
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
        raise AssertionError(f"unhandled action {a.text}")  # parse_sim_action admits no other

    # -- goal and consistency
    def goal_failures(self, s: SimState) -> list[str]:
        out = [] if self.table is None else self.table.stable_failures(s)
        out += [
            f"{p} is not attached to {q}"
            for p, q in self.f.goals
            if not any(y[0] == "attached" and y[1:3] == (p, q) for y in s)
        ]
        out += [f"{y[1]} still holds {y[2]}" for y in sorted(s) if y[0] == "holding"]
        out += [f"pending task {fluent_str(t)}" for t in self.tasks(s)]
        return out


# Families of actions that share preconditions (docs/domain.md).
_HUMAN_ATTACHES = frozenset({"confirmAttach", "askHelp", "offerHelp", "requestToAttach"})
_HUMAN_FETCHES = frozenset({"askHelp", "requestToAttach"})  # a loose part, from the bench
_INVOLVE_HUMAN = frozenset({"askHelp", "requestToAttach", "requestToUnhold", "confirmAttach"})
_NO_TASK = _HUMAN_ATTACHES | {"requestToUnhold", "humanUnholding"}
_ABOUT_HELD_PART = frozenset({"confirmAttach", "offerHelp", "requestToUnhold", "humanUnholding"})

# Each action's own preconditions, beyond its families'.
_OWN_PRECONDITIONS: dict[str, Callable[[Domain, SimState, SimAction], list[str]]] = {
    "hold": Domain._hold_preconditions,
    "attach": Domain._attach_preconditions,
    "unhold": Domain._unhold_preconditions,
    "humanHolding": Domain._human_holding_preconditions,
    "humanHoldingWhichPart": Domain._which_part_preconditions,
    "humanUnholding": Domain._unholding_preconditions,
    "humanAttachingWhere": Domain._attaching_where_preconditions,
    "confirmAttach": Domain._confirm_preconditions,
    "askHelp": Domain._ask_help_preconditions,
    "offerHelp": Domain._offer_help_preconditions,
    "requestToAttach": Domain._request_attach_preconditions,
}


def _unmet(*checks: tuple[bool, str]) -> list[str]:
    """The names of the preconditions that do not hold, in the order given."""
    return [name for ok, name in checks if not ok]
