"""Members that no longer matter: states solved on programs without them get the plans
of the whole program (planner.search.relevance)."""

from __future__ import annotations

import random

from planner.planning import feasible_pairs, plan_scenario
from planner.scenario import paper
from planner.scenario.loading import Scenario, parse_scenario
from planner.search.encoding import FeasibilityContext
from planner.search.hcp import ConditionalPlanner
from planner.search.relevance import EXTERNALS, RULES, Reduction, Relevance
from planner.search.solver import BranchSolver, SequentialPlan
from planner.search.symmetry import Symmetry
from planner.vocabulary import State


def _declared(family: str, n: int) -> Scenario:
    return parse_scenario(paper.scenario_toml(family, n, "declared"), f"{family}{n}")


def _facts(scenario: Scenario) -> tuple[list[str], frozenset[tuple[str, str]]]:
    reachable, _ = feasible_pairs(scenario, None)
    facts = sorted(f for f in scenario.facts(reachable) if not f.startswith("reachable("))
    return facts, reachable


def _relevance(scenario: Scenario) -> Relevance:
    facts, reachable = _facts(scenario)
    return Relevance(Symmetry.of(facts, reachable).classes, facts, reachable)


# U10: the odd shared legs (3, 5, 7, 9) and the even ones (4, 6, 8, 10) with their feet
# are two classes; leg1 and leg2 have no twin.
FINISHED_3 = {"attached(leg3,top,c1)", "attached(foot3,leg3,foot)"}
SPENT = {"humanHolding", "humanHoldingPart(leg2)", "initiatives(1)"}


def test_finished_members_leave_their_points_blocked_and_come_back() -> None:
    relevance = _relevance(_declared("U", 10))
    state = frozenset({*FINISHED_3, *SPENT, "holding(left,leg1)"})
    reduced = relevance.reduce(state, 3, frozenset())
    assert reduced is not None
    # Pair 3 is left out, its point blocked; everything else is kept or stands in.
    assert "blocked(top,c1)" in reduced.state
    assert not any("leg3" in f or "foot3" in f for f in reduced.state)
    assert reduced.actual_state(reduced.state) == state
    # A state of the program maps back with the left-out member's fluents.
    after = frozenset({*reduced.state, "attached(leg1,top,c2)"})
    assert reduced.actual_state(after) == state | {"attached(leg1,top,c2)"}


def test_waiting_members_are_left_out_only_where_no_initiative_or_ban_is_left() -> None:
    relevance = _relevance(_declared("U", 10))
    spent = frozenset({*FINISHED_3, *SPENT})
    reduced = relevance.reduce(spent, 3, frozenset())
    assert reduced is not None
    # Loose pairs beyond two of each class are left out (one odd, two even): counted
    # below the parts kept, and the shared region stays unsafe (dangerous feet).
    assert reduced.waiting == 3 and "unsafeElsewhere(shared)" in reduced.state
    # Pairs 9, 6 and 8 are left out, every part of them loose and reached. Below leg2
    # in id order lie their three feet (3 = bits 0 and 1); below leg7, kept as the
    # odd class's last member leg9, the feet and leg6 (4 = bit 2); below foot7,
    # kept as foot9, foot6 alone.
    assert reduced.to_program["leg7"] == "leg9" and reduced.to_program["foot7"] == "foot9"
    counts = {f for f in reduced.state if f.startswith("skippedBelow(")}
    assert {"skippedBelow(leg2,0)", "skippedBelow(leg2,1)", "skippedBelow(leg9,2)"} <= counts
    assert "skippedBelow(leg9,0)" not in counts and "skippedBelow(foot9,0)" in counts
    assert reduced.shape == (2, 2)  # two waiting pairs of each class kept
    # The human may still pick a part up: only finished pairs are left out.
    finished_4 = {"attached(leg4,top,c2)", "attached(foot4,leg4,foot)"}
    left = frozenset({*FINISHED_3, *finished_4, "humanFree"})
    kept_all = relevance.reduce(left, 3, frozenset())
    assert kept_all is not None and kept_all.shape == (3, 3)
    assert kept_all.waiting == 0
    ban = frozenset({"hold(left,leg5)"})
    banned = relevance.reduce(frozenset({*spent, *finished_4}), 3, ban)
    assert banned is not None and banned.waiting == 0
    assert banned.forbidden(ban) <= {"hold(left,leg5)", "hold(left,leg7)", "hold(left,leg9)"}
    # Nothing finished and nothing waiting beyond the rung: the whole program.
    assert relevance.reduce(frozenset({"humanFree"}), 3, frozenset()) is None


def _plan_states(scenario: Scenario) -> list[State]:
    """The states a real plan of `scenario` has an action in."""
    planners: list[ConditionalPlanner] = []
    plan_scenario(scenario, workers=2, planner_hook=planners.append)
    return sorted(
        (state for state, node in planners[0].nodes.items() if node.action is not None),
        key=sorted,
    )


def _key(plan: SequentialPlan | None) -> object:
    if plan is None:
        return None
    steps = [(s.state, str(s.action), s.outcome, s.after, s.after_goal) for s in plan.steps]
    return steps, plan.start_goal, plan.steps_cost_only


def test_states_of_a_real_plan_get_the_whole_programs_plans_without_members() -> None:
    scenario = _declared("U", 12)
    facts, reachable = _facts(scenario)
    symmetry = Symmetry.of(facts, reachable)
    relevance = Relevance(symmetry.classes, facts, reachable)
    states = sorted({symmetry.canonical(s)[0] for s in _plan_states(scenario)}, key=sorted)
    random.Random(5).shuffle(states)
    context = FeasibilityContext(lambda m, p: (m, p) in reachable)
    for horizon in (3, 4):
        whole = BranchSolver(facts, horizon, context, history_free=True)
        programs: dict[tuple[int, ...], BranchSolver] = {}
        # States with waiting members left out, and with finished ones alone.
        picked: dict[bool, list[tuple[State, Reduction]]] = {True: [], False: []}
        for state in states:
            reduced = relevance.reduce(state, horizon, frozenset())
            if reduced is not None:
                picked[reduced.waiting > 0].append((state, reduced))
            if min(map(len, picked.values())) >= 30:
                break
        assert len(picked[True]) >= 20 and len(picked[False]) >= 20
        for state, reduced in picked[True][:30] + picked[False][:30]:
            if reduced.shape not in programs:
                shape_facts, shape_reach = relevance.facts_of(reduced.shape)
                programs[reduced.shape] = BranchSolver(
                    shape_facts,
                    horizon,
                    FeasibilityContext(lambda m, p, r=shape_reach: (m, p) in r),
                    history_free=True,
                    rules=RULES,
                    externals=EXTERNALS,
                )
            found = programs[reduced.shape].plan(reduced.state)
            mapped = None if found is None else reduced.actual_plan(found)
            assert _key(mapped) == _key(whole.plan(state)), sorted(state)
        assert len(programs) >= 2


def test_the_branch_planner_leaves_members_out_and_gets_the_same_branch() -> None:
    """The planning path itself: a history-free planner given the classes solves a
    branch whose human has no initiative left on a program without members, and the
    branch, outcomes included, is the one a planner without them finds."""
    from dataclasses import replace

    from planner.search.branch_planner import BranchPlanner, Problem

    scenario = _declared("U", 10)
    facts, reachable = _facts(scenario)
    plain = Problem(tuple(facts), reachable, horizon=4, history_free=True, short_first=True)
    members = Symmetry.of(facts, reachable).classes
    start = frozenset({*FINISHED_3, *SPENT, "holding(left,leg1)"})
    with_members = BranchPlanner(replace(plain, members=members))
    found = with_members.branch(start, frozenset())
    assert len(with_members._reduced) == 1  # one program without members, used
    whole = BranchPlanner(plain).branch(start, frozenset())
    assert found.steps is not None and found.steps == whole.steps
    assert found.horizon == whole.horizon
