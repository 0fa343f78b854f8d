"""Checks answered by several processes, and the declared tables of the paper's layout."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from planner.feasibility import BenchChecks, CheckCache
from planner.feasibility.check_pool import NICENESS, CheckPool, Pair, question
from planner.feasibility.plan_motions import add_motions
from planner.feasibility.reach import ReachResult
from planner.planning import plan_scenario
from planner.scenario import paper
from planner.scenario.loading import load_scenario, parse_scenario
from planner.search.hcp import ConditionalPlanner, DagNode

PAPER_DIR = Path("static/scenarios/paper")


@pytest.mark.parametrize("name", ["paper-05", "paper-15"])
def test_two_check_processes_answer_as_one(name: str) -> None:
    scenario = load_scenario(PAPER_DIR / f"{name}.toml")
    with BenchChecks(scenario) as one, BenchChecks(scenario, workers=2) as two:
        alone = one.table()
        pooled = two.table()
        assert two.pool is not None and one.pool is None
    assert list(pooled) == list(alone)  # file order, whatever finished first
    for pair, result in alone.items():
        got = pooled[pair]
        assert (got.reachable, got.reason) == (result.reachable, result.reason)
        assert got.path == result.path


def test_motions_from_the_pool_are_those_of_one_process(tmp_path: Path) -> None:
    scenario = load_scenario(PAPER_DIR / "paper-03.toml")
    plan = plan_scenario(scenario, workers=1, cache_dir=tmp_path / "first").plan
    with CheckCache(":memory:") as c1, BenchChecks(scenario, cache=c1) as one:
        alone = plan.model_copy(deep=True)
        n_alone = add_motions(alone, one)
    with CheckCache(":memory:") as c2, BenchChecks(scenario, cache=c2, workers=2) as two:
        pooled = plan.model_copy(deep=True)
        n_pooled = add_motions(pooled, two)
    assert n_alone == n_pooled > 5
    assert pooled.to_json()["nodes"] == alone.to_json()["nodes"]


def test_plans_are_the_same_with_cold_and_warm_caches_when_checks_run_in_parallel(
    tmp_path: Path,
) -> None:
    scenario = load_scenario(PAPER_DIR / "paper-05.toml")
    # Two check processes, one planning worker (one worker's plan is reproducible).
    cold = plan_scenario(scenario, workers=1, check_workers=2, cache_dir=tmp_path).plan
    with CheckCache(tmp_path) as cache, BenchChecks(scenario, cache=cache) as checks:
        checks.table()
        assert cache.misses == 0 and cache.hits > 0
    warm = plan_scenario(scenario, workers=1, check_workers=2, cache_dir=tmp_path).plan
    cold_doc, warm_doc = cold.to_json(), warm.to_json()
    assert any(n.get("motion") for n in cold_doc["nodes"].values())
    for doc in (cold_doc, warm_doc):
        doc["stats"] = {k: v for k, v in doc["stats"].items() if not k.endswith("_s")}
    assert cold_doc == warm_doc


@pytest.mark.parametrize(("family", "n"), [("U", 2), ("P", 2), ("R", 3)])
def test_the_declared_table_is_what_geometry_finds(family: str, n: int) -> None:
    geometric = parse_scenario(paper.scenario_toml(family, n), "geometry")
    declared = parse_scenario(paper.scenario_toml(family, n, "declared"), "declared")
    assert declared.feasibility.source == "declared"
    with BenchChecks(geometric, workers=2) as checks:
        found = {pair for pair, r in checks.table().items() if r.reachable}
    assert declared.reachable_pairs() == found


def test_families_continue_to_any_size() -> None:
    assert paper.all_instances(to=18)[-1] == ("R", 18)
    u18 = parse_scenario(paper.scenario_toml("U", 18, "declared"), "U18")
    assert sum(p.dangerous for p in u18.parts) == 18
    with pytest.raises(ValueError, match="feasibility"):
        paper.scenario_toml("U", 3, "maybe")


def test_motions_started_while_planning_are_those_of_one_process(tmp_path: Path) -> None:
    # With a pool, answers come before their paths are simplified and attach motions
    # start in the pool while planning goes on: the plan must not notice.
    scenario = load_scenario(PAPER_DIR / "paper-03.toml")
    started: list[int] = []

    def count(planner: ConditionalPlanner) -> None:
        seen = planner.on_planned
        assert seen is not None  # geometric feasibility: motions are prefetched

        def spy(planned: list[DagNode]) -> None:
            seen(planned)
            started.append(len(planned))

        planner.on_planned = spy

    alone = plan_scenario(scenario, workers=1, cache_dir=tmp_path / "one").plan
    pooled = plan_scenario(
        scenario, workers=1, check_workers=2, cache_dir=tmp_path / "two", planner_hook=count
    ).plan
    assert started
    docs = [alone.to_json(), pooled.to_json()]
    for doc in docs:
        doc["stats"] = {k: v for k, v in doc["stats"].items() if not k.endswith("_s")}
    assert docs[0] == docs[1]


def test_the_pool_leaves_fixed_parts_paths_until_asked(tmp_path: Path) -> None:
    """No motion goes to the top's work point: the pool stores its answer without a
    path, and a path asked for later is the one a single process makes."""
    scenario = load_scenario(PAPER_DIR / "paper-15.toml")
    plan_scenario(scenario, workers=1, check_workers=2, cache_dir=tmp_path)
    with CheckCache(tmp_path) as cache, BenchChecks(scenario, cache=cache) as stored:
        answers = stored.answers()
        assert cache.misses == 0
        kept = {pair: cache.get(f"{stored.key}/reach/{pair[0]}/{pair[1]}") for pair in answers}
    top = {arm: kept[(arm, "top")] for arm in ("left", "right")}
    assert all(r is not None and r["reachable"] and r["path"] is None for r in top.values())
    legs = [r for pair, r in kept.items() if pair[1] != "top" and r and r["reachable"]]
    assert legs and all(r["path"] for r in legs)
    with CheckCache(":memory:") as fresh, BenchChecks(scenario, cache=fresh) as one:
        expected = {arm: one.reach(arm, "top").path for arm in top}
    with CheckCache(tmp_path) as cache, BenchChecks(scenario, cache=cache) as again:
        for arm in top:
            made = again.reach(arm, "top")
            assert made.path is not None and made.path == expected[arm]
    with CheckCache(tmp_path) as cache, BenchChecks(scenario, cache=cache) as later:
        assert later.reach("left", "top").path == expected["left"]  # cached once made
        assert cache.misses == 0


def test_a_cold_plan_solves_with_the_program_ground_while_the_checks_decide(
    tmp_path: Path,
) -> None:
    planners: list[ConditionalPlanner] = []
    scenario = load_scenario(PAPER_DIR / "paper-13.toml")
    for _ in range(2):  # cold, then warm
        plan_scenario(scenario, workers=2, cache_dir=tmp_path, planner_hook=planners.append)
    # Every pair the pool was asked about was reachable: the hoped-for program served.
    # (The plan is that of a warm cache: the test above.)
    assert planners[0].grounded_ahead
    assert planners[1].settings.ahead is None  # every answer cached: nothing to wait for


def test_a_motion_asked_before_the_paths_goes_before_them() -> None:
    """Plan motions wait for moves; the paths of reach answers are needed last. A move
    asked before the paths may be made is answered at once (the processes are not
    held for them), and every path is made later, by the process that decided its
    pair."""
    scenario = load_scenario(PAPER_DIR / "paper-05.toml")
    pool = CheckPool(scenario, {"planner": "RRTConnect", "time_limit": 1.0, "seed": 0}, 2)
    try:
        movable = [p.id for p in scenario.parts if p.movable]
        pairs = [(arm, part) for arm in ("left", "right") for part in movable]
        by_question = {question(pair): pair for pair in pairs}
        given = [(by_question[q], ik) for q, ik in pool.first_batches(by_question) if ik]
        batches = pool.decide(given)
        goals = {pair: goal for pair, ok, _, goal in pool.decisions(len(given), batches) if ok}
        left = [part for arm, part in goals if arm == "left"]
        assert len(left) >= 2
        a, b = left[:2]
        start, goal = goals[("left", a)], goals[("left", b)]
        assert start is not None and goal is not None
        path = pool.move("left", start, goal, frozenset({a, b})).result(timeout=60)
        assert path is not None and path[0] == start and path[-1] == goal
        assert not any(batch.done() for batch in batches)  # no path made yet
        pool.release_paths()
        made: dict[Pair, ReachResult] = {}
        for batch in batches:
            made.update(batch.result(timeout=120))
        assert set(made) == {pair for pair, _ in given}
        assert all(made[pair].path for pair in goals)
    finally:
        pool.close()


def test_check_processes_leave_the_cores_to_the_planning_process_first() -> None:
    scenario = load_scenario(PAPER_DIR / "paper-05.toml")
    pool = CheckPool(scenario, {"planner": "RRTConnect", "time_limit": 1.0, "seed": 0}, 2)
    try:
        mine = os.getpriority(os.PRIO_PROCESS, 0)
        for index in range(2):
            theirs = pool._submit(index, os.getpriority, os.PRIO_PROCESS, 0).result(timeout=60)
            assert theirs == min(mine + NICENESS, 19) > mine
    finally:
        pool.close()


def test_the_check_processes_solve_the_ik_as_this_process_does() -> None:
    from planner.feasibility.grasp_ik import GraspIk
    from planner.feasibility.reach import robot_only
    from planner.feasibility.scene import part_boxes

    scenario = load_scenario(PAPER_DIR / "paper-05.toml")
    pairs = [(arm, p.id) for arm in ("left", "right") for p in scenario.parts]
    questions = [question(pair) for pair in pairs]
    here = GraspIk(robot_only(scenario.robot.base_pose), part_boxes(scenario), 0)
    expected = dict(here.first_batches(questions))
    pool = CheckPool(scenario, {"planner": "RRTConnect", "time_limit": 1.0, "seed": 0}, 2)
    try:
        got = dict(pool.first_batches(questions))
    finally:
        pool.close()
    assert got == expected  # every answer, to the last bit
    assert sum(a is None for a in got.values()) > 0 and sum(a is not None for a in got.values()) > 0


def test_an_ik_pass_that_fails_leaves_no_process_waiting_for_pairs() -> None:
    from planner.feasibility.grasp_ik import Question

    scenario = load_scenario(PAPER_DIR / "paper-05.toml")
    pool = CheckPool(scenario, {"planner": "RRTConnect", "time_limit": 1.0, "seed": 0}, 2)
    try:
        solved = pool.first_batches([Question("left", "no-such-part")])
        with pytest.raises(KeyError):
            pool.decide((("left", q.part), answers) for q, answers in solved)
        # Each process's deciding job got its end mark and ended, having decided nothing.
        for batches in pool._batches:
            assert [batch.decided.result(timeout=60) for batch in batches] == [[]]
    finally:
        pool.close()
