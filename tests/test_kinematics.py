"""The numpy model of Baxter's arms against pybullet's own kinematics."""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from planner.feasibility import World
from planner.feasibility._bullet import pb
from planner.feasibility.arms import ARMS, HOME
from planner.feasibility.kinematics import ArmChain
from planner.scenario.loading import load_scenario

DEFAULT = Path(__file__).resolve().parent.parent / "static" / "scenarios" / "default.toml"


@pytest.fixture(scope="module")
def world() -> Iterator[World]:
    with World(load_scenario(DEFAULT)) as w:
        yield w


def _pybullet_pose(world: World, arm: str, q: list[float]) -> tuple[np.ndarray, list[float]]:
    world.robot.set_arm(arm, q)
    state = pb.getLinkState(
        world.robot.body,
        world.robot.end_effector[arm],
        computeForwardKinematics=True,
        physicsClientId=world.client,
    )
    world.robot.go_home()
    return np.array(state[4]), list(state[5])


def _random_configurations(chain: ArmChain, count: int, seed: int) -> list[list[float]]:
    rng = np.random.default_rng(seed)
    return [list(map(float, rng.uniform(chain.lower, chain.upper))) for _ in range(count)]


@pytest.mark.parametrize("arm", ARMS)
def test_forward_kinematics_is_pybullets(world: World, arm: str) -> None:
    chain = world.ik.chains[arm]
    for q in [HOME[arm], *_random_configurations(chain, 25, seed=1)]:
        position, rotation = chain.pose(q)
        expected_p, expected_q = _pybullet_pose(world, arm, q)
        expected_r = np.array(pb.getMatrixFromQuaternion(expected_q)).reshape(3, 3)
        assert np.abs(position - expected_p).max() < 1e-5
        assert np.abs(rotation - expected_r).max() < 1e-5


@pytest.mark.parametrize("arm", ARMS)
def test_ik_meets_poses_the_arm_can_take(world: World, arm: str) -> None:
    """Poses of random configurations are reachable by construction: from home and
    a few random seeds, some search must meet each, and pybullet must agree."""
    chain = world.ik.chains[arm]
    targets = _random_configurations(chain, 12, seed=2)
    seeds = [HOME[arm], *_random_configurations(chain, 5, seed=3)]
    met = 0
    for target in targets:
        pos, orn = _pybullet_pose(world, arm, target)
        asked = [(pos.tolist(), orn)] * len(seeds)
        for answer in chain.search(asked, seeds):
            if answer.solved:
                assert chain.lower.min() - 1e-9 <= min(answer.q)
                assert world.ik.meets(arm, answer.q, pos.tolist(), orn)
                met += 1
                break
    assert met >= 11  # a pose at a joint limit may defeat every seed; not more than one


def test_answers_come_in_order_and_a_caller_may_stop_early(world: World) -> None:
    chain = world.ik.chains["left"]
    reachable, orn = _pybullet_pose(world, "left", HOME["left"])
    far = (reachable + np.array([2.0, 0.0, 0.0])).tolist()
    asked = [(reachable.tolist(), orn), (far, orn), (reachable.tolist(), orn)]
    seeds = [HOME["left"]] * 3
    answers = list(chain.search(asked, seeds))
    assert [a.solved for a in answers] == [True, False, True]
    assert answers[1].pos_err > 1.0  # two metres out: it ends far away
    assert answers[0].pos_err < 1e-6 and answers[0].q == pytest.approx(HOME["left"])
    first = next(chain.search(asked, seeds))
    assert first == answers[0]


def test_a_half_turn_of_the_hand_is_corrected(world: World) -> None:
    """The orientation error's logarithm near pi (the other top-down yaw) still
    points somewhere: the search turns the wrist round rather than stalling."""
    chain = world.ik.chains["right"]
    pos, orn = _pybullet_pose(world, "right", HOME["right"])
    yaw_flip = pb.getQuaternionFromEuler([0.0, 0.0, math.pi])
    turned = list(pb.multiplyTransforms([0, 0, 0], orn, [0, 0, 0], yaw_flip)[1])
    seeds = [HOME["right"], *_random_configurations(chain, 5, seed=4)]
    answers = list(chain.search([(pos.tolist(), turned)] * len(seeds), seeds))
    assert any(a.solved for a in answers)
