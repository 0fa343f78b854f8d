"""A branch longer than the horizon: the horizons are asked out of order (twice the
horizon, then the longest, then those between), and the answer is still the plan of
the shortest horizon that has one, or a dead end at the longest."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import replace

from planner.search.branch_planner import MAX_HORIZON_FACTOR, BranchPlanner, as_solved
from planner.search.solver import SequentialPlan
from planner.vocabulary import State
from tests.plan_fixtures import family_states


def test_the_shortest_horizon_with_a_plan_answers_and_the_longest_proves_dead_ends() -> None:
    states, problem = family_states("U", 4, workers=1)
    # A horizon of one step: most milestones take two to four. History-free, so that
    # each answer is a function of its state, whichever solves came before.
    problem = as_solved(replace(problem, horizon=1, short_first=False), 2)
    horizons = [2**k for k in range(MAX_HORIZON_FACTOR.bit_length())]  # 1, 2, 4, 8
    searched, reference = BranchPlanner(problem), BranchPlanner(problem)
    asked: list[int] = []
    for h in horizons:
        solver = searched.solver(h)
        real_plan = solver.plan

        def plan(
            state: State,
            forbid: Iterable[str] = (),
            h: int = h,
            real: Callable[[State, Iterable[str]], SequentialPlan | None] = real_plan,
        ) -> SequentialPlan | None:
            asked.append(h)
            return real(state, forbid)

        solver.plan = plan  # type: ignore[method-assign]
    needed: set[int] = set()
    for state in states[:: max(1, len(states) // 60)]:
        asked.clear()
        found = searched.branch(state, frozenset())
        first = next((h for h in horizons if reference.solver(h).plan(state) is not None), None)
        assert first is not None  # the plan's states all have a way on
        assert found.horizon == first and found.steps is not None
        plan = reference.solver(first).plan(state)
        assert plan is not None
        assert [s.action for s in found.steps] == [s.action for s in plan.steps]
        needed.add(first)
        if first == 4:
            assert asked == [1, 2, 8, 4]  # the longest before the horizon between
    # Milestones of two and four steps were both met.
    assert {2, 4} <= needed
    # Every first action banned, one after the other: a dead end, proven by the longest
    # horizon alone after the horizon and twice it.
    banned: set[str] = set()
    while (plan := reference.solver(horizons[-1]).plan(states[0], banned)) is not None:
        banned.add(str(plan.steps[0].action))
    asked.clear()
    dead = searched.branch(states[0], frozenset(banned))
    assert (dead.steps, dead.horizon) == (None, horizons[-1])
    assert asked == [1, 2, 8] and banned
