"""The robot link's own rules, without a robot: which address a ROS node gives the
robot, when a motion counts as arrived, and the robot's clock read as this
machine's (real message classes handed to the link as rospy hands them)."""

from __future__ import annotations

import importlib
import threading
import time

import pytest

from app.execution.robot_drive import arrived, joined
from app.execution.robot_link import GOAL_TOLERANCE_RAD, Followed, off_goal
from app.robot.link_network import advertised_line, choose_address
from planner.plan.model import Motion
from tests.robot_graph import ros_installed

LOCAL = "http://127.0.0.1:11311"
ROBOT = "http://011502P0001.local:11311"  # a Baxter's master, by its serial number


def test_ros_ip_is_respected_and_loopback_only_without_either_on_a_local_master() -> None:
    # baxter.sh sets ROS_IP: it must stay what the robot reaches (it used to be hidden
    # behind a ROS_HOSTNAME of 127.0.0.1, which rospy prefers).
    env = {"ROS_IP": "192.0.2.2"}
    choose_address(LOCAL, env)
    assert env == {"ROS_IP": "192.0.2.2"}
    env = {"ROS_HOSTNAME": "workstation.local"}
    choose_address(ROBOT, env)
    assert env == {"ROS_HOSTNAME": "workstation.local"}
    env = {}
    choose_address(ROBOT, env)  # rospy's own choice: this machine's name
    assert env == {}
    env = {"ROS_IP": ""}  # set but empty: as unset
    choose_address("http://localhost:11311", env)
    assert env["ROS_HOSTNAME"] == "127.0.0.1"


def test_the_advertised_line_says_why_and_warns_of_loopback_for_a_remote_master() -> None:
    line = advertised_line("http://192.0.2.2:40001/", ROBOT, {"ROS_IP": "192.0.2.2"})
    assert "http://192.0.2.2:40001/" in line and "ROS_IP=192.0.2.2" in line
    assert "cannot reach" not in line
    line = advertised_line("http://127.0.0.1:40001/", ROBOT, {"ROS_HOSTNAME": "127.0.0.1"})
    assert "cannot reach" in line and "ROS_IP" in line
    line = advertised_line("http://127.0.0.1:40001/", LOCAL, {"ROS_HOSTNAME": "127.0.0.1"})
    assert "cannot reach" not in line


def _motion() -> Motion:
    joints = tuple(f"left_{j}" for j in ("s0", "s1", "e0", "e1", "w0", "w1", "w2"))
    path = [[0.0] * 7, [0.1, -0.2, 0.3, 0.4, 0.0, 0.5, -0.1]]
    return Motion(arm="left", joints=list(joints), path=path)


def test_a_motion_the_robot_calls_done_but_short_of_its_end_is_an_off_goal_fault() -> None:
    motion = _motion()
    end = dict(zip(motion.joints, motion.path[-1], strict=True))
    assert off_goal(end, end) is None
    short = dict(end, left_e1=end["left_e1"] - 0.15)
    said_done = Followed(None, "reached the end of 2 waypoints", short)
    followed = arrived(motion, said_done)
    assert followed.cause == "off-goal"
    assert "left_e1" in followed.detail and "0.150 rad" in followed.detail
    within = dict(end, left_e1=end["left_e1"] - GOAL_TOLERANCE_RAD / 2)
    assert arrived(motion, Followed(None, "", within)).ok
    missing = {k: v for k, v in end.items() if k != "left_w2"}
    assert off_goal(missing, end) is not None  # a joint the robot did not report


def test_a_motion_sent_again_after_pauses_keeps_every_goals_states_on_one_clock() -> None:
    a, b = (0.0,) * 7, (0.1,) * 7
    paused = Followed("preempted", "cancelled", {}, ((0.0, a), (0.4, a)), 1000.0)
    refused = Followed("disabled", "the robot is disabled", {})  # never sent
    resumed = Followed(None, "reached the end of 2 waypoints", {}, ((0.1, b), (0.9, b)), 1002.5)
    whole = joined([paused, refused, resumed])
    assert whole.ok and whole.began == 1000.0 and whole.detail == resumed.detail
    assert whole.samples == ((0.0, a), (0.4, a), (2.6, b), (3.4, b))
    assert joined([resumed]) is resumed


@pytest.mark.skipif(not ros_installed(), reason="ROS 1 is not installed: make robot")
@pytest.mark.parametrize("skew_s", [-30.0, 30.0])
def test_a_fresh_joint_state_is_found_whatever_the_robots_clock(skew_s: float) -> None:
    """The robot's clock `skew_s` off this machine's: the state taken after a goal ends
    is the first one published after that moment, not one from before (robot ahead)
    nor none for a second (robot behind)."""
    from app.robot.ros_env import use_ros
    from app.robot.ros_link import RosLink

    use_ros()
    genpy = importlib.import_module("genpy")
    joint_state = importlib.import_module("sensor_msgs.msg").JointState
    link = RosLink(LOCAL)

    def publish(position: float) -> None:
        message = joint_state(name=["left_s0"], position=[position])
        message.header.stamp = genpy.Time.from_sec(time.time() + skew_s)
        link._on_joints(message)

    for _ in range(20):  # the robot's stream, at 100 Hz, before the goal ends
        publish(0.0)
        time.sleep(0.01)
    ended = time.time()
    later = threading.Timer(0.1, publish, args=(1.0,))  # the first state after the end
    later.start()
    began = time.monotonic()
    state = link._fresh(ended)
    took = time.monotonic() - began
    later.join()
    assert state is not None and state.positions["left_s0"] == 1.0
    assert took < 0.5
