"""IK of many reach checks at once gives each check the answers it finds alone."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pytest

from app.benchmark import planner_benchmark as bench
from planner.feasibility import World
from planner.feasibility.check_pool import question
from planner.feasibility.checks import BenchChecks
from planner.feasibility.grasp_ik import GraspIk, Question
from planner.feasibility.reach import robot_only
from planner.feasibility.scene import part_boxes
from planner.scenario.model import Scenario


@pytest.fixture(scope="module")
def scenario() -> Scenario:
    # 13 parts, half of them out of one arm's reach: "no IK", "ok" and paths found by RRT.
    return bench.load(bench.instances(only=["paper-05"])[0])


@pytest.fixture(scope="module")
def world(scenario: Scenario) -> Iterator[World]:
    with World(scenario) as w:
        yield w


def _questions(scenario: Scenario) -> list[Question]:
    checks = BenchChecks(scenario)
    return [question(pair) for pair in checks.pairs()]


def test_a_pass_over_many_searches_answers_each_as_alone(world: World) -> None:
    chain = world.ik.chains["left"]
    rng = np.random.default_rng(3)
    poses = [
        pose for box in world.scene.parts.values() for pose in world.ik.grasp_poses(box, "left")
    ]
    seeds = [list(map(float, rng.uniform(chain.lower, chain.upper))) for _ in poses]
    together = list(chain.search(poses, seeds))
    alone = [next(chain.search([p], [s])) for p, s in zip(poses, seeds, strict=True)]
    assert together == alone  # to the last bit
    assert any(a.solved for a in alone) and not all(a.solved for a in alone)


def test_first_batches_decide_as_the_check_does(scenario: Scenario, world: World) -> None:
    questions = _questions(scenario)
    # Another robot, as in the planning process, which has no scene.
    ik = GraspIk(robot_only(scenario.robot.base_pose), part_boxes(scenario))
    first = dict(ik.first_batches(questions))
    assert sorted(first, key=questions.index) == questions
    reasons = set()
    for q in questions:
        alone = world.decide_reach(q.arm, q.part, q.point)
        reasons.add(alone.reason)
        given = first[q]
        if given is None:
            assert alone.reason == "no IK", q
            continue
        helped = world.decide_reach(q.arm, q.part, q.point, ik=given)
        assert (helped.reachable, helped.reason, helped.simplify_seed) == (
            alone.reachable,
            alone.reason,
            alone.simplify_seed,
        ), q
        if alone.found is not None:
            assert helped.found is not None
            path = world.finish_reach(helped).path
            assert path == world.finish_reach(alone).path, q
            # Where the arm stands is known from the decision (BenchChecks.at).
            assert path is not None and path[-1] == helped.goal, q
    assert {"ok", "no IK"} <= reasons
    assert sum(v is None for v in first.values()) >= 10  # decided without a collision check
