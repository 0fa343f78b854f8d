"""`tandem robot sim` on a real roscore, driven by a real actionlib client from here.

One master and one simulated Baxter serve the module; each test moves from
where the arm is, so the tests do not depend on their order. The start pose
and the exit on SIGTERM use a node of their own on a master of their own.
"""

from __future__ import annotations

import importlib
import json
import subprocess
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import pytest

from app.robot.ros_env import RosMaster, free_port
from app.robot.sim_gripper import PART_POSITION
from planner.feasibility.arms import HOME, joint_names
from tests.robot_graph import (
    ROOT,
    JointWatch,
    SimBaxter,
    ros_installed,
    ros_node,
    shared_master,
    sim_baxter,
)

pytestmark = pytest.mark.skipif(not ros_installed(), reason="ROS 1 is not installed: make robot")

LEFT = joint_names("left")
# actionlib_msgs/GoalStatus
SUCCEEDED, ABORTED, PREEMPTED = 3, 4, 2


@dataclass
class Graph:
    sim: SimBaxter
    rospy: Any
    watch: JointWatch
    clients: dict[str, Any]
    control: Any
    baxter: Any
    faults: Any
    grippers: dict[str, Any]


def _publisher(rospy: Any, topic: str, kind: Any) -> Any:
    """A publisher whose first message is not lost: it waits for the sim's subscription."""
    publisher = rospy.Publisher(topic, kind, queue_size=10)
    deadline = time.monotonic() + 10.0
    while publisher.get_num_connections() == 0 and time.monotonic() < deadline:
        time.sleep(0.02)
    return publisher


@pytest.fixture(scope="module")
def graph() -> Iterator[Graph]:
    master = shared_master()
    with sim_baxter(master) as sim:
        rospy = ros_node(master)
        actionlib = importlib.import_module("actionlib")
        control = importlib.import_module("control_msgs.msg")
        baxter = importlib.import_module("baxter_core_msgs.msg")
        std = importlib.import_module("std_msgs.msg")
        clients = {}
        for side in ("left", "right"):
            client = actionlib.SimpleActionClient(
                f"/robot/limb/{side}/follow_joint_trajectory", control.FollowJointTrajectoryAction
            )
            assert client.wait_for_server(rospy.Duration(20.0))
            clients[side] = client
        grippers = {
            side: _publisher(
                rospy, f"/robot/end_effector/{side}_gripper/command", baxter.EndEffectorCommand
            )
            for side in ("left", "right")
        }
        watch = JointWatch(master)
        watch.latest()
        faults = _publisher(rospy, "/tandem_sim/fault", std.String)
        yield Graph(sim, rospy, watch, clients, control, baxter, faults, grippers)
        watch.close()
        for client in clients.values():
            client.cancel_all_goals()


def _goal(
    g: Graph, names: Sequence[str], points: Sequence[Sequence[float]], times: Sequence[float]
) -> Any:
    points_msg = importlib.import_module("trajectory_msgs.msg")
    goal = g.control.FollowJointTrajectoryGoal()
    goal.trajectory.joint_names = list(names)
    for q, t in zip(points, times, strict=True):
        goal.trajectory.points.append(
            points_msg.JointTrajectoryPoint(positions=list(q), time_from_start=g.rospy.Duration(t))
        )
    return goal


def _path(
    start: Sequence[float], end: Sequence[float], seconds: float, n: int = 6
) -> tuple[list[list[float]], list[float]]:
    """`n` waypoints on the straight line from `start` to `end`, evenly timed."""
    points = [
        [a + (b - a) * k / n for a, b in zip(start, end, strict=True)] for k in range(1, n + 1)
    ]
    return points, [seconds * k / n for k in range(1, n + 1)]


def _left(state: dict[str, float]) -> list[float]:
    return [state[name] for name in LEFT]


def _send_left(g: Graph, target: Sequence[float], seconds: float) -> tuple[list[float], Any]:
    """Sends a straight move of the left arm from where it is; its start and the client."""
    start = _left(g.watch.latest())
    points, times = _path(start, target, seconds)
    g.clients["left"].send_goal(_goal(g, LEFT, points, times))
    return start, g.clients["left"]


def _finish(client: Any, g: Graph) -> int:
    assert client.wait_for_result(g.rospy.Duration(30.0))
    return int(client.get_state())


def _go_home(g: Graph) -> None:
    _, client = _send_left(g, HOME["left"], 1.5)
    assert _finish(client, g) == SUCCEEDED


def test_a_trajectory_is_followed_to_its_last_point(graph: Graph) -> None:
    _go_home(graph)
    target = [
        h + d for h, d in zip(HOME["left"], (0.4, -0.2, 0.3, 0.35, -0.3, -0.25, 0.5), strict=True)
    ]
    began = time.monotonic()
    start, client = _send_left(graph, target, 1.5)
    assert _finish(client, graph) == SUCCEEDED
    result = client.get_result()
    assert result.error_code == 0, result.error_string
    final = _left(graph.watch.current())
    assert max(abs(a - b) for a, b in zip(final, target, strict=True)) < 0.01
    # Along the way: states strictly between the start and the end, in order.
    s0 = [state["left_s0"] for state in graph.watch.since(began)]
    between = [v for v in s0 if start[0] + 0.02 < v < target[0] - 0.02]
    assert len(between) >= 5
    assert between == sorted(between)
    # The right arm stayed where it was.
    right = graph.watch.latest()
    assert [right[n] for n in joint_names("right")] == pytest.approx(HOME["right"], abs=1e-6)


def test_a_trajectory_beyond_the_limits_is_aborted_before_moving(graph: Graph) -> None:
    before = _left(graph.watch.latest())
    beyond = [*before]
    beyond[0] = 2.0  # left_s0's limit is 1.70 rad
    client = graph.clients["left"]
    client.send_goal(_goal(graph, LEFT, [beyond], [4.0]))
    assert _finish(client, graph) == ABORTED
    result = client.get_result()
    assert result.error_code == graph.control.FollowJointTrajectoryResult.INVALID_GOAL
    assert "left_s0" in result.error_string and "limits" in result.error_string
    # Too fast: left_e1 (1.5 rad/s at most) 1 rad in 0.2 s.
    fast = [*before]
    fast[3] = before[3] + 1.0 if before[3] < 1.5 else before[3] - 1.0
    client.send_goal(_goal(graph, LEFT, [fast], [0.2]))
    assert _finish(client, graph) == ABORTED
    result = client.get_result()
    assert result.error_code == graph.control.FollowJointTrajectoryResult.INVALID_GOAL
    assert "left_e1" in result.error_string and "rad/s" in result.error_string
    # Another arm's joint on the left arm's action.
    client.send_goal(_goal(graph, ["right_s0"], [[0.0]], [1.0]))
    assert _finish(client, graph) == ABORTED
    assert (
        client.get_result().error_code == graph.control.FollowJointTrajectoryResult.INVALID_JOINTS
    )
    after = _left(graph.watch.current())
    assert after == pytest.approx(before, abs=1e-9)


def test_a_cancel_stops_the_arm_short(graph: Graph) -> None:
    _go_home(graph)
    target = [*HOME["left"]]
    target[0] = 1.0  # left_s0 from 0 to 1 rad in 3 s
    start, client = _send_left(graph, target, 3.0)
    graph.watch.wait_for(lambda s: s["left_s0"] > start[0] + 0.05)
    client.cancel_goal()
    assert _finish(client, graph) == PREEMPTED
    stopped = graph.watch.current()["left_s0"]
    # Still there a while later: the arm stopped, short of the target.
    time.sleep(0.5)
    later = graph.watch.current()["left_s0"]
    assert later == pytest.approx(stopped, abs=1e-9)
    assert start[0] + 0.05 < later < target[0] - 0.05


def test_an_injected_abort_stops_the_next_goal_halfway(graph: Graph) -> None:
    _go_home(graph)
    std = importlib.import_module("std_msgs.msg")
    graph.faults.publish(std.String("abort"))
    time.sleep(0.3)  # the fault is heard before the goal is sent
    target = [*HOME["left"]]
    target[2] = 0.8  # left_e0
    start, client = _send_left(graph, target, 2.0)
    assert _finish(client, graph) == ABORTED
    result = client.get_result()
    assert result.error_code == graph.control.FollowJointTrajectoryResult.PATH_TOLERANCE_VIOLATED
    assert "fault injected" in result.error_string
    e0 = graph.watch.current()["left_e0"]
    assert start[2] + 0.1 < e0 < target[2] - 0.1  # halfway: 0.4 rad


class GripperStates:
    """The states one gripper publishes, heard from here."""

    def __init__(self, g: Graph, side: str) -> None:
        self.g, self.side = g, side
        self.states: list[Any] = []
        self._subscriber = g.rospy.Subscriber(
            f"/robot/end_effector/{side}_gripper/state",
            g.baxter.EndEffectorState,
            self.states.append,
        )

    def send(self, command: str, args: str = "", sequence: int = 1, id: int = 65538) -> None:
        self.g.grippers[self.side].publish(
            self.g.baxter.EndEffectorCommand(
                id=id, command=command, args=args, sender="test", sequence=sequence
            )
        )

    def until(self, fits: Callable[[Any], bool], timeout_s: float = 10.0) -> Any:
        began = time.monotonic()
        while not (self.states and fits(self.states[-1])):
            assert time.monotonic() - began < timeout_s, f"{self.side}: {self.states[-1:]}"
            time.sleep(0.02)
        return self.states[-1]

    def close(self) -> None:
        self._subscriber.unregister()


def test_an_electric_gripper_refuses_go_until_calibrated_then_goes(graph: Graph) -> None:
    right = GripperStates(graph, "right")
    try:
        right.send("clear_calibration", sequence=1)
        right.until(lambda s: s.command_sequence == 1 and s.calibrated == 0)
        right.send("go", json.dumps({"position": 0.0}), sequence=2)
        refused = right.until(lambda s: s.error == 1)
        assert refused.position == 100.0 and refused.moving == 0 and refused.ready == 0
        # Handled, with the error flag: the state acknowledges it.
        assert refused.command == "go" and refused.command_sequence == 2
        right.send("calibrate", sequence=3)
        calibrated = right.until(lambda s: s.calibrated == 1 and s.ready == 1)
        assert calibrated.error == 0 and calibrated.command == "calibrate"
        assert calibrated.command_sender == "test" and calibrated.command_sequence == 3
        right.send("go", json.dumps({"position": 0.0}), sequence=4)
        moving = right.until(lambda s: s.moving == 1)
        assert 30.0 < moving.position < 100.0
        # No part is simulated: closing fingers meet one at PART_POSITION.
        held = right.until(lambda s: s.gripping == 1 and s.moving == 0)
        assert held.position == pytest.approx(PART_POSITION) and held.force > 0.0
        right.send("go", json.dumps({"position": 100.0}), sequence=5)
        opened = right.until(lambda s: s.position == 100.0 and s.moving == 0)
        assert opened.gripping == 0 and opened.command_sequence == 5
    finally:
        right.close()


def test_a_gripper_ignores_another_id_and_grip_on_an_electric_gripper(graph: Graph) -> None:
    left = GripperStates(graph, "left")
    try:
        left.send("calibrate", sequence=10)
        left.until(lambda s: s.calibrated == 1 and s.ready == 1 and s.command_sequence == 10)
        left.send("go", json.dumps({"position": 0.0}), sequence=11, id=65537)
        left.send("grip", sequence=12)
        time.sleep(0.5)
        left.send("go", json.dumps({"position": 60.0}), sequence=13)
        state = left.until(lambda s: s.command_sequence == 13 and s.moving == 0)
        assert state.position == pytest.approx(60.0) and state.gripping == 0
        assert [s.command_sequence for s in left.states if s.command_sequence in (11, 12)] == []
    finally:
        left.close()


def test_mute_stops_the_joint_states_and_unmute_resumes_them(graph: Graph) -> None:
    std = importlib.import_module("std_msgs.msg")
    graph.watch.latest()
    graph.faults.publish(std.String("mute"))
    time.sleep(0.5)  # states already on the wire arrive
    quiet_from = time.monotonic()
    time.sleep(0.7)
    assert graph.watch.since(quiet_from) == []
    graph.faults.publish(std.String("unmute"))
    assert "left_s0" in graph.watch.latest()


def test_start_pose_and_exit_on_sigterm() -> None:
    """A node of its own (on its own master): it starts where it is told, and
    SIGTERM ends it with exit code 0."""
    with RosMaster() as master, sim_baxter(master, start={"left_s0": 0.3, "right_e1": 1.2}) as sim:
        state = _one_joint_state(master)
        assert state["left_s0"] == pytest.approx(0.3, abs=1e-9)
        assert state["right_e1"] == pytest.approx(1.2, abs=1e-9)
        assert state["left_e1"] == pytest.approx(HOME["left"][3], abs=1e-9)
        assert sim.stop() == 0
    assert "ready on " + master.uri in sim.said()


def _one_joint_state(master: RosMaster) -> dict[str, float]:
    """One joint state read by rostopic (its own process: this one's node is on the
    shared master)."""
    out = subprocess.run(
        ["rostopic", "echo", "-n", "1", "/robot/joint_states"],
        env=master.env(), capture_output=True, text=True, timeout=60, check=True,
    ).stdout  # fmt: skip
    lines = out.splitlines()
    names = [line[len("  - ") :] for line in lines if line.startswith("  - ")]
    (positions,) = [line for line in lines if line.startswith("position: ")]
    values = [float(v) for v in positions[len("position: ") :].strip("[]").split(",")]
    return dict(zip(names, values, strict=True))


@pytest.mark.parametrize(
    ("arguments", "said"),
    [
        (["--master", "http://127.0.0.1:{port}"], "no ROS master answers at http://127.0.0.1:"),
        (["--start", '{"left_s9": 1.0}'], "--start: not arm joints: left_s9"),
        (["--start", "left_s0=1"], "--start: not JSON nor home"),
        (["--gripper", "vacuum"], "--gripper vacuum: the kind is electric or suction"),
        (["--gripper", "middle=suction"], "--gripper middle=suction: the side is left or right"),
    ],
)
def test_what_the_node_cannot_run_on_is_one_line_and_exit_code_2(
    arguments: list[str], said: str
) -> None:
    port = str(free_port())
    given = [a.replace("{port}", port) for a in arguments]
    run = subprocess.run(
        [sys.executable, "-m", "app.cli", "robot", "sim", *given],
        cwd=ROOT, capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert run.returncode == 2
    assert run.stderr.startswith(said) and run.stderr.count("\n") == 1, run.stderr
