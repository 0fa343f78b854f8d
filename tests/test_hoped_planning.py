"""Planning on the hoped reach answers while the checks decide them."""

from __future__ import annotations

import threading
from pathlib import Path

from planner.planning import DEFAULT_HORIZON, initial_state, plan_scenario
from planner.scenario.loading import load_scenario
from planner.search.branch_planner import Problem
from planner.search.hcp import ConditionalPlanner, DagNode, PlannerSettings, Progress
from planner.search.hoped_planning import HopedPlanning
from planner.vocabulary import State
from tests.domain_fixtures import scenario

PAPER_DIR = Path("static/scenarios/paper")


def _problem() -> tuple[Problem, list[tuple[str, str]]]:
    sc = scenario()
    reach = frozenset(sc.reachable_pairs())
    facts = tuple(f for f in sc.facts(reach) if not f.startswith("reachable("))
    return Problem(facts, reach, DEFAULT_HORIZON), list(sc.goal_pairs())


def _dag(planner: ConditionalPlanner) -> dict[State, tuple[str, list[tuple[str | None, State]]]]:
    return {s: (str(n.action), sorted(n.children, key=str)) for s, n in planner.nodes.items()}


def test_what_planning_tells_waits_for_the_answers() -> None:
    problem, goals = _problem()
    told: list[tuple[str, int]] = []
    planner = ConditionalPlanner(
        problem,
        goals,
        PlannerSettings(workers=1),
        on_planned=lambda nodes: told.append(("planned", len(nodes))),
        on_first_branch=lambda nodes: told.append(("first", len(nodes))),
    )
    hoped = HopedPlanning(planner, initial_state(scenario()))
    hoped.result()  # planned to the end on the hoped answers alone
    assert planner.solves > 0 and not told
    hoped.confirm()
    # Everything held back is told at once: the first branch, then every planned node.
    assert [kind for kind, _ in told] == ["first", "planned"]
    assert told[1][1] == sum(1 for n in planner.nodes.values() if n.action is not None)
    alone = ConditionalPlanner(problem, goals, PlannerSettings(workers=1))
    alone.build(initial_state(scenario()))
    assert _dag(planner) == _dag(alone)  # the plan is the one made after the answers


def test_planning_on_answers_that_were_not_the_decided_ones_is_abandoned() -> None:
    problem, goals = _problem()
    planner = ConditionalPlanner(problem, goals, PlannerSettings(workers=1))
    planning, release = threading.Event(), threading.Event()

    def held(_: Progress) -> None:  # holds the planning thread in the middle of planning
        planning.set()
        release.wait(timeout=60)

    planner.progress = held
    hoped = HopedPlanning(planner, initial_state(scenario()))
    assert planning.wait(timeout=60)
    threading.Timer(0.2, release.set).start()
    hoped.abandon()  # stops it, and waits until it has stopped
    assert planner.cancelled and not hoped.planning
    assert any(n.action is None and not n.goal for n in planner.nodes.values())
    hoped.abandon()  # once stopped, nothing to do


def test_a_cold_plan_is_planned_once_on_the_hoped_answers(tmp_path: Path) -> None:
    """paper-13's hoped answers are the decided ones: one planner plans, in the
    thread started on the hoped answers (no second one after the answers)."""
    planners: list[ConditionalPlanner] = []
    firsts: list[dict[State, DagNode]] = []
    planned_in: list[set[threading.Thread]] = []  # the threads each planner planned in

    def hook(planner: ConditionalPlanner) -> None:
        planners.append(planner)
        planned_in.append(set())
        planner.progress = lambda _: planned_in[-1].add(threading.current_thread())
        told = planner.on_first_branch

        def on_first(nodes: dict[State, DagNode]) -> None:
            firsts.append(nodes)
            if told is not None:
                told(nodes)

        planner.on_first_branch = on_first

    sc = load_scenario(PAPER_DIR / "paper-13.toml")
    cold = plan_scenario(sc, workers=2, cache_dir=tmp_path, planner_hook=hook)
    assert len(planners) == 1 and len(firsts) == 1
    assert planners[0].grounded_ahead  # on the program ground for the hoped answers
    # In one thread, not the caller's: planning began before the answers were decided.
    assert len(planned_in[0]) == 1 and threading.current_thread() not in planned_in[0]
    warm = plan_scenario(sc, workers=2, cache_dir=tmp_path, planner_hook=hook)
    assert planners[1].settings.ahead is None  # every answer cached: nothing hoped
    assert not planners[1].grounded_ahead
    assert planned_in[1] == {threading.current_thread()}  # planned after the answers
    assert cold.plan.to_json()["nodes"] == warm.plan.to_json()["nodes"]


def test_cancelling_the_planning_on_the_hoped_answers_cancels_the_plan() -> None:
    import pytest

    from planner.planning import PlanningCancelled

    sc = load_scenario(PAPER_DIR / "paper-13.toml")
    planners: list[ConditionalPlanner] = []

    def cancel(planner: ConditionalPlanner) -> None:  # as the dashboard's stop button does
        planners.append(planner)
        planner.cancel()

    with pytest.raises(PlanningCancelled):
        plan_scenario(sc, workers=2, cache_dir=":memory:", planner_hook=cancel)
    assert len(planners) == 1 and planners[0].solves == 0
