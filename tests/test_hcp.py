"""The conditional-plan builder: progress, cancel, anytime first branch, ground once."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

import pytest

from planner.audit.branches import audit
from planner.plan import walks
from planner.planning import PlanningCancelled, plan_scenario
from planner.search import encoding, solver
from planner.search.branch_planner import Problem
from planner.search.errors import DeadEnd
from planner.search.hcp import ConditionalPlanner, DagNode, PlannerSettings, Progress
from planner.vocabulary import CONVERSATION, State, parse_action
from tests.domain_fixtures import scenario


def test_progress_reports_done_and_open_until_nothing_is_open() -> None:
    seen: list[Progress] = []
    result = plan_scenario(scenario(), workers=1, progress=seen.append)
    assert seen and seen[-1].open == 0
    # Every node the builder planned is in the plan; the talk around them is added after.
    talk = [n for n in result.plan.nodes.values() if n.action and n.action.name in CONVERSATION]
    assert talk
    assert seen[-1].done == result.plan.statistics["dag_nodes"] - len(talk)
    assert any(p.open > 0 for p in seen)
    assert [p.solves for p in seen] == sorted(p.solves for p in seen)


def test_first_branch_is_complete_before_the_rest() -> None:
    snapshots: list[tuple[int, list[str]]] = []
    planners: list[ConditionalPlanner] = []

    def on_first(nodes: dict[State, DagNode]) -> None:
        # Follow the hoped-for outcomes from the root: every step must be planned.
        planner = planners[0]
        state, path = planner.root, []
        while not nodes[state].goal:
            node = nodes[state]
            assert node.action is not None
            path.append(str(node.action))
            state = dict(node.children)[node.expected] if node.expected else node.children[0][1]
        snapshots.append((planner.solves, path))

    def hook(planner: ConditionalPlanner) -> None:
        planners.append(planner)
        planner.on_first_branch = on_first

    result = plan_scenario(scenario(), workers=1, planner_hook=hook)
    solves_then, path = snapshots[0]
    assert solves_then < result.solves
    planned = [a for a, _ in result.plan.first_branch()]
    assert planned[0] == "greet" and planned[-1] == "farewell"
    assert [a for a in planned if parse_action(a).name not in CONVERSATION] == path


def test_the_window_holds_the_first_branch_alone_until_it_reaches_a_goal() -> None:
    """Before the first branch is complete one state is solved at a time, the
    hoped-for branch's continuation; after it, up to a window of states."""
    from app.benchmark.planner_benchmark import instances, load
    from app.benchmark.scaling import Trace

    sc = load(instances(only=["paper-03"])[0], feasibility="declared")
    planners: list[ConditionalPlanner] = []
    first_at: list[int] = []

    def hook(planner: ConditionalPlanner) -> None:
        planners.append(planner)
        told = planner.on_first_branch

        def on_first(nodes: dict[State, DagNode]) -> None:
            first_at.append(len(planner.trace))
            if told is not None:
                told(nodes)

        planner.on_first_branch = on_first

    plan_scenario(sc, workers=1, window=4, planner_hook=hook)
    run = Trace(list(planners[0].trace), 0.0, 0.0)
    assert first_at[0] > 3
    assert all(run.pending(k) == 1 for k in range(first_at[0]))
    assert max(run.pending(k) for k in range(first_at[0], len(run.solves))) == 4


def test_find_back_edge_names_the_edge_that_closes_a_loop() -> None:
    loop = {"a": ["b", "c"], "b": ["d"], "c": ["d"], "d": ["b"]}
    assert walks.find_back_edge("a", loop.__getitem__) == ("d", "b")
    dag = {"a": ["b", "c"], "b": ["d"], "c": ["d"], "d": []}
    assert walks.find_back_edge("a", dag.__getitem__) is None


def test_chains_go_before_their_nodes_in_breadth_first_order() -> None:
    dag = {"a": ["b", "c"], "b": ["d"], "c": ["d"], "d": []}
    chains = {"a": 1, "c": 2, "d": 1}
    order = walks.with_chains("a", dag.__getitem__, lambda n: chains.get(n, 0))
    # (n, i < chains[n]) is the i-th before n; (n, chains[n]) is n; edges enter at (n, 0).
    assert order == [("a", 0), ("a", 1), ("b", 0), ("c", 0), ("d", 0), ("c", 1), ("d", 1), ("c", 2)]


def test_a_loop_is_planned_again_without_the_action_that_closes_it() -> None:
    """With initiative the human may pick up a dangerous spare part in their reach.
    The branches that dodge it lead back to states before them; each is planned
    again without the action that closed its loop, until the search names the
    state no plan leaves: the human holding the part (the loop itself was
    reported before)."""
    nail = (
        "[goal]",
        '[[parts]]\nid = "nail"\nkind = "other"\nclass = "nail"\nregion = "humanOnly"\n'
        "dangerous = true\n\n[goal]",
    )
    with pytest.raises(DeadEnd, match=r"humanHoldingPart\(nail\)") as err:
        plan_scenario(scenario(nail), workers=1)
    assert "loops back" not in str(err.value)


def test_cancel_stops_planning() -> None:
    planners: list[ConditionalPlanner] = []

    def cancel_at_once(p: Progress) -> None:
        planners[0].cancel()

    with pytest.raises(PlanningCancelled):
        plan_scenario(scenario(), workers=1, progress=cancel_at_once, planner_hook=planners.append)
    assert planners[0].solves <= 2


def test_parallel_workers_give_a_sound_plan() -> None:
    result = plan_scenario(scenario(), workers=2)
    assert audit(result.plan.to_json()) == []
    # States reached along several branches are planned once: a DAG, not a tree.
    assert result.plan.statistics["N"] > result.plan.statistics["dag_nodes"]


def test_a_plan_with_few_states_open_is_finished_without_worker_processes(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Past its CPU mark (`inline_s`) planning goes on to worker processes only with
    many states open: forking and grounding twice costs more than a few solves."""
    from planner.search import hcp

    planners: list[ConditionalPlanner] = []
    here = plan_scenario(scenario(), workers=2, inline_s=1e-3, planner_hook=planners.append)
    assert planners[-1].sent_away == 0
    monkeypatch.setattr(hcp, "SWITCH_MIN_OPEN", 0)
    away = plan_scenario(scenario(), workers=2, inline_s=1e-3, planner_hook=planners.append)
    assert planners[-1].sent_away > 0
    docs = [here.plan.to_json(), away.plan.to_json()]
    for doc in docs:
        doc["stats"] = {k: v for k, v in doc["stats"].items() if not k.endswith("_s")}
    assert docs[0] == docs[1]


def test_grounds_once_per_horizon_and_solves_many_times(monkeypatch: pytest.MonkeyPatch) -> None:
    calls: list[int] = []
    real = encoding.ground

    def counting(*args, **kwargs):  # type: ignore[no-untyped-def]
        calls.append(args[1])
        return real(*args, **kwargs)

    monkeypatch.setattr(solver, "ground", counting)
    result = plan_scenario(scenario(), workers=1)
    assert result.solves > 20
    # One planning program per horizon used, and one one-step program.
    planning = [h for h in calls if h != 1]
    assert len(planning) == len(set(planning)) and calls.count(1) == 1
    assert len(calls) <= 6


def test_a_dead_outcome_bans_the_parent_action_and_plans_the_parent_again() -> None:
    from planner.planning import DEFAULT_HORIZON, initial_state
    from planner.search.branch_planner import BranchPlanner
    from planner.search.errors import DeadEnd

    sc = scenario()
    reach = frozenset(sc.reachable_pairs())
    facts = tuple(f for f in sc.facts(reach) if not f.startswith("reachable("))
    problem = Problem(facts, reach, DEFAULT_HORIZON)
    planner = ConditionalPlanner(problem, sc.goal_pairs(), PlannerSettings(workers=1))
    worker = BranchPlanner(problem)
    root = initial_state(sc)
    planner.root = root
    planner._node(root)
    first = worker.branch(root, frozenset())
    planner._integrate(first, root)
    first_action = planner.nodes[root].action
    assert first_action is not None
    # Suppose the state after the root's action turned out to be a dead end.
    after = planner.nodes[root].children[0][1]
    todo = planner._dead_end(after, root, DEFAULT_HORIZON)
    assert todo == [root]
    assert planner.nodes[root].action is None
    assert planner.nodes[root].forbidden == {str(first_action)}
    again = worker.branch(root, frozenset(planner.nodes[root].forbidden))
    assert again.steps is not None and again.steps[0].action != first_action
    # A dead end at the start state itself is reported, naming the dead branch.
    with pytest.raises(DeadEnd, match="first dead branch: hold"):
        planner._dead_end(root, root, DEFAULT_HORIZON)


def test_one_worker_always_gives_the_same_plan() -> None:
    def doc() -> dict[str, object]:
        d = plan_scenario(scenario(), workers=1).plan.to_json()
        d["stats"] = {k: v for k, v in d["stats"].items() if not k.endswith("_s")}
        return d

    assert doc() == doc()


def test_looking_one_step_short_first_finds_the_horizons_own_plan(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """`Problem.short_first` changes how fast a branch is planned, not its plan: a plan
    one step short that costs nothing beyond its steps is the horizon's optimum, and
    one that costs more is looked for again with the whole horizon."""
    from dataclasses import replace

    from app.benchmark.planner_benchmark import instances, load
    from planner.planning import DEFAULT_HORIZON

    sc = load(instances(only=["paper-03"])[0], feasibility="declared")
    answers: list[tuple[int, int, bool]] = []
    real = solver.BranchSolver.plan

    def plan(self: solver.BranchSolver, state: State, forbid: Iterable[str] = ()) -> Any:
        found = real(self, state, forbid)
        if found is not None:
            answers.append((self.horizon, len(found.steps), found.steps_cost_only))
        return found

    monkeypatch.setattr(solver.BranchSolver, "plan", plan)

    def doc(short_first: bool) -> dict[str, Any]:
        def hook(planner: ConditionalPlanner) -> None:
            # As several workers solve: each answer from its state alone.
            planner.problem = replace(planner.problem, history_free=True, short_first=short_first)

        out = plan_scenario(sc, workers=1, planner_hook=hook).plan.to_json()
        out["stats"] = {k: v for k, v in out["stats"].items() if not k.endswith("_s")}
        return out

    whole = doc(short_first=False)
    assert {h for h, _, _ in answers} == {DEFAULT_HORIZON}
    answers.clear()
    assert doc(short_first=True) == whole
    short = [a for a in answers if a[0] == DEFAULT_HORIZON - 1]
    again = [a for a in answers if a[0] == DEFAULT_HORIZON]
    # Both ways were taken: short plans kept, and costlier ones looked for again...
    assert any(cheap for _, _, cheap in short) and any(not cheap for _, _, cheap in short)
    # ...where a plan using the whole horizon was sometimes the better one.
    assert any(steps == DEFAULT_HORIZON for _, steps, _ in again)


def test_a_program_preprocessed_by_clasp_gives_the_same_plan(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Large benches solve with clasp's preprocessed program (planner.search.preprocessing):
    faster solves of the same program, so the same plan."""
    from dataclasses import replace

    from app.benchmark.planner_benchmark import instances, load
    from planner.planning import DEFAULT_HORIZON, preprocessed_programs
    from planner.search import preprocessing

    sc = load(instances(only=["paper-03"])[0], feasibility="declared")
    loaded: list[int] = []
    real = preprocessing.load_preprocessed

    def load_preprocessed(program: str, options: Sequence[str] = ()) -> Any:
        loaded.append(len(program))
        return real(program, options)

    monkeypatch.setattr(solver, "load_preprocessed", load_preprocessed)

    def doc(preprocessed: bool) -> dict[str, Any]:
        def hook(planner: ConditionalPlanner) -> None:
            problem = replace(planner.problem, history_free=True, short_first=True)
            if preprocessed:
                problem = replace(problem, programs=preprocessed_programs(problem))
            planner.problem = problem

        out = plan_scenario(sc, workers=1, planner_hook=hook).plan.to_json()
        out["stats"] = {k: v for k, v in out["stats"].items() if not k.endswith("_s")}
        return out

    ground = doc(preprocessed=False)
    assert not loaded
    assert doc(preprocessed=True) == ground
    # Both horizons' programs were made and loaded: a step short, and the horizon.
    assert len(loaded) == 2 and all(loaded)
    programs = preprocessed_programs(
        replace(Problem(("part(top)",), frozenset(), DEFAULT_HORIZON), short_first=True)
    )
    assert [h for h, _ in programs] == [DEFAULT_HORIZON - 1, DEFAULT_HORIZON]
    assert all(text.startswith("asp 1 0 0") for _, text in programs)
    # A program clingo cannot read is told in clingo's words, one line.
    with pytest.raises(encoding.EncodingError) as err:
        preprocessed_programs(Problem(("part(top",), frozenset(), DEFAULT_HORIZON))
    assert str(err.value).startswith("clasp's preprocessing failed: <block>:1:")
    assert "syntax error" in str(err.value) and "\n" not in str(err.value)


def test_the_step_priority_counts_steps_alone() -> None:
    """`solver.STEP_PRIORITY` is the priority of one weak constraint: one per step
    with an action. The shorter-first search relies on it (a longer plan costs more
    there, and can win only above it)."""
    import re

    from planner.search.encoding import encoding_files

    weak = [
        (m.group(1).strip(), m.group(2), int(m.group(3)))
        for f in encoding_files()
        for m in re.finditer(r":~ (.*?)\. \[(\w+)@(\d+)", f.read_text())
    ]
    at_steps = [(body, weight) for body, weight, p in weak if p == solver.STEP_PRIORITY]
    assert at_steps == [("occurs(T)", "1")]
    assert {p for _, _, p in weak} >= {solver.STEP_PRIORITY + 1}


def test_solvers_ground_ahead_serve_only_their_own_problem() -> None:
    """`ground_ahead` solvers made for the hoped-for answers are used when those are
    the answers, and ignored otherwise: the plan is the same either way."""
    from dataclasses import replace

    from planner.planning import DEFAULT_HORIZON, initial_state
    from planner.search.branch_planner import ground_ahead

    sc = scenario()
    reach = frozenset(sc.reachable_pairs())
    facts = tuple(f for f in sc.facts(reach) if not f.startswith("reachable("))
    problem = Problem(facts, reach, DEFAULT_HORIZON)
    other = replace(problem, reachable=reach - {min(reach)})
    plans = []
    for ahead in (None, ground_ahead(problem), ground_ahead(other)):
        settings = PlannerSettings(workers=1, ahead=ahead)
        planner = ConditionalPlanner(problem, sc.goal_pairs(), settings)
        planner.build(initial_state(sc))
        # Solved on the solvers ground ahead if, and only if, they are this problem's.
        assert planner.grounded_ahead == (ahead is not None and ahead.result().problem == problem)
        plans.append({s: (str(n.action), sorted(n.children)) for s, n in planner.nodes.items()})
    assert plans[0] == plans[1] == plans[2]
