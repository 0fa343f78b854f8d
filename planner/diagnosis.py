"""Why a scenario has no plan, in words a person can act on.

Run before the search (and again when a search fails): each rule is a
necessary condition of the domain (docs/domain.md, planner/asp/) read off the
scenario and the feasibility answers alone, so a cause found here is a real
reason why no conditional plan exists, found in microseconds instead of after
a search through every contingency. Each cause is one line with a fix.
"""

from __future__ import annotations

from collections.abc import Set
from dataclasses import dataclass

from planner.scenario.loading import Scenario
from planner.search.errors import DeadEnd

# The kinds of cause, in the order they are reported.
OUT_OF_EVERY_REACH = "outOfEveryReach"
DANGEROUS_ONLY_HUMAN = "dangerousOnlyHuman"
STRICT_SAFETY_BLOCKS = "strictSafetyBlocks"
HUMAN_CANNOT_REACH_ASSEMBLY = "humanCannotReachAssembly"
ROBOT_CANNOT_REACH_ASSEMBLY = "robotCannotReachAssembly"
KINDS = (
    OUT_OF_EVERY_REACH,
    DANGEROUS_ONLY_HUMAN,
    STRICT_SAFETY_BLOCKS,
    HUMAN_CANNOT_REACH_ASSEMBLY,
    ROBOT_CANNOT_REACH_ASSEMBLY,
)


@dataclass(frozen=True)
class Cause:
    """One reason why no plan exists: its kind, the part to act on, the line to show."""

    kind: str
    part: str
    message: str


class Unsolvable(DeadEnd):
    """No conditional plan exists, for a cause named before (or after) the search."""

    def __init__(self, cause: Cause) -> None:
        super().__init__(cause.message)
        self.cause = cause


def causes(scenario: Scenario, reachable: Set[tuple[str, str]]) -> list[Cause]:
    """Every cause found, ordered by kind (see KINDS), then by the goal's order."""
    found = _Bench(scenario, reachable).causes()
    return sorted(found, key=lambda c: KINDS.index(c.kind))


def check(scenario: Scenario, reachable: Set[tuple[str, str]]) -> None:
    """Raise `Unsolvable` for the first cause, if any; before the search."""
    found = causes(scenario, reachable)
    if found:
        raise Unsolvable(found[0])


def explain(err: DeadEnd, scenario: Scenario, reachable: Set[tuple[str, str]]) -> DeadEnd:
    """The error to report for a failed search: its cause when one is found, else `err`."""
    found = causes(scenario, reachable)
    return Unsolvable(found[0]) if found else err


class _Bench:
    """The scenario's parts, regions and reach, indexed for the rules."""

    def __init__(self, scenario: Scenario, reachable: Set[tuple[str, str]]) -> None:
        self.s = scenario
        # A planned table has no pair fixed in advance (goal_pairs() is empty), so
        # no pair is a necessary condition and nothing is refused here; the
        # scenario's own check has made sure every sensing outcome has a table.
        self.goal = scenario.goal_pairs()
        self.onto = dict(self.goal)  # part -> what the goal attaches it to
        self.arms = {p.id: {m for m, q in reachable if q == p.id} for p in scenario.parts}
        self.human_regions = [r.id for r in scenario.regions if r.human_reach]
        # Regions where an arm reaches at least one part: where a part can be moved to.
        robot_regions = {p.region for p in scenario.parts if self.arms[p.id]}
        self.shared = [r for r in self.human_regions if r in robot_regions]

    def human_reaches(self, part: str) -> bool:
        return self.s.part(part).region in self.human_regions

    def chain(self, part: str) -> list[str]:
        """`part` and what the goal attaches it to, up to the assembly's root."""
        out = [part]
        while out[-1] in self.onto and self.onto[out[-1]] not in out:
            out.append(self.onto[out[-1]])
        return out

    def causes(self) -> list[Cause]:
        out: list[Cause] = []
        for p, q in self.goal:
            cause = self.about(p, q)
            if cause is not None:
                out.append(cause)
        return out

    def about(self, p: str, q: str) -> Cause | None:
        part = self.s.part(p)
        if self.arms[p]:
            return self.robot_attaches(p, q)
        where = part.region
        if not self.human_reaches(p):
            into = _either(self.human_regions, "a region the human reaches")
            return Cause(
                OUT_OF_EVERY_REACH,
                p,
                f"{p} lies in {where}, where no arm reaches it and the human cannot: "
                f"move {p} into {into}, or where an arm reaches it",
            )
        if part.dangerous:
            into = _either(self.shared, "a region an arm reaches")
            return Cause(
                DANGEROUS_ONLY_HUMAN,
                p,
                f"{p} is dangerous and only the human reaches it (in {where}), but the human "
                f"may not handle a dangerous part: move {p} into {into}, or mark it not dangerous",
            )
        blocker = self.lasting_danger(p)
        if blocker is not None:
            return Cause(
                STRICT_SAFETY_BLOCKS,
                p,
                f"only the human can fetch {p}, but under strict safety the human may not work "
                f"in {where} while the dangerous {blocker} lies there, and the robot never "
                f"takes {blocker} away: move {blocker} out of {where}, or set "
                'preferences.safety = "normal"',
            )
        chain = self.chain(q)
        if not any(self.human_reaches(x) for x in chain):
            root = chain[-1]
            return Cause(
                HUMAN_CANNOT_REACH_ASSEMBLY,
                p,
                f"only the human can fetch {p}, but {_onto(chain)} out of the human's reach "
                f"(in {self.s.part(root).region}), and the robot cannot take a part from the "
                f"human: move {p} where an arm reaches it, or {root} into "
                f"{_either(self.human_regions, 'a region the human reaches')}",
            )
        return None

    def robot_attaches(self, p: str, q: str) -> Cause | None:
        # An arm reaches p, so the robot may not ask the human for it: in the branch
        # where the human does not pick it up unasked, the robot must attach it.
        # An arm M attaches onto q when M reaches the assembly's root (q or a part
        # q goes onto), or when the other arm holds q.
        chain = self.chain(q)
        q_movable = self.s.part(q).movable
        for m in self.arms[p]:
            if any(m in self.arms[x] for x in chain):
                return None
            if q_movable and self.arms[q] - {m}:
                return None
        root = chain[-1]
        arms = " or ".join(sorted(self.arms[p]))
        return Cause(
            ROBOT_CANNOT_REACH_ASSEMBLY,
            p,
            f"the robot must attach {p} itself (the {arms} arm reaches it, so it may not ask "
            f"the human), but {_onto(chain)} out of that arm's reach (in "
            f"{self.s.part(root).region}): move {root} where the {arms} arm reaches it, "
            f"or {p} where no arm reaches it and the human does",
        )

    def lasting_danger(self, p: str) -> str | None:
        """Under strict safety, a dangerous part that stays loose in p's region forever."""
        if self.s.preferences.safety != "strict":
            return None
        region = self.s.part(p).region
        needed = {x for x, _ in self.goal}
        for d in self.s.parts:
            if d.dangerous and d.region == region and d.id != p:
                # The robot picks up only what the goal needs and only what it reaches.
                if not d.movable or d.id not in needed or not self.arms[d.id]:
                    return d.id
        return None


def _either(regions: list[str], otherwise: str) -> str:
    if not regions:
        return otherwise
    if len(regions) == 1:
        return f"the {regions[0]} region"
    return "the " + " or ".join(regions) + " region"


def _onto(chain: list[str]) -> str:
    """What a part goes onto, with the assembly's root: `the top it goes onto lies`."""
    if len(chain) == 1:
        return f"the {chain[0]} it goes onto lies"
    return f"{' and '.join(chain[:-1])} and the {chain[-1]} it goes onto lie"
