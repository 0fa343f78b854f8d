"""The link checks what Rethink's trajectory action server does not: a real roscore,
the simulated Baxter node, `tandem execute --robot ros` as a user runs it.

Rethink's server reports success on a disabled robot without moving it (its
default goal tolerance is -1, no check). So: a disabled robot refuses the first
motion (one line, exit 2, the session stored with the refusal), unless
`--enable` enables it; an e-stop pressed mid-motion stops the run (the cause in
one line, the arm's last state stored); a goal that stops short of its end is a
fault naming the joint and the error.
"""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest

from app.execution.events import ExecutionEvent
from app.execution.robot_link import GOAL_TOLERANCE_RAD
from app.robot.link_state import RobotState, StateWatch
from app.robot.ros_env import RosMaster
from app.sessions.store import SessionStore
from tests.robot_graph import (
    ROOT,
    JointWatch,
    SimControls,
    ros_installed,
    ros_node,
    shared_master,
    sim_baxter,
)
from tests.test_robot_execute import _moved, _wait_for

pytestmark = pytest.mark.skipif(not ros_installed(), reason="ROS 1 is not installed: make robot")

STALL_RAD = 0.15  # well beyond the goal tolerance


def _execute(master: RosMaster, data: Path, *options: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-m", "app.cli", "execute", "default.toml", "--responses", "random",
         "--seed", "1", "--robot", f"ros:{master.uri}", "--data-dir", str(data), *options],
        cwd=ROOT, env=master.env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        stdin=subprocess.DEVNULL,
    )  # fmt: skip


def _stored(data: Path) -> tuple[str | None, list[ExecutionEvent]]:
    with SessionStore(data, read_only=True) as store:
        sessions = store.list_sessions()
        assert len(sessions) == 1
        return sessions[0].result, store.events(sessions[0].id)


def _robot_state(master: RosMaster, fits: object, timeout_s: float = 10.0) -> RobotState:
    """The simulated robot's `/robot/state` once `fits(state)` holds."""
    watch = StateWatch(ros_node(master))
    try:
        began = time.monotonic()
        while time.monotonic() - began < timeout_s:
            state = watch.state
            if state is not None and callable(fits) and fits(state):
                return state
            time.sleep(0.02)
        raise TimeoutError(f"/robot/state never fitted: {watch.state}")
    finally:
        watch.close()


def _the_fault(data: Path, cause: str) -> ExecutionEvent:
    result, events = _stored(data)
    assert result == "aborted"
    faults = [e for e in events if e.kind == "robot-fault"]
    assert len(faults) == 1
    fault = faults[0]
    assert fault.text and "\n" not in fault.text
    robot = fault.evidence.robot if fault.evidence else None
    assert robot is not None and robot.cause == cause, robot
    assert len(robot.reached) == 7  # the arm's last joint state, stored
    return fault


def test_a_disabled_robot_refuses_in_one_line_and_enable_enables_it(tmp_path: Path) -> None:
    master = shared_master()
    with sim_baxter(master, options=("--enabled", "no")):  # as Baxter boots
        _robot_state(master, lambda s: not s.enabled)
        watch = JointWatch(master)
        before = watch.latest()
        run = _execute(master, tmp_path / "refused")
        out, err = run.communicate(timeout=120)
        after = watch.latest()
        assert run.returncode == 2, (out, err)
        said = [line for line in err.splitlines() if line.startswith("robot:")]
        assert len(said) == 1 and "disabled" in said[0], err  # the refusal, in one line
        fault = _the_fault(tmp_path / "refused", "disabled")
        assert "enable" in (fault.text or "")
        _, events = _stored(tmp_path / "refused")
        assert not any(e.kind == "actuation" for e in events)  # nothing moved
        assert max(abs(after[j] - before[j]) for j in before) < 1e-6

        run = _execute(master, tmp_path / "enabled", "--enable", "--speed-ratio", "1.0")
        out, err = run.communicate(timeout=300)
        watch.close()
    assert run.returncode == 0, err
    result, _ = _stored(tmp_path / "enabled")
    assert result == "goal"


def test_an_estop_mid_motion_stops_the_run_with_the_cause(tmp_path: Path) -> None:
    master = shared_master()
    with sim_baxter(master):
        controls = SimControls(master)
        run = _execute(master, tmp_path, "--speed-ratio", "0.3")
        _wait_for(_moved(tmp_path, 1), run)
        time.sleep(0.3)  # the next motion under way
        controls.estop(True)
        out, err = run.communicate(timeout=120)
        state = _robot_state(master, lambda s: s.stopped)
        controls.estop(False)
        controls.close()
    assert run.returncode == 1, err
    fault = _the_fault(tmp_path, "estop")
    assert "e-stop button" in (fault.text or "")
    assert state.estop_button == 1 and not state.enabled


def test_a_goal_that_stops_short_is_a_fault_naming_the_joint(tmp_path: Path) -> None:
    master = shared_master()
    with sim_baxter(master):
        controls = SimControls(master)
        controls.stall(STALL_RAD)
        time.sleep(0.5)  # the latched stall reached the node
        run = _execute(master, tmp_path, "--speed-ratio", "1.0")
        out, err = run.communicate(timeout=300)
        controls.stall(0.0)
        time.sleep(0.3)
        controls.close()
    assert run.returncode == 1, err
    fault = _the_fault(tmp_path, "off-goal")
    robot = fault.evidence.robot if fault.evidence else None
    assert robot is not None and robot.off_rad > GOAL_TOLERANCE_RAD
    assert f"{STALL_RAD:.3f} rad" in (fault.text or "") or "rad from the end" in (fault.text or "")
    assert any(f"_{j}" in (fault.text or "") for j in ("s0", "s1", "e0", "e1", "w0", "w1", "w2"))
