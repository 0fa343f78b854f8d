"""One of Baxter's grippers, driven as Rethink's `baxter_interface.Gripper` drives it.

The gripper says what it is: `/robot/end_effector/<side>_gripper/state`
(EndEffectorState: its hardware id, calibrated, ready, moving, gripping, error,
position 0 closed - 100 open) and `.../properties` (EndEffectorProperties: its
`ui_type`, electric or suction). Every command carries the id read from the
state (the firmware ignores any other) and a sender and sequence the state
echoes back once the command was handled.

- An electric gripper is calibrated (`calibrate`) before its first move, and
  again after an error (a `reset` first, as `Gripper.calibrate` does). Closing
  and opening are `go` with `{"position": 0}` or `{"position": 100}`; the move
  is done when the fingers are within the gripper's dead zone of the position,
  or grip something on the way.
- A suction cup closes with `go` and `{"grip_attempt_seconds": ...}` (Rethink's
  `command_suction`) and opens with `release` (its `stop`).
- A gripper that is absent, of another kind, or does not do its command within
  `MOVE_WAIT_S` is a `gripper` fault.
"""

from __future__ import annotations

import importlib
import json
import threading
import time
from collections.abc import Callable
from typing import Any

from app.execution.robot_link import GripperCommand, RobotFault, Side
from app.robot.link_state import until

STATE_WAIT_S = 5.0  # as long as Gripper waits for the state and the properties
CALIBRATE_WAIT_S = 5.0  # Gripper.calibrate's timeout
MOVE_WAIT_S = 5.0  # Gripper.command_position's timeout
DEAD_ZONE = 5.0  # Gripper's default dead_zone (percent of the travel)
GRIP_ATTEMPT_S = 5.0  # how long a suction cup sucks for a grasp (Gripper's default)
# EndEffectorProperties.ui_type, and what Tandem can do with each.
KINDS = {0: "none", 1: "suction", 2: "electric", 3: "custom"}


class Gripper:
    """One side's gripper behind ROS (see the module's text)."""

    def __init__(self, rospy: Any, side: Side) -> None:
        self.side = side
        self._rospy = rospy
        self._baxter = importlib.import_module("baxter_core_msgs.msg")
        self._lock = threading.Lock()
        self._state: Any = None
        self._kind: str | None = None
        self._sequence = 0
        self.calibrations = 0  # calibrate commands sent (once, and after errors)
        prefix = f"/robot/end_effector/{side}_gripper"
        self._command = rospy.Publisher(
            f"{prefix}/command", self._baxter.EndEffectorCommand, queue_size=10
        )
        self._subscribers = [
            rospy.Subscriber(f"{prefix}/state", self._baxter.EndEffectorState, self._on_state),
            rospy.Subscriber(
                f"{prefix}/properties", self._baxter.EndEffectorProperties, self._on_properties
            ),
        ]

    def _on_state(self, message: Any) -> None:
        with self._lock:
            self._state = message

    def _on_properties(self, message: Any) -> None:
        with self._lock:
            self._kind = KINDS.get(int(message.ui_type), "custom")

    @property
    def kind(self) -> str | None:
        """electric, suction, custom, none; None until the properties came."""
        with self._lock:
            return self._kind

    def _now(self) -> Any:
        with self._lock:
            return self._state

    def wait(self, timeout_s: float = STATE_WAIT_S) -> None:
        """Until the state and the properties came (RobotFault `gripper` if not)."""
        if not until(lambda: self._now() is not None and self.kind is not None, timeout_s):
            raise RobotFault(
                "gripper", f"the {self.side} gripper publishes no state and properties"
            )

    def prepare(self) -> None:
        """Calibrates an electric gripper not calibrated yet (or in error)."""
        self.wait()
        state = self._now()
        if self.kind == "electric" and (state.calibrated != 1 or state.error == 1):
            self._calibrate()

    def do(self, command: GripperCommand) -> None:
        """Closes (`grip`) or opens (`release`) the gripper and waits until it did."""
        self.wait()
        kind = self.kind
        if kind == "electric":
            self.prepare()
            position = 0.0 if command == "grip" else 100.0
            done = self._send("go", {"position": position}, lambda s: _at(s, position))
        elif kind == "suction":
            if command == "grip":
                done = self._send(
                    "go", {"grip_attempt_seconds": GRIP_ATTEMPT_S}, lambda s: s.error != 1
                )
            else:
                done = self._send("release", None, lambda s: s.error != 1)
        else:
            line = f"the {self.side} arm has no gripper Tandem drives ({kind})"
            raise RobotFault("gripper", line)
        if not done:
            raise RobotFault("gripper", self._failed(command))

    def _failed(self, command: GripperCommand) -> str:
        state = self._now()
        what = "close" if command == "grip" else "open"
        if state is not None and state.error == 1:
            return f"the {self.side} gripper is in error after its command to {what}"
        return f"the {self.side} gripper did not {what} within {MOVE_WAIT_S:.0f} s"

    def _calibrate(self) -> None:
        if self._now().error == 1:
            self._send("reset", None, lambda s: s.error != 1 and s.ready == 1)
        self.calibrations += 1
        calibrated = self._send(
            "calibrate", None, lambda s: s.calibrated == 1 and s.ready == 1, CALIBRATE_WAIT_S
        )
        if not calibrated:
            raise RobotFault("gripper", f"the {self.side} gripper did not calibrate")

    def _send(
        self, command: str, args: dict[str, float] | None, done: Callable[[Any], bool],
        timeout_s: float = MOVE_WAIT_S,
    ) -> bool:  # fmt: skip
        """Publishes `command` (again until the state acknowledges it), then waits for
        `done(state)`: whether it came within `timeout_s`."""
        self._sequence = self._sequence % 0x7FFFFFFF + 1
        sender = f"{self._rospy.get_name()}_{command}"
        message = self._baxter.EndEffectorCommand(
            id=int(self._now().id), command=command, args=json.dumps(args) if args else "",
            sender=sender, sequence=self._sequence,
        )  # fmt: skip
        sequence = self._sequence

        def handled() -> bool:
            state = self._now()
            return bool(state.command_sender == sender and state.command_sequence == sequence)

        deadline = time.monotonic() + timeout_s
        if not until(handled, timeout_s, lambda: self._command.publish(message)):
            return False
        left = max(0.5, deadline - time.monotonic())
        return until(lambda: not self._now().moving and done(self._now()), left)

    def close(self) -> None:
        self._command.unregister()
        for subscriber in self._subscribers:
            subscriber.unregister()


def _at(state: Any, position: float) -> bool:
    """A move done: the fingers within the dead zone of `position`, or gripping."""
    return bool(abs(state.position - position) < DEAD_ZONE or state.gripping == 1)
