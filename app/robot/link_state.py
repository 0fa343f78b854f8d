"""Baxter's enable state, as the robot publishes it and Rethink's RobotEnable reads it.

`/robot/state` (baxter_core_msgs/AssemblyState) says whether the robot is
enabled and whether it is stopped (an e-stop: its red button, a joint fault, a
lapse of its brain's heartbeat, or a stop from software). Rethink's trajectory
action server does not refuse a goal on a disabled robot: with its default goal
tolerance it reports success without moving. So the link reads the state
itself: it refuses a motion on a robot that is not enabled or is stopped, and
faults a motion during which it became so.

`enable` does what Rethink's `RobotEnable.enable` does: a stopped robot is
reset first (`/robot/set_super_reset`; impossible while the e-stop button is
pressed), then `/robot/set_super_enable` is published until the state says
enabled.
"""

from __future__ import annotations

import importlib
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from app.execution.robot_link import RobotFault

STATE_TOPIC = "/robot/state"
STATE_WAIT_S = 2.0  # as long as RobotEnable waits for the first state
ENABLE_WAIT_S = 2.0  # RobotEnable's time to enable
RESET_WAIT_S = 3.0  # RobotEnable's time to reset
REPUBLISH_S = 0.1
# AssemblyState's estop_button and estop_source, in words.
BUTTON_PRESSED = 1
SOURCES = {0: "", 1: "its e-stop button", 2: "an unknown source", 3: "a joint fault",
           4: "a lapse of its brain's heartbeat"}  # fmt: skip


@dataclass(frozen=True)
class RobotState:
    """What `/robot/state` said last."""

    enabled: bool
    stopped: bool
    error: bool
    estop_button: int
    estop_source: int

    def fault(self, during: bool) -> RobotFault | None:
        """Why the robot would not move (`during` a motion: why it stopped moving);
        None when it is enabled and not stopped."""
        if self.stopped:
            by = SOURCES.get(self.estop_source, "")
            pressed = " (e-stop button pressed)" if self.estop_button == BUTTON_PRESSED else ""
            line = "the robot was stopped" + (f" by {by}" if by else "") + pressed
            if during:
                return RobotFault("estop", line + " during the motion")
            return RobotFault("estop", line + ": release the e-stop, then reset and enable it")
        if not self.enabled:
            if during:
                return RobotFault("disabled", "the robot was disabled during the motion")
            return RobotFault(
                "disabled", "the robot is disabled: enable it (`--enable`, or "
                "`rosrun baxter_tools enable_robot.py -e`) and run again",
            )  # fmt: skip
        return None


class StateWatch:
    """`/robot/state` as it comes (a rospy subscriber), and the robot's enabling."""

    def __init__(self, rospy: Any) -> None:
        self._rospy = rospy
        self._baxter = importlib.import_module("baxter_core_msgs.msg")
        self._std = importlib.import_module("std_msgs.msg")
        self._lock = threading.Lock()
        self._state: RobotState | None = None
        self._subscriber = rospy.Subscriber(
            STATE_TOPIC, self._baxter.AssemblyState, self._on_state, queue_size=10
        )

    def _on_state(self, message: Any) -> None:
        state = RobotState(
            bool(message.enabled), bool(message.stopped), bool(message.error),
            int(message.estop_button), int(message.estop_source),
        )  # fmt: skip
        with self._lock:
            self._state = state

    @property
    def state(self) -> RobotState | None:
        with self._lock:
            return self._state

    def wait(self, timeout_s: float = STATE_WAIT_S) -> RobotState:
        """The first state (RobotFault `silent` when none comes in `timeout_s`)."""
        if not until(lambda: self.state is not None, timeout_s):
            raise RobotFault("silent", f"the robot publishes no state on {STATE_TOPIC}")
        assert self.state is not None
        return self.state

    def fault(self, during: bool = False) -> RobotFault | None:
        state = self.state
        return state.fault(during) if state is not None else None

    def enable(self) -> None:
        """Enables the robot as RobotEnable does (see the module's text), or raises
        RobotFault saying why it could not."""
        state = self.wait()
        if state.stopped:
            if state.estop_button == BUTTON_PRESSED:
                raise RobotFault("estop", "cannot enable the robot: its e-stop button is pressed")
            reset = self._rospy.Publisher("/robot/set_super_reset", self._std.Empty, queue_size=10)
            done = until(lambda: _is_reset(self.state), RESET_WAIT_S, lambda: reset.publish())
            reset.unregister()
            if not done:
                raise RobotFault("estop", "the robot did not reset from its stop")
        enable = self._rospy.Publisher("/robot/set_super_enable", self._std.Bool, queue_size=10)
        done = until(
            lambda: bool(self.state and self.state.enabled), ENABLE_WAIT_S,
            lambda: enable.publish(self._std.Bool(data=True)),
        )  # fmt: skip
        enable.unregister()
        if not done:
            raise RobotFault("disabled", f"the robot did not enable within {ENABLE_WAIT_S:.0f} s")

    def close(self) -> None:
        self._subscriber.unregister()


def _is_reset(state: RobotState | None) -> bool:
    return state is not None and not state.stopped and not state.enabled


def until(
    test: Callable[[], bool], timeout_s: float, body: Callable[[], object] | None = None
) -> bool:
    """Whether `test()` came true within `timeout_s`, calling `body()` between tries (a
    command published again until the robot acknowledges it, as Rethink's code does)."""
    deadline = time.monotonic() + timeout_s
    while True:
        if test():
            return True
        if time.monotonic() > deadline:
            return False
        if body is not None:
            body()
        time.sleep(REPUBLISH_S if body is not None else REPUBLISH_S / 5)
