"""Abort and the voice's "stop" cancel the robot's goal within half a second (issue
35, item 4), on a real roscore and the simulated Baxter node.

The arm's motion is read as the robot publishes it (`/robot/joint_states`), not as
the executor believes it: the time from the command to the last state that still
moved is what a person standing by the robot would see. The motions run at a tenth
of Baxter's speed, so the command always falls inside one.
"""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from app.cli.execute import load_plan
from app.execution.events import ExecutionEvent
from app.execution.retargeting import MotionRetargeter, retargeter_for
from app.execution.robot_drive import RobotDriver
from app.execution.robot_link import farthest
from app.execution.walker import Executor
from app.robot.ros_link import RosLink
from app.sources.outcomes import RandomSource
from planner.plan.model import Plan
from speech.recognition import Recognizer
from speech.sources import Span
from tests.robot_graph import JointWatch, ros_installed, shared_master, sim_baxter
from tests.test_voice_dialogue_stop import live_dialogue, resume_by_voice, say_once, until

pytestmark = pytest.mark.skipif(not ros_installed(), reason="ROS 1 is not installed: make robot")

CANCEL_WITHIN_S = 0.5  # the bound, from the command to the arm standing still
MOVED_RAD = 1e-4  # two states this far apart (largest joint): the arm moved between them
SLOW = 0.1  # the motions' speed, as a share of Baxter's joint velocity limits


def last_moving(watch: JointWatch, since: float) -> float | None:
    """When (time.monotonic()) the last joint state that differed from the one before
    it arrived, among the states since `since`; None if the arm never moved."""
    samples = watch.arrived_since(since)
    moved = None
    for (_, before), (at, after) in zip(samples, samples[1:], strict=False):
        names = sorted(after)
        then = [before.get(n, after[n]) for n in names]
        if farthest([after[n] for n in names], then) > MOVED_RAD:
            moved = at
    return moved


def wait_moving(watch: JointWatch, since: float, for_s: float = 0.3) -> None:
    """Until the arm has been moving for `for_s` (a motion is well under way)."""
    assert until(lambda: (last_moving(watch, since) or 0.0) > since + for_s, 60.0)


def drive(
    master_uri: str, scenario_name: str
) -> tuple[RosLink, RobotDriver, Plan, MotionRetargeter | None]:
    """The scenario's plan, and a driver on the simulated Baxter at a tenth of its speed."""
    plan, scenario = load_plan(scenario_name)
    retarget = retargeter_for(scenario, plan)
    link = RosLink(master_uri)
    link.connect(10.0)
    driver = RobotDriver(link, retarget.to_start if retarget else None, None, SLOW)
    return link, driver, plan, retarget


def test_abort_stops_the_arm_within_half_a_second() -> None:
    master = shared_master()
    with sim_baxter(master):
        watch = JointWatch(master)
        link, driver, plan, retarget = drive(master.uri, "default.toml")
        events: list[ExecutionEvent] = []
        executor = Executor(plan, RandomSource(1), [events.append], retarget=retarget, robot=driver)
        began = time.monotonic()
        executor.start()
        wait_moving(watch, began)
        aborted_at = time.monotonic()
        executor.abort()
        result = executor.wait(30)
        time.sleep(1.0)  # the arm stays still after
        stopped = last_moving(watch, began)
        link.close()
    assert result == "aborted"
    assert stopped is not None
    print(f"the arm stopped {stopped - aborted_at:.3f} s after Abort")
    assert stopped - aborted_at <= CANCEL_WITHIN_S
    assert not any(e.kind == "actuation" for e in events)  # the motion never ended


def test_the_voice_stop_stops_the_arm_within_half_a_second_and_continue_finishes(
    tmp_path: Path,
) -> None:
    master = shared_master()
    recognizer = Recognizer("ko")
    with sim_baxter(master):
        watch = JointWatch(master)
        link, driver, plan, retarget = drive(master.uri, "default-ko.toml")
        voice, human = live_dialogue(recognizer, tmp_path, seed=1)
        executor = Executor(
            plan, voice.source, narrator=voice.robot, retarget=retarget, robot=driver
        )
        paused_at: list[float] = []  # when the execution paused (its `paused` event)
        executor.listeners.append(
            lambda e: paused_at.append(time.monotonic()) if e.kind == "paused" else None
        )
        began = time.monotonic()
        executor.start()
        wait_moving(watch, began)
        said: list[Span] = []
        say_once(human, "멈춰", said, 0.2)
        assert until(lambda: bool(paused_at)), voice.ear.heard if voice.ear else None
        time.sleep(1.5)
        assert not any(e.kind == "actuation" for e in executor.events)  # stopped inside it
        stopped = last_moving(watch, began)
        driver.speed_ratio = 1.0  # the stop is measured: the rest at Baxter's full speed
        resume_by_voice(voice, human, executor)  # says 계속 and waits for the goal
        link.close()
    assert stopped is not None
    print(f"the arm stopped {stopped - paused_at[0]:.3f} s after the voice's pause")
    assert stopped - paused_at[0] <= CANCEL_WITHIN_S
    first = next(e for e in executor.events if e.kind == "actuation")
    robot = first.evidence.robot if first.evidence else None
    assert robot is not None and robot.off_rad <= 0.01  # resumed to the motion's end
    paused = next(e for e in executor.events if e.kind == "paused")
    assert paused.source == "voice" and paused.seq < first.seq
