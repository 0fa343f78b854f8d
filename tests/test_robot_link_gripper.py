"""The grippers driven as Rethink's Gripper drives them, on a real roscore and the
simulated Baxter node (which, as the firmware, ignores a command carrying
another gripper's id, refuses `go` before `calibrate`, and moves an electric
gripper's fingers only on `go`).

What the gripper did is read from its own `/state` along a whole
`tandem execute --robot ros` run: the commands it handled (echoed in the
state), and where its fingers went.
"""

from __future__ import annotations

import importlib
import subprocess
import sys
import threading
from pathlib import Path
from typing import Any

import pytest

from app.robot.ros_env import RosMaster
from app.sessions.store import SessionStore
from tests.robot_graph import ROOT, ros_installed, ros_node, shared_master, sim_baxter

pytestmark = pytest.mark.skipif(not ros_installed(), reason="ROS 1 is not installed: make robot")


class GripperStates:
    """Every state both grippers published: side -> [(command, sequence, position,
    gripping, error, calibrated)]."""

    def __init__(self, master: RosMaster) -> None:
        rospy = ros_node(master)
        state = importlib.import_module("baxter_core_msgs.msg").EndEffectorState
        self._lock = threading.Lock()
        self.seen: dict[str, list[tuple[str, int, float, int, int, int]]] = {
            "left": [], "right": []
        }  # fmt: skip
        self._subscribers = [
            rospy.Subscriber(
                f"/robot/end_effector/{side}_gripper/state",
                state,
                lambda m, s=side: self._on(s, m),
                queue_size=100,
            )  # fmt: skip
            for side in self.seen
        ]

    def _on(self, side: str, m: Any) -> None:
        with self._lock:
            self.seen[side].append(
                (m.command, m.command_sequence, m.position, m.gripping, m.error, m.calibrated)
            )

    def handled(self, side: str) -> list[str]:
        """The commands the gripper handled, in order (each once)."""
        with self._lock:
            states = list(self.seen[side])
        out: list[str] = []
        last: tuple[str, int] | None = None
        for command, sequence, *_ in states:
            if command and (command, sequence) != last:
                out.append(command)
                last = (command, sequence)
        return out

    def close(self) -> None:
        for subscriber in self._subscribers:
            subscriber.unregister()


def _run(master: RosMaster, data: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "app.cli", "execute", "default.toml", "--responses", "random",
         "--seed", "1", "--robot", f"ros:{master.uri}", "--speed-ratio", "1.0",
         "--data-dir", str(data)],
        cwd=ROOT, env=master.env(), capture_output=True, text=True, timeout=300,
        stdin=subprocess.DEVNULL,
    )  # fmt: skip


def _grips(data: Path) -> list[tuple[str, str]]:
    """(arm, grip|release) of each hold and unhold the run made, in order."""
    with SessionStore(data, read_only=True) as store:
        session = store.list_sessions()[0]
        events = store.events(session.id)
    out = []
    for e in events:
        robot = e.evidence.robot if e.evidence else None
        action = type(e.action).__name__ if e.action is not None else ""
        if e.kind == "actuation" and robot is not None and action in ("Hold", "Unhold"):
            out.append((robot.arm, "grip" if action == "Hold" else "release"))
    return out


def test_an_electric_gripper_is_calibrated_once_then_moved_with_go(tmp_path: Path) -> None:
    master = shared_master()
    with sim_baxter(master):
        states = GripperStates(master)
        done = _run(master, tmp_path)
        states.close()
    assert done.returncode == 0, done.stderr
    grips = _grips(tmp_path)
    assert grips, "the default plan holds and releases parts"
    for side in {arm for arm, _ in grips}:
        handled = [c for c in states.handled(side) if c != "configure"]
        # Calibrated once, before any move; then one `go` per hold or unhold of that arm.
        assert handled[0] == "calibrate" and handled.count("calibrate") == 1, handled
        assert handled[1:] == ["go"] * sum(arm == side for arm, _ in grips), handled
        seen = states.seen[side]
        assert not any(error for *_, error, _ in seen)  # never refused
        assert any(gripping for *_, gripping, _, _ in seen)  # closed on a part
    last_release = [arm for arm, what in grips if what == "release"]
    for side in last_release[-1:]:
        assert states.seen[side][-1][2] > 95.0  # opened at the end


def test_a_suction_gripper_sucks_with_go_and_opens_with_release(tmp_path: Path) -> None:
    master = shared_master()
    with sim_baxter(master, options=("--gripper", "suction")):
        states = GripperStates(master)
        done = _run(master, tmp_path)
        states.close()
    assert done.returncode == 0, done.stderr
    grips = _grips(tmp_path)
    for side in {arm for arm, _ in grips}:
        handled = states.handled(side)
        assert "calibrate" not in handled  # a suction cup has no calibration
        expected = ["go" if what == "grip" else "release" for arm, what in grips if arm == side]
        assert [c for c in handled if c in ("go", "release")] == expected, handled
