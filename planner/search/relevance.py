"""Members that no longer matter to a solve: a state solved on a program without them.

A solve pays for the whole grounded program (at U30, 57,000 variables, and clasp's
update of them on every solve: docs/performance.md), though a plan to the next
milestone touches a few parts. Members of a class of interchangeable parts
(`planner.search.symmetry`) of two kinds are left out of a solve, and its optimal
plans stay those of the whole program:

- **Finished**: every goal attachment of its parts made, nothing else said of
  them. No action takes or asks about a part that is not loose, and no rule reads
  them but for the points they occupy, which the state keeps as `blocked(Q,C)`.
- **Waiting**, beyond the first `horizon - 1` of a group: members in the same
  state up to renaming (untouched, or their own parts attached to each other), of
  which nothing else is said. A plan to the next milestone touches at most
  `horizon - 1` members (one step at least makes the milestone), so an optimal plan
  that touches a left-out member has an equal one that touches a kept member, with
  a lower id, instead. What the left-out members' loose parts add to the rules that
  read every loose part stands in for them: how many lie below each part in id
  order (preferences.lp's lowest priority, `skippedBelow(P,B)` in binary), whether
  one the human would be asked for does (commonsense.lp, `delegableBelow(P)`), the
  regions a dangerous one makes unsafe (safety.lp, `unsafeElsewhere(R)`). (The goal
  stays unmet without them: the kept members of their group are not finished
  either.) Only where the human has no initiative
  left (no outcome then names a part the human picked up unasked), no action is
  banned at the start (a ban could make a left-out member the best choice), and no
  point was checked by geometry (lookahead.lp matches every leg still to place).

The kept members take the names of the last members of their class, so that one
program per shape (how many members each class keeps) serves every state of that
shape. Names then no longer follow id order, so a program without members is given
the order of the loose parts it keeps (`below(P2,P)`: only loose parts are read in
id order, and a part that is not loose never is again) instead of state.lp's
`nextPart`. Every state of U30 that is left without members gets the plan of the
whole program (4,273 of 4,293 at horizon 3, the others solved there).
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

from planner.search.solver import SequentialPlan, Step
from planner.search.symmetry import Member, Symmetry, substitute
from planner.vocabulary import Action, State, parse_action

# What a program without some members adds to the domain, assumed with the state's
# fluents: what stands in for the members left out (the module's docstring).
SKIP_BITS = 7
RULES = f"""
#external blocked(Q,C) : connection(Q,C).
occupied(Q,C,T) :- blocked(Q,C), time(T).
skipBit(0..{SKIP_BITS - 1}).
#external skippedBelow(P,B) : movable(P), skipBit(B).
:~ heldAt(P,T), skippedBelow(P,B). [2**B@0,T,P,B,skipped]
chainGiven.
#external below(P2,P) : movable(P2), movable(P), P != P2.
:~ heldAt(P,T), below(P2,P), stillNeeded(P2,T), loose(P2,T), robotReaches(P2). [1@0,T,P2]
delegableBefore(P,T) :- delegable(P2,T), below(P2,P).
#external delegableBelow(P) : movable(P).
delegableBefore(P,T) :- delegableBelow(P), time(T).
#external unsafeElsewhere(R) : humanReach(R).
unsafeRegion(R,T) :- unsafeElsewhere(R), time(T).
"""
# The externals above, assumed with the state's fluents (`solver.BranchSolver`).
EXTERNALS = (
    ("blocked", 2),
    ("skippedBelow", 2),
    ("below", 2),
    ("delegableBelow", 1),
    ("unsafeElsewhere", 1),
)
_HELPERS = tuple(f"{name}(" for name, _ in EXTERNALS)
# How many members of each class a program keeps: a state keeps the next rung up
# (of its class that keeps most), so that few programs serve every state. A state
# that keeps more is solved on the whole program: at U30, programs keeping 8-12
# members took more to ground and to hold (10-40 MB each in every worker) than
# their few states gained (the bench: 34.6 s and 992 MB against 37.9 s and 1,119 MB).
RUNGS = (1, 2, 3, 4, 5, 6)
_ATTACHED = re.compile(r"^attached\(([^,()]+),([^,()]+),([^()]+)\)$")
_TOKEN = re.compile(r"[a-z_][\w']*")
_HOLDING = re.compile(r"^holding\([^,()]+,([^,()]+)\)$")

Shape = tuple[int, ...]  # members kept, per class


@dataclass
class Reduction:
    """A state in the names of the program of its `shape`, and the way back."""

    shape: Shape
    state: State
    to_actual: dict[str, str]  # a kept part's name in the program -> its own
    to_program: dict[str, str]
    left_out: State  # the fluents of the members left out, added back to every state
    waiting: int  # how many of them are waiting (the others are finished)
    _back: dict[str, str] = field(default_factory=dict)

    def forbidden(self, forbid: Iterable[str]) -> frozenset[str]:
        return frozenset(substitute(a, self.to_program) for a in forbid)

    def actual_state(self, state: State) -> State:
        out = set(self.left_out)
        for fluent in state:
            if fluent.startswith(_HELPERS):
                continue
            back = self._back.get(fluent)
            if back is None:
                back = self._back[fluent] = substitute(fluent, self.to_actual)
            out.add(back)
        return frozenset(out)

    def actual_plan(self, plan: SequentialPlan) -> SequentialPlan:
        steps = [
            Step(
                self.actual_state(s.state),
                self._action(s.action),
                None if s.outcome is None else substitute(s.outcome, self.to_actual),
                self.actual_state(s.after),
                s.after_goal,
            )
            for s in plan.steps
        ]
        return SequentialPlan(steps, plan.start_goal, plan.steps_cost_only)

    def _action(self, action: Action) -> Action:
        return parse_action(substitute(str(action), self.to_actual))


@dataclass(frozen=True)
class _Kinds:
    """The members of one class in a state: those kept, and the finished ones among
    those left out (the others wait)."""

    kept: list[int]
    finished: dict[int, list[str]]  # member -> the points it blocks


class Relevance:
    """Which members a state's solve leaves out, and the facts of each shape's program."""

    def __init__(
        self,
        classes: Sequence[Sequence[Member]],
        facts: Sequence[str],
        reachable: Iterable[tuple[str, str]],
    ) -> None:
        self.symmetry = Symmetry(tuple(tuple(c) for c in classes))
        self.facts = tuple(facts)
        self.reachable = frozenset(reachable)
        self._goals: dict[str, set[str]] = {}
        for fact in facts:
            m = re.fullmatch(r"goal\(([^,()]+),([^,()]+)\)", fact)
            if m:
                self._goals.setdefault(m.group(1), set()).add(m.group(2))
        self._reaches = {part for _, part in self.reachable}
        self._movable = {f[8:-1] for f in facts if f.startswith("movable(")}
        self._dangerous = {f[10:-1] for f in facts if f.startswith("dangerous(")}
        self._human_reach = {f[11:-1] for f in facts if f.startswith("humanReach(")}
        self._loc: dict[str, str] = {}
        for fact in facts:
            if m := re.fullmatch(r"loc\(([^,()]+),([^,()]+)\)", fact):
                self._loc[m.group(1)] = m.group(2)
        self._member_parts = {p for c in self.symmetry.classes for m in c for p in m}
        parts = {f[5:-1] for f in facts if f.startswith("part(")}
        self._others = sorted(parts - self._member_parts)
        budgets = [int(f[11:-1]) for f in facts if re.fullmatch(r"initiative\(\d+\)", f)]
        self._budget = budgets[0] if budgets else 1
        # Waiting members are left out only where geometry fixes no point, and where
        # a class's members are in the same id order in every role (the exchange).
        self._waiting_ok = not any(f.startswith("pointsChecked(") for f in facts)
        self._ordered = [_role_ordered(c) for c in self.symmetry.classes]

    def facts_of(self, shape: Shape) -> tuple[tuple[str, ...], frozenset[tuple[str, str]]]:
        """The facts and reach answers of the program of `shape`."""
        gone = {
            part
            for c, members in enumerate(self.symmetry.classes)
            for member in members[: len(members) - shape[c]]
            for part in member
        }
        facts = tuple(f for f in self.facts if not gone.intersection(_TOKEN.findall(f)))
        return facts, frozenset(p for p in self.reachable if p[1] not in gone)

    def reduce(self, state: State, horizon: int, forbid: frozenset[str]) -> Reduction | None:
        """`state` in the program of its shape; None: solved on the whole program."""
        said = self._said(state)
        if said is None:
            return None
        waiting = self._waiting_ok and not forbid and self._spent(state)
        kinds = [
            self._kinds(c, said, waiting, horizon - 1) for c in range(len(self.symmetry.classes))
        ]
        shape = self._shape(kinds)
        if shape is None:
            return None
        return self._reduction(state, said, kinds, shape)

    def _said(self, state: State) -> dict[tuple[int, int], list[str]] | None:
        said: dict[tuple[int, int], list[str]] = {}
        for fluent in state:
            mention = self.symmetry.mention(fluent)
            if mention is None:
                continue
            if mention[0] < 0:
                return None  # names two members
            said.setdefault(mention[:2], []).append(fluent)
        return said

    def _spent(self, state: State) -> bool:
        taken = [int(f[12:-1]) for f in state if f.startswith("initiatives(")]
        return max(taken, default=0) >= self._budget

    def _kinds(
        self, c: int, said: dict[tuple[int, int], list[str]], waiting: bool, keep: int
    ) -> _Kinds:
        kept: list[int] = []
        finished: dict[int, list[str]] = {}
        groups: dict[tuple[str, ...], list[int]] = {}
        for m, member in enumerate(self.symmetry.classes[c]):
            fluents = said.get((c, m), [])
            blocks = self._finished(member, fluents)
            if blocks is not None:
                finished[m] = blocks
            elif waiting and self._ordered[c] and self._waits(member, fluents):
                group = tuple(sorted(self._generic(f) for f in fluents))
                groups.setdefault(group, []).append(m)
            else:
                kept.append(m)
        for members in groups.values():
            kept.extend(members[:keep])
        return _Kinds(sorted(kept), finished)

    def _finished(self, member: Member, fluents: list[str]) -> list[str] | None:
        """The points a finished member occupies outside itself; None: not finished."""
        made: set[tuple[str, str]] = set()
        blocks = []
        for fluent in fluents:
            m = _ATTACHED.match(fluent)
            if m is None:
                return None
            part, onto, point = m.groups()
            if onto not in self._goals.get(part, ()):
                return None
            made.add((part, onto))
            if onto not in member:
                blocks.append(f"blocked({onto},{point})")
        wanted = {(p, q) for p in member for q in self._goals.get(p, ())}
        return blocks if wanted and made == wanted else None

    def _generic(self, fluent: str) -> str:
        mention = self.symmetry.mention(fluent)
        return fluent if mention is None else mention[2]

    @staticmethod
    def _waits(member: Member, fluents: list[str]) -> bool:
        """Whether nothing is said of the member but attachments of its parts to each other."""
        for fluent in fluents:
            m = _ATTACHED.match(fluent)
            if m is None or m.group(1) not in member or m.group(2) not in member:
                return False
        return True

    def _shape(self, kinds: list[_Kinds]) -> Shape | None:
        """The members each class keeps: one rung for every class (few programs, each
        with its memory), or None where no class would leave a member out."""
        need = max((len(kind.kept) for kind in kinds), default=0)
        rung = next((r for r in RUNGS if r >= need), None)
        sizes = [len(members) for members in self.symmetry.classes]
        if rung is None or rung >= max(sizes, default=0):
            return None
        return tuple(min(rung, size) for size in sizes)

    def _reduction(
        self,
        state: State,
        said: dict[tuple[int, int], list[str]],
        kinds: list[_Kinds],
        shape: Shape,
    ) -> Reduction:
        to_program: dict[str, str] = {}
        left_out: set[str] = set()
        helpers: set[str] = set()
        loose: list[str] = []  # the loose parts of the waiting members left out
        waiting = 0
        for c, kind in enumerate(kinds):
            members = self.symmetry.classes[c]
            out = [m for m in range(len(members)) if m not in kind.kept]
            # Put back first: the last members left out (the robot assembles in id
            # order, so the members kept are mostly the last ones already).
            kept = sorted([*kind.kept, *out[len(out) - (shape[c] - len(kind.kept)) :]])
            first = len(members) - shape[c]
            for slot, m in enumerate(kept, start=first):
                to_program.update(zip(members[m], members[slot], strict=True))
            for m in set(out) - set(kept):
                left_out.update(said.get((c, m), []))
                if m in kind.finished:
                    helpers.update(kind.finished[m])
                else:
                    waiting += 1
                    loose.extend(_loose(members[m], said.get((c, m), [])))
        helpers.update(self._below(to_program, state))
        helpers.update(self._stand_ins(to_program, loose))
        kept_state = [substitute(f, to_program) for f in state - left_out]
        return Reduction(
            shape,
            frozenset([*kept_state, *helpers]),
            {v: k for k, v in to_program.items()},
            to_program,
            frozenset(left_out),
            waiting,
        )

    def _stand_ins(self, to_program: dict[str, str], loose: list[str]) -> list[str]:
        """What the loose parts left out (still needed: waiting) add to the rules that
        read every loose part: the count of those an arm reaches below each part in id
        order (preferences.lp), whether one the human would be asked for lies below it
        (commonsense.lp), and the human's regions a dangerous one makes unsafe
        (safety.lp)."""
        reached = [p for p in loose if p in self._reaches]
        asked = [p for p in loose if p not in self._reaches and self._human_may_fetch(p)]
        out = [
            f"unsafeElsewhere({self._loc[p]})"
            for p in loose
            if p in self._dangerous and self._loc.get(p) in self._human_reach
        ]
        for part in [*to_program, *self._others]:
            if part not in self._movable:
                continue
            name = to_program.get(part, part)
            count = sum(1 for p in reached if p < part)
            if count >= 2**SKIP_BITS:
                raise ValueError(f"{count} parts left out below {part}: more than SKIP_BITS")
            out.extend(f"skippedBelow({name},{b})" for b in range(SKIP_BITS) if count >> b & 1)
            if any(p < part for p in asked):
                out.append(f"delegableBelow({name})")
        return out

    def _human_may_fetch(self, part: str) -> bool:
        """commonsense.lp's `delegable`, for a loose part still needed."""
        return (
            part in self._movable
            and self._loc.get(part) in self._human_reach
            and part not in self._dangerous
        )

    def _below(self, to_program: dict[str, str], state: State) -> list[str]:
        """Which loose movable part lies below which in their own id order, under their
        program names (preferences.lp and commonsense.lp read id order between loose
        parts alone; the program's names are in another order)."""
        fixed = {m.group(1) for f in state if (m := _ATTACHED.match(f))}
        fixed.update(m.group(1) for f in state if (m := _HOLDING.match(f)))
        loose = sorted(
            p for p in [*to_program, *self._others] if p in self._movable and p not in fixed
        )
        named = [to_program.get(p, p) for p in loose]
        return [f"below({a},{b})" for i, b in enumerate(named) for a in named[:i]]


def _loose(member: Member, fluents: list[str]) -> list[str]:
    """The parts of a waiting member that lie loose (attached to nothing)."""
    attached = {m.group(1) for f in fluents if (m := _ATTACHED.match(f))}
    return [p for p in member if p not in attached]


def _role_ordered(members: Sequence[Member]) -> bool:
    """Whether members in id order have every role's parts in id order too."""
    return all(list(roles) == sorted(roles) for roles in zip(*members, strict=True))
