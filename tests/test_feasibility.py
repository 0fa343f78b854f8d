"""Geometric feasibility with the real Baxter (example-robot-data), pybullet and OMPL."""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path

import pytest

from app.cli.main import main
from planner.feasibility import ReachResult, World, reachability_table, reachable_pairs
from planner.feasibility.path_planner import plan_path
from planner.feasibility.robot import HOME
from planner.feasibility.scene import part_boxes, region_extents
from planner.scenario.loading import load_scenario, parse_scenario
from planner.scenario.model import Scenario

DEFAULT = Path(__file__).resolve().parent.parent / "static" / "scenarios" / "default.toml"
FINE_STEP = 0.005  # radians: 10x finer than the returned path's spacing


@pytest.fixture(scope="module")
def scenario() -> Scenario:
    return load_scenario(DEFAULT)


@pytest.fixture(scope="module")
def table(scenario: Scenario) -> dict[tuple[str, str], ReachResult]:
    return reachability_table(scenario)


@pytest.fixture(scope="module")
def world(scenario: Scenario) -> Iterator[World]:
    with World(scenario) as w:
        yield w


def test_table_covers_every_arm_and_part(
    scenario: Scenario, table: dict[tuple[str, str], ReachResult]
) -> None:
    expected = {(m, p.id) for m in scenario.robot.manipulators for p in scenario.parts}
    assert set(table) == expected
    for result in table.values():
        assert (result.path is not None) == result.reachable == (result.reason == "ok")
        assert result.seconds >= 0


def test_robot_only_part_is_reachable(
    scenario: Scenario, table: dict[tuple[str, str], ReachResult]
) -> None:
    assert scenario.part("leg1").region == "robotOnly"
    assert any(table[(arm, "leg1")].reachable for arm in ("left", "right"))


def test_human_only_part_is_out_of_reach(
    scenario: Scenario, table: dict[tuple[str, str], ReachResult]
) -> None:
    # 1.2 m out is beyond the stretched arm, so IK is not even tried.
    assert scenario.part("leg2").region == "humanOnly"
    for arm in ("left", "right"):
        assert table[(arm, "leg2")].reason == "no IK"
        assert not table[(arm, "leg2")].reachable


def test_paths_are_collision_free_at_fine_resolution(
    world: World, table: dict[tuple[str, str], ReachResult]
) -> None:
    checked = 0
    for (arm, part), result in table.items():
        if result.path is None:
            continue
        path = result.path
        assert path[0] == pytest.approx(HOME[arm])
        for q in path:
            assert world.robot.within_limits(arm, q)
        for a, b in zip(path, path[1:], strict=False):
            jump = max(abs(x - y) for x, y in zip(a, b, strict=True))
            steps = max(1, math.ceil(jump / FINE_STEP))
            for k in range(steps + 1):
                q = [x + (y - x) * k / steps for x, y in zip(a, b, strict=True)]
                assert world.is_valid(arm, q, part), (arm, part, q)
        checked += 1
        # The last configuration really puts the gripper over the part, pointing down.
        world.robot.set_arm(arm, path[-1])
        pos, orn = world.ik.grasp_poses(world.scene.parts[part], arm)[0]
        assert world.ik.pose_error(arm, pos, orn)[0] < 0.01
        world.robot.go_home()
    assert checked >= 2


def test_reasons_are_deterministic(
    scenario: Scenario, table: dict[tuple[str, str], ReachResult]
) -> None:
    again = reachability_table(scenario)
    assert {k: r.reason for k, r in again.items()} == {k: r.reason for k, r in table.items()}
    assert reachable_pairs(again) == reachable_pairs(table)


def test_rrtstar_is_selectable(scenario: Scenario) -> None:
    with World(scenario, planner="RRTstar") as w:
        result = w.check_reach("right", "leg1")
    assert result.reachable and result.path is not None


# A foot buried in a tall crate: the arm can get there, but only through the crate.
BURIED = """
name = "buried"
[[regions]]
id = "robotOnly"
x = [0.30, 0.65]
human_reach = false
[[parts]]
id = "leg1"
kind = "leg"
length = "tall"
shape = "square"
region = "robotOnly"
pose = [0.45, -0.3, 0.0]
[[parts]]
id = "foot1"
kind = "foot"
shape = "square"
region = "robotOnly"
pose = [0.45, 0.3, 0.0]
[[parts]]
id = "crate"
kind = "other"
class = "crate"
region = "robotOnly"
pose = [0.45, 0.3, 0.0]
size = [0.25, 0.25, 0.40]
[goal]
attachments = [["foot1", "leg1"]]
"""


def test_ik_in_collision_names_the_cause() -> None:
    buried = parse_scenario(BURIED, "buried.toml")
    with World(buried) as w:
        result = w.check_reach("left", "foot1")
        assert (result.reachable, result.reason, result.path) == (False, "IK in collision", None)
        assert w.check_reach("right", "leg1").reason == "ok"


def test_base_pose_moves_the_robot(scenario: Scenario) -> None:
    # Baxter rolled 0.6 m along the bench: the human-only leg comes within reach.
    moved = scenario.model_copy(
        update={"robot": scenario.robot.model_copy(update={"base_pose": [0.6, 0.0, 0.0]})}
    )
    with World(moved) as w:
        assert any(w.check_reach(arm, "leg2").reachable for arm in ("left", "right"))


def test_default_parts_fill_their_regions(scenario: Scenario) -> None:
    extents = region_extents(scenario)
    assert extents["robotOnly"] == (0.30, 0.65)
    boxes = part_boxes(scenario)
    for part in scenario.parts:
        lo, hi = extents[part.region]
        assert lo <= boxes[part.id].x <= hi
    positions = [(b.x, b.y) for b in boxes.values()]
    assert len(set(positions)) == len(positions)


@pytest.mark.parametrize("planner", ["RRTConnect", "RRTstar"])
def test_plan_path_goes_around_an_obstacle(planner: str) -> None:
    # A wall at x in [0.4, 0.6] with a gap only at y > 0.8: the straight line is blocked.
    def valid(q: list[float]) -> bool:
        return not (0.4 <= q[0] <= 0.6 and q[1] < 0.8)

    path = plan_path(
        valid, [0.0, 0.0], [1.0, 0.0], [0.0, 0.0], [1.0, 1.0], planner=planner, time_limit=2.0
    )
    assert path is not None
    assert path[0] == [0.0, 0.0] and path[-1] == pytest.approx([1.0, 0.0])
    assert all(valid(q) for q in path)
    assert plan_path(valid, [0.0, 0.0], [0.5, 0.0], [0.0, 0.0], [1.0, 1.0]) is None


def test_cli_prints_every_pair(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["feasibility", str(DEFAULT)]) == 0
    out = capsys.readouterr().out
    assert "leg2" in out and "no IK" in out and "checks in" in out


def test_planning_takes_feasibility_from_geometry_when_asked() -> None:
    from planner.planning import bench_checks, feasible_pairs

    with bench_checks(load_scenario(DEFAULT), ":memory:") as checks:
        assert checks is not None  # the default scenario's source is geometry
        pairs, seconds = feasible_pairs(load_scenario(DEFAULT), checks)
    assert {("left", "leg1"), ("right", "leg1")} <= pairs
    assert not {("left", "leg2"), ("right", "leg2")} & pairs
    # Each arm reaches the top at the connection point on its side.
    assert {("left", "top"), ("right", "top")} <= pairs
    assert seconds > 0
    declared_scenario = load_scenario(DEFAULT.with_name("declared.toml"))
    with bench_checks(declared_scenario, ":memory:") as none:
        assert none is None  # a declared table needs no robot model
    declared, zero = feasible_pairs(declared_scenario)
    assert ("left", "foot2") in declared and zero == 0.0


def test_plan_motions_are_collision_free_within_limits_and_continuous(tmp_path: Path) -> None:
    from planner.feasibility.plan_motions import joint_names
    from planner.plan.model import Motion
    from planner.planning import plan_scenario
    from planner.vocabulary import Hold, Unhold

    plan = plan_scenario(load_scenario(DEFAULT), workers=1, cache_dir=tmp_path).plan
    motions: dict[tuple[str, str], Motion] = {}
    for node in plan.nodes.values():
        if node.kind != "actuation":
            continue
        motion = node.motion
        assert motion is not None
        assert motion.joints == joint_names(motion.arm)
        # A free arm waits at home: holds start there, releases end there.
        if isinstance(node.action, Hold):
            assert motion.path[0] == pytest.approx(HOME[motion.arm], abs=1e-3)
        if isinstance(node.action, Unhold):
            assert motion.path[-1] == pytest.approx(HOME[motion.arm], abs=1e-3)
        motions[(motion.arm, str(motion.path))] = motion
    assert len(motions) >= 4
    with World(load_scenario(DEFAULT)) as world:
        parts = frozenset(world.scene.parts)
        for arm, _ in motions:
            path = motions[(arm, _)].path
            for q in path:
                assert world.robot.within_limits(arm, q, tol=1e-3)
            for a, b in zip(path, path[1:], strict=False):
                jump = max(abs(x - y) for x, y in zip(a, b, strict=True))
                steps = max(1, math.ceil(jump / FINE_STEP))
                for k in range(steps + 1):
                    q = [x + (y - x) * k / steps for x, y in zip(a, b, strict=True)]
                    # The gripper may touch what it holds or works on; nothing else.
                    assert world.is_valid(arm, q, parts), (arm, q)


def test_audit_checks_that_motions_are_continuous(tmp_path: Path) -> None:
    import copy

    from planner.audit.branches import audit
    from planner.planning import plan_scenario

    doc = plan_scenario(load_scenario(DEFAULT), workers=1, cache_dir=tmp_path).plan.to_json()
    assert audit(doc) == []
    broken = copy.deepcopy(doc)
    node_id, node = next(
        (i, n) for i, n in broken["nodes"].items() if str(n["action"]).startswith("unhold")
    )
    node["motion"]["path"] = [[q + 0.2 for q in node["motion"]["path"][0]]]
    messages = {(v.node, v.message) for v in audit(broken)}
    arm = node["motion"]["arm"]
    assert (node_id, f"{arm} motion starts away from where the arm is") in messages
    del broken["nodes"][node_id]["motion"]
    assert any("actuation without a motion" in v.message for v in audit(broken))


def test_the_collision_model_drops_bare_frames_and_checks_as_the_full_model() -> None:
    """The checks load Baxter without the links that can neither collide nor carry
    a joint (sensor and cable frames): every other link stands where it stood, and
    every collision check answers as with the full model."""
    import random
    import re

    from planner.feasibility._bullet import pb
    from planner.feasibility.arms import ARMS
    from planner.feasibility.robot import baxter_urdf, collision_urdf, load_robot

    full_text, lean_text = baxter_urdf().read_text(), collision_urdf().read_text()
    assert len(re.findall("<collision", lean_text)) == len(re.findall("<collision", full_text))
    scenario = load_scenario(Path("static/scenarios/paper/paper-05.toml"))
    lean = World(scenario)
    client = pb.connect(pb.DIRECT)
    full = World(scenario, robot=load_robot(client, scenario.robot.base_pose, baxter_urdf()))
    try:
        assert len(lean.robot.link) == len(full.robot.link) - 15
        assert set(lean.robot.link) < set(full.robot.link)
        rng = random.Random(5)
        answers = []
        for arm in ARMS:
            lo, hi = lean.robot.lower[arm], lean.robot.upper[arm]
            for _ in range(300):
                q = [rng.uniform(a, b) for a, b in zip(lo, hi, strict=True)]
                assert lean.endpoint(arm, q) == full.endpoint(arm, q)
                answers.append(lean.is_valid(arm, q, "top"))
                assert answers[-1] == full.is_valid(arm, q, "top")
        assert any(answers) and not all(answers)
    finally:
        lean.close()
        full.close()
