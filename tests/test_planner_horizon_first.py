"""Looking for the horizon's plan first (along a large bench's first branch) gives the
branch the step-short search gives, state for state: the horizon's program holds
every plan a step short, so the order of the two solves cannot change the answer."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import replace

from planner import planning
from planner.search.branch_planner import BranchPlanner, as_solved
from planner.search.solver import SequentialPlan
from planner.vocabulary import State
from tests.plan_fixtures import family_states


def test_the_horizon_first_gives_the_step_short_searchs_branches() -> None:
    states, problem = family_states("U", 10, workers=2)
    assert problem.short_first  # a large bench, where branches look a step short first
    problem = as_solved(replace(problem, programs=planning.preprocessed_programs(problem)), 2)
    step_short, horizon_first = BranchPlanner(problem), BranchPlanner(problem)
    short = horizon_first.solver(problem.horizon - 1)
    looked_short: list[State] = []
    real_plan = short.plan

    def plan(state: State, forbid: Iterable[str] = ()) -> SequentialPlan | None:
        looked_short.append(state)
        return real_plan(state, forbid)

    short.plan = plan  # type: ignore[method-assign]
    sample = states[:: max(1, len(states) // 150)]
    whole: set[State] = set()
    for state in sample:
        expected = step_short.branch(state, frozenset())
        found = horizon_first.branch(state, frozenset(), horizon_first=True)
        assert (found.steps, found.horizon, found.start_goal) == (
            expected.steps,
            expected.horizon,
            expected.start_goal,
        )
        assert expected.steps is not None
        if len(expected.steps) == problem.horizon:
            whole.add(state)
    # Both kinds were met: branches of the whole horizon, where the plan a step short
    # was not looked for, and branches a step short, where it was (where it could
    # cost its steps alone).
    assert whole and len(whole) < len(sample)
    assert looked_short and not whole & set(looked_short)
