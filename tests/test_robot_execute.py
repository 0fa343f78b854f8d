"""`tandem execute --robot ros` against a real roscore and the simulated Baxter node.

Each test runs the command line as a user would (a subprocess, a session store
in a temp folder) and reads what the session stored: every actuation node's
robot report (where the arm ended, the joint states along the way), or the
fault that stopped the run, with the robot's last joint state and the cause
in one line.
"""

from __future__ import annotations

import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Literal

import pytest

from app.execution.events import ExecutionEvent
from app.execution.robot_link import farthest
from app.robot.ros_env import RosMaster, free_port
from app.robot.ros_link import RESULT_GRACE_S
from app.sessions.store import DB_NAME, SessionStore, StoreError
from tests.robot_graph import (
    ROOT,
    FaultTopic,
    JointWatch,
    kill_sim,
    ros_installed,
    ros_node,
    shared_master,
    sim_baxter,
)

pytestmark = pytest.mark.skipif(not ros_installed(), reason="ROS 1 is not installed: make robot")

REACHED_RAD = 0.01


def _execute(
    master_uri: str, data: Path, seed: int, env: dict[str, str], ratio: float = 1.0
) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-m", "app.cli", "execute", "default.toml", "--responses", "random",
         "--seed", str(seed), "--robot", f"ros:{master_uri}", "--speed-ratio", str(ratio),
         "--data-dir", str(data)],
        cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        stdin=subprocess.DEVNULL,
    )  # fmt: skip


def _events(data: Path) -> tuple[str | None, list[ExecutionEvent]]:
    with SessionStore(data, read_only=True) as store:
        sessions = store.list_sessions()
        assert len(sessions) == 1
        return sessions[0].result, store.events(sessions[0].id)


def _wait_for(
    done: Callable[[], bool], process: subprocess.Popen[str], timeout_s: float = 120
) -> None:
    began = time.monotonic()
    while not done():
        assert process.poll() is None, process.communicate()
        assert time.monotonic() - began < timeout_s, "timed out"
        time.sleep(0.05)


def _moved(data: Path, count: int) -> Callable[[], bool]:
    """Whether the run stored `count` actuation events yet."""

    def done() -> bool:
        if not (data / DB_NAME).exists():
            return False
        try:
            with SessionStore(data, read_only=True) as store:
                sessions = store.list_sessions()
                events = store.events(sessions[0].id) if sessions else []
        except StoreError:
            # The run has created the file but not yet all its tables.
            return False
        return sum(e.kind == "actuation" for e in events) >= count

    return done


def test_five_seeds_reach_the_goal_on_the_simulated_baxter(tmp_path: Path) -> None:
    master = shared_master()
    with sim_baxter(master) as sim:
        for seed in range(1, 6):
            data = tmp_path / f"seed{seed}"
            run = _execute(master.uri, data, seed, master.env())
            out, err = run.communicate(timeout=300)
            assert run.returncode == 0, err
            result, events = _events(data)
            assert result == "goal"
            moves = [e for e in events if e.kind == "actuation"]
            assert moves, "the default plan moves the arms"
            with SessionStore(data, read_only=True) as store:
                plan = store.plan(store.list_sessions()[0].plan_hash)
            for event in moves:
                robot = event.evidence.robot if event.evidence else None
                assert robot is not None and robot.link == "ros"
                assert robot.cause is None and robot.off_rad <= REACHED_RAD
                # The step starts when the goal was sent, not when it was reached (the
                # robot's state read, a way to the motion's start planned before it).
                assert robot.began is not None
                assert event.start == pytest.approx(robot.began, rel=0, abs=1e-6)
                assert len(robot.states) >= 2  # joint states along the motion, stored
                # Against the plan's own motion (unless the world's slots re-targeted it).
                retargeted = event.evidence.retargeted if event.evidence else None
                motion = retargeted.motion if retargeted and retargeted.motion else None
                motion = motion or plan.nodes[event.node].motion
                assert motion is not None
                assert farthest(robot.reached, motion.path[-1]) <= REACHED_RAD
        assert sim.process.poll() is None
    _exported_joint_states_are_the_robots(tmp_path / "seed1")


def _exported_joint_states_are_the_robots(data: Path) -> None:
    """The session's MCAP export carries the robot's own joint states, at their times."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    out = data / "session.mcap"
    done = subprocess.run(
        [sys.executable, "-m", "app.cli", "sessions", "export", "1", "--format", "mcap",
         "-o", str(out), "--data-dir", str(data)],
        cwd=ROOT, capture_output=True, text=True,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    _, events = _events(data)
    robot_events = [e for e in events if e.evidence and e.evidence.robot]
    expected = [(q, e) for e in robot_events for _, q in e.evidence.robot.states]  # type: ignore[union-attr]
    with out.open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        seen = [
            (tuple(m.position), message.log_time / 1e9)
            for _, channel, message, m in reader.iter_decoded_messages()
            if channel.topic == "/joint_states"
        ]
    assert [q for q, _ in seen] == [tuple(q) for q, _ in expected] and len(seen) > 10
    # Each state at its time: within the step that made it (sent after the step began,
    # seen before it ended), however long planning the way to the motion's start took.
    for (_, t), (_, event) in zip(seen, expected, strict=True):
        assert event.start is not None and event.end is not None
        assert event.start - 1e-3 <= t <= event.end + 1e-3


def test_no_master_at_start_is_one_line_and_exit_2(tmp_path: Path) -> None:
    run = _execute(f"http://127.0.0.1:{free_port()}", tmp_path, 1, shared_master().env())
    out, err = run.communicate(timeout=60)
    assert run.returncode == 2
    assert err.strip().count("\n") == 0 and "no ROS master" in err
    assert not (tmp_path / DB_NAME).exists()  # nothing started, nothing stored


def _stopped(data: Path, run: subprocess.Popen[str], cause: str) -> ExecutionEvent:
    """The run ended aborted (exit 1) on one robot fault of `cause`, stored with its
    line and the arm's last joint state; that fault's event."""
    assert run.returncode == 1
    result, events = _events(data)
    assert result == "aborted"
    faults = [e for e in events if e.kind == "robot-fault"]
    assert len(faults) == 1
    fault = faults[0]
    assert fault.text and "\n" not in fault.text
    assert fault.evidence is not None and fault.evidence.robot is not None
    assert fault.evidence.robot.cause == cause
    assert len(fault.evidence.robot.reached) == 7  # the arm's last joint state
    return fault


def test_an_aborted_goal_stops_the_run_with_the_cause(tmp_path: Path) -> None:
    master = shared_master()
    with sim_baxter(master):
        faults = FaultTopic(master)
        run = _execute(master.uri, tmp_path, 3, master.env(), ratio=0.5)
        _wait_for(_moved(tmp_path, 1), run)
        faults.send("abort")  # the next goal is aborted halfway
        out, err = run.communicate(timeout=120)
        faults.close()
    fault = _stopped(tmp_path, run, "aborted")
    assert "aborted" in (fault.text or "") and "robot:" in err


def test_a_goal_the_robot_never_ends_is_cancelled_and_stops_the_run(tmp_path: Path) -> None:
    """A stuck driver keeps a goal active and never moves: the link does not wait for
    ever, but cancels it `RESULT_GRACE_S` after the motion's end and says why."""
    master = shared_master()
    with sim_baxter(master):
        faults = FaultTopic(master)
        run = _execute(master.uri, tmp_path, 3, master.env(), ratio=0.5)
        _wait_for(_moved(tmp_path, 1), run)
        faults.send("hang")  # the next goal is accepted and never ends
        sent = time.monotonic()
        out, err = run.communicate(timeout=120)
        waited = time.monotonic() - sent
        faults.close()
    fault = _stopped(tmp_path, run, "no-result")
    assert "no result" in (fault.text or "") and "cancelled" in (fault.text or "")
    assert RESULT_GRACE_S <= waited < 60, waited


def test_killing_the_node_mid_trajectory_stops_the_run(tmp_path: Path) -> None:
    master = shared_master()
    with sim_baxter(master) as sim:
        watch = JointWatch(master)
        run = _execute(master.uri, tmp_path, 4, master.env(), ratio=0.3)
        _wait_for(_moved(tmp_path, 1), run)
        still = watch.latest()
        left = [f"left_{j}" for j in ("s0", "s1", "e0", "e1", "w0", "w1", "w2")]
        # The next motion is under way: the left arm moves.
        watch.wait_for(lambda s: farthest([s[j] for j in left], [still[j] for j in left]) > 0.02)
        kill_sim(sim)
        run.communicate(timeout=120)
        watch.close()
    fault = _stopped(tmp_path, run, "silent")
    assert "during the motion" in (fault.text or "")


def test_killing_the_master_stops_the_run(tmp_path: Path) -> None:
    with RosMaster() as master, sim_baxter(master):
        run = _execute(master.uri, tmp_path, 5, master.env(), ratio=0.3)
        _wait_for(_moved(tmp_path, 1), run)
        master.kill()
        run.communicate(timeout=120)
    _stopped(tmp_path, run, "master-lost")


def test_pause_stops_the_arm_at_once_and_resume_finishes_the_motion() -> None:
    from app.cli.execute import load_plan
    from app.execution.retargeting import retargeter_for
    from app.execution.robot_drive import RobotDriver
    from app.execution.walker import Executor
    from app.robot.ros_link import RosLink
    from app.sources.outcomes import RandomSource

    master = shared_master()
    with sim_baxter(master):
        ros_node(master)  # this process's node, on the shared master
        plan, scenario = load_plan("default.toml")
        retarget = retargeter_for(scenario, plan)
        link = RosLink(master.uri)
        link.connect(10.0)
        moving: list[float] = []  # when the arm was last seen moving
        last: dict[str, float] = {}

        def seen(state: object) -> None:
            positions = getattr(state, "positions", {})
            if last and farthest(list(positions.values()), list(last.values())) > 1e-4:
                moving.append(time.monotonic())
            last.clear()
            last.update(positions)

        stop_watching = link.watch(seen)
        driver = RobotDriver(link, retarget.to_start if retarget else None, None, 0.3)
        events: list[ExecutionEvent] = []
        executor = Executor(plan, RandomSource(1), [events.append], retarget=retarget, robot=driver)
        executor.start()
        began = time.monotonic()
        while not moving or moving[-1] < began + 0.3:  # the first motion is under way
            assert time.monotonic() - began < 30
            time.sleep(0.02)
        executor.pause()
        paused_at, paused_wall = time.monotonic(), time.time()
        time.sleep(1.5)
        assert not any(e.kind == "actuation" for e in events)  # the motion did not end
        stopped_after = moving[-1] - paused_at
        print(f"the arm stopped {stopped_after:.3f} s after the pause")
        assert moving[-1] < paused_at + 1.0  # still for the last half second at least
        executor.resume()
        result = executor.wait(120)
        stop_watching()
        link.close()
    assert result == "goal"
    first = next(e for e in events if e.kind == "actuation")
    assert first.evidence is not None and first.evidence.robot is not None
    robot = first.evidence.robot
    assert robot.off_rad <= REACHED_RAD  # resumed to the motion's end
    # The states stored are the whole motion's, before the pause and after it, timed
    # from the goal first sent.
    times = [t for t, _ in robot.states]
    assert robot.began is not None and times == sorted(times)
    assert robot.began + times[0] < paused_wall < robot.began + times[-1] - 1.5


def test_retry_after_an_aborted_goal_goes_back_to_the_start_and_reaches_the_goal() -> None:
    from app.cli.execute import load_plan
    from app.execution.retargeting import retargeter_for
    from app.execution.robot_drive import RobotDriver
    from app.execution.robot_link import RobotFault
    from app.execution.walker import Executor
    from app.robot.ros_link import RosLink
    from app.sources.outcomes import RandomSource

    master = shared_master()
    with sim_baxter(master):
        faults = FaultTopic(master)
        plan, scenario = load_plan("default.toml")
        retarget = retargeter_for(scenario, plan)
        link = RosLink(master.uri)
        link.connect(10.0)
        asked: list[RobotFault] = []

        def retry(fault: RobotFault) -> Literal["retry"]:
            asked.append(fault)
            return "retry"

        driver = RobotDriver(link, retarget.to_start if retarget else None, retry, 1.0)
        events: list[ExecutionEvent] = []
        executor = Executor(plan, RandomSource(2), [events.append], retarget=retarget, robot=driver)
        faults.send("abort")  # the first goal is aborted halfway
        result = executor.run()
        faults.close()
        link.close()
    assert result == "goal"
    assert [f.cause for f in asked] == ["aborted"]
    fault = next(e for e in events if e.kind == "robot-fault")
    retried = next(e for e in events if e.kind == "actuation" and e.seq > fault.seq)
    robot = retried.evidence.robot if retried.evidence else None
    # Stopped halfway, the arm went back to the motion's start first, then made it.
    assert robot is not None and robot.to_start and robot.off_rad <= REACHED_RAD
