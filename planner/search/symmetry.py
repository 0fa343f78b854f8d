"""Interchangeable parts: states that differ only by a renaming of them are solved once.

Two parts are interchangeable when swapping their names (and those of the parts
that go onto them: a leg with its foot) leaves every fact of the problem and
every reach answer as it was. Then a state and the state with the swap made are
the same problem under other names, and the plan of one, renamed, is a plan of
the other, optimal at every priority that does not look at names. A class of
such parts is the `members` of one parent in the goal (the legs that go onto the
top and their feet); the planner solves a state once per canonical renaming
(`Symmetry.canonical`) and renames the plan back (`Renaming`).

What names still decide: the id-order tie-breaks of the encodings (preferences.lp,
commonsense.lp: parts taken and asked about in id order) hold in the canonical
names. Members whose state is the same keep their id order in them (members are
sorted by their state, then by id), so the robot still takes loose parts of a
class in id order; between members in different states the order may differ.
The audit does not check symmetry breaking (it is not part of the domain).
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass, field

from planner.vocabulary import State

Member = tuple[str, ...]  # part ids in role order: the member's root, then what goes onto it
# A constant of clingo's term syntax not followed by "(" (then it would name a
# function), or a quoted string, which is left as it is.
_TOKEN = re.compile(r'"(?:\\.|[^"\\])*"|(?<![\w\'])[a-z_][\w\']*(?![\w\'(])')
_CONSTANT = re.compile(r"[a-z_][\w']*")
_GOAL = re.compile(r"^goal\(([^(),]+),([^(),]+)\)$")


def substitute(text: str, mapping: dict[str, str]) -> str:
    """`text` with every constant in `mapping` replaced (not inside strings or names
    of functions)."""

    def one(m: re.Match[str]) -> str:
        return mapping.get(m.group(0), m.group(0))

    return _TOKEN.sub(one, text)


@dataclass(frozen=True)
class Renaming:
    """A renaming of the members of classes, between a state and its canonical state:
    (class, member) to the member whose names it takes, for the members that move."""

    symmetry: Symmetry
    to_canonical: dict[tuple[int, int], int]
    to_actual: dict[tuple[int, int], int]
    # The canonical state this renaming was made for, and that state's actual one:
    # the states of a plan solved for it differ from it in a few fluents, so only
    # those are renamed (`actual_state`).
    canonical_start: State = frozenset()
    actual_start: State = frozenset()
    # Fluents renamed to the actual names so far: the states of one plan share most
    # of their fluents (U14: 494,000 renames of far fewer texts, 1.5 s of planning).
    _actual: dict[str, str] = field(default_factory=dict, compare=False, repr=False)

    def canonical(self, text: str) -> str:
        return self.symmetry.rename(text, self.to_canonical)

    def actual(self, text: str) -> str:
        return self.symmetry.rename(text, self.to_actual)

    def actual_state(self, state: State) -> State:
        """`state` (canonical names) in the actual names. A renaming is one-to-one on
        fluents, so a state near the canonical start is the actual start with the
        fluents it lacks or adds renamed (U30: the search's own CPU 7.8 -> 5.8 s, its
        states of up to 65 fluents renamed one at a time before); the states share
        the actual start's strings."""
        start = self.canonical_start
        gone, added = start - state, state - start
        if not start or len(gone) + len(added) >= len(state):
            return frozenset(self._renamed(state))
        return (self.actual_start - frozenset(self._renamed(gone))) | self._renamed(added)

    def _renamed(self, fluents: Iterable[str]) -> set[str]:
        done, rename, moves = self._actual, self.symmetry.rename, self.to_actual
        out = set()
        for fluent in fluents:
            text = done.get(fluent)
            if text is None:
                text = done[fluent] = rename(fluent, moves)
            out.add(text)
        return out


# What a fluent says about the members of a class: the member it names and its
# text with that member's parts as role placeholders; None: it names none.
_Mention = tuple[int, int, str] | None
_CROSS = (-1, -1, "")  # names parts of two members: no renaming for such a state


@dataclass
class Symmetry:
    """Classes of interchangeable members; each member's parts are in role order,
    members of a class in id order (the canonical names are theirs in this order)."""

    classes: tuple[tuple[Member, ...], ...]
    _of_part: dict[str, tuple[int, int, int]] = field(default_factory=dict, repr=False)
    _mentions: dict[str, _Mention] = field(default_factory=dict, repr=False)
    _filled: dict[tuple[str, int, int], str] = field(default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        for c, members in enumerate(self.classes):
            for m, member in enumerate(members):
                for role, part in enumerate(member):
                    self._of_part[part] = (c, m, role)

    @classmethod
    def of(cls, facts: Iterable[str], reachable: Iterable[tuple[str, str]]) -> Symmetry:
        """The classes of interchangeable members of a problem (facts and reach answers)."""
        fact_set = frozenset(facts) | {f"reachable({m},{p})" for m, p in reachable}
        onto: dict[str, list[str]] = {}
        for fact in sorted(fact_set):
            goal = _GOAL.match(fact)
            if goal:
                onto.setdefault(goal.group(2), []).append(goal.group(1))

        def member(root: str, seen: frozenset[str]) -> Member | None:
            """The root and what goes onto it (depth first, by id); None: a cycle."""
            parts: list[str] = [root]
            for child in sorted(onto.get(root, ())):
                if child in seen:
                    return None
                below = member(child, seen | {child})
                if below is None:
                    return None
                parts.extend(below)
            return tuple(parts)

        classes: list[tuple[Member, ...]] = []
        for parent in sorted(onto):
            found: list[list[Member]] = []
            taken: set[str] = set()
            for root in sorted(onto[parent]):
                mine = member(root, frozenset({root, parent}))
                # Renaming needs members apart (a part going onto two parents would be
                # in two) and named by constants (what `substitute` renames).
                if mine is None or taken & set(mine) or not all(map(_CONSTANT.fullmatch, mine)):
                    continue
                taken |= set(mine)
                for group in found:
                    if _swaps(group[0], mine, fact_set):
                        group.append(mine)
                        break
                else:
                    found.append([mine])
            classes.extend(tuple(members) for members in found if len(members) > 1)
        # A part in two classes (a class inside another's members) would need nested
        # renamings: keep the classes of the larger members.
        used: set[str] = set()
        kept = []
        for members in sorted(classes, key=lambda g: -len(g[0])):
            parts = {p for m in members for p in m}
            if parts & used:
                continue
            used |= parts
            kept.append(members)
        return cls(tuple(kept))

    def __bool__(self) -> bool:
        return bool(self.classes)

    def canonical(self, state: State) -> tuple[State, Renaming | None]:
        """The canonical state of `state` and the renaming between them; None: the
        state is its own canonical state."""
        said: dict[tuple[int, int], list[str]] = {}
        rest: list[str] = []
        for fluent in state:
            mention = self.mention(fluent)
            if mention is None:
                rest.append(fluent)
            elif mention is _CROSS:
                return state, None
            else:
                said.setdefault(mention[:2], []).append(mention[2])
        to_canonical: dict[tuple[int, int], int] = {}
        for c, members in enumerate(self.classes):
            order = sorted(range(len(members)), key=lambda m: _rank(said.get((c, m), []), m))
            for slot, m in enumerate(order):
                if slot != m:
                    to_canonical[(c, m)] = slot
        if not to_canonical:
            return state, None
        canon = rest + [
            self._fill(generic, c, to_canonical.get((c, m), m))
            for (c, m), generics in said.items()
            for generic in generics
        ]
        to_actual = {(c, slot): m for (c, m), slot in to_canonical.items()}
        canonical = frozenset(canon)
        return canonical, Renaming(self, to_canonical, to_actual, canonical, state)

    def rename(self, text: str, moves: dict[tuple[int, int], int]) -> str:
        """`text` with the parts of each member in `moves` named as the member it moves to."""
        mention = self.mention(text)
        if mention is None:
            return text
        if mention is _CROSS:
            parts = {
                part: self.classes[c][to][role]
                for (c, m), to in moves.items()
                for role, part in enumerate(self.classes[c][m])
            }
            return substitute(text, parts)
        c, m, generic = mention
        to = moves.get((c, m), m)
        return text if to == m else self._fill(generic, c, to)

    def _fill(self, generic: str, c: int, m: int) -> str:
        """A text's generic form with member `m` of class `c` named in it (made once:
        the same string object, its hash kept, every time)."""
        key = (generic, c, m)
        text = self._filled.get(key)
        if text is None:
            text = generic
            for role, part in enumerate(self.classes[c][m]):
                text = text.replace(_role(role), part)
            self._filled[key] = text
        return text

    def mention(self, fluent: str) -> _Mention:
        """The member a fluent names and its text with that member's parts as role
        placeholders; None: it names none; (-1, -1, ""): it names two."""
        if fluent in self._mentions:
            return self._mentions[fluent]
        named: set[tuple[int, int]] = set()
        roles: dict[str, int] = {}
        for token in _TOKEN.findall(fluent):
            where = self._of_part.get(token)
            if where is not None:
                named.add(where[:2])
                roles[token] = where[2]
        mention: _Mention
        if not named:
            mention = None
        elif len(named) > 1:
            mention = _CROSS
        else:
            c, m = next(iter(named))
            mention = (c, m, substitute(fluent, {p: _role(r) for p, r in roles.items()}))
        self._mentions[fluent] = mention
        return mention


def _rank(said: list[str], member: int) -> tuple[int, list[str], int]:
    """Where a member goes in the canonical order: the more its state says (the further
    it is assembled), the earlier; then by what it says, then by id. The robot
    assembles in id order, so most states are their own canonical state."""
    return -len(said), sorted(said), member


def _role(role: int) -> str:
    """The placeholder of a member's part in a fluent's text: no constant looks like it."""
    return f"\x00{role}\x01"


def _swaps(a: Member, b: Member, facts: frozenset[str]) -> bool:
    """Whether swapping the parts of members `a` and `b` (role by role) leaves the facts."""
    if len(a) != len(b):
        return False
    mapping = {**dict(zip(a, b, strict=True)), **dict(zip(b, a, strict=True))}
    return all(substitute(f, mapping) in facts for f in facts)
