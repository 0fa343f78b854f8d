"""The simulated node's robot-level topics: `/robot/state` and its enable, stop and
reset topics, the grippers' state, properties and commands, and the drills a
test triggers (the e-stop button, a stall).

- `/robot/state` (baxter_core_msgs/AssemblyState) at `STATE_HZ`;
  `/robot/set_super_enable` (std_msgs/Bool), `/robot/set_super_stop` and
  `/robot/set_super_reset` (std_msgs/Empty) change it (`app.robot.sim_robot_state`);
- `/robot/end_effector/<side>_gripper/state` (EndEffectorState) at `STATE_HZ`,
  `.../properties` (EndEffectorProperties, latched, and again every second), and
  `.../command` (EndEffectorCommand), handled as `app.robot.sim_gripper` says;
- drills, no such topics on a real robot: `/tandem_sim/estop` (std_msgs/Bool:
  true presses the e-stop button, false releases it) and `/tandem_sim/stall`
  (std_msgs/Float64: the arm stops this many radians short of each goal's last
  point on one joint; 0 ends the stall).
"""

from __future__ import annotations

import importlib
import threading
from collections.abc import Mapping
from dataclasses import asdict
from typing import Any

from app.robot.sim_gripper import Gripper, properties
from app.robot.sim_model import Side
from app.robot.sim_robot_state import RobotState

STATE_HZ = 20.0  # /robot/state and the grippers' state
PROPERTIES_HZ = 1.0


class RobotTopics:
    """The robot state, the grippers and the drills on ROS (after `connect`)."""

    def __init__(self, state: RobotState, grippers: Mapping[Side, Gripper]) -> None:
        self.state = state
        self.grippers = grippers
        self._stall = 0.0
        self._lock = threading.Lock()
        self._ros: dict[str, Any] = {}
        self._publishers: dict[str, Any] = {}
        self._subscribers: list[Any] = []

    @property
    def stall_rad(self) -> float:
        with self._lock:
            return self._stall

    def connect(self) -> None:
        """Publishers and subscribers, on the node rospy was initialised as."""
        rospy = importlib.import_module("rospy")
        std = importlib.import_module("std_msgs.msg")
        baxter = importlib.import_module("baxter_core_msgs.msg")
        self._ros = {"rospy": rospy, "baxter": baxter}
        publish = self._publishers
        publish["state"] = rospy.Publisher("/robot/state", baxter.AssemblyState, queue_size=2)
        listen = [
            ("/robot/set_super_enable", std.Bool, lambda m: self.state.set_enabled(bool(m.data))),
            ("/robot/set_super_stop", std.Empty, lambda _: self.state.stop()),
            ("/robot/set_super_reset", std.Empty, lambda _: self._reset()),
            ("/tandem_sim/estop", std.Bool, lambda m: self.state.press_estop(bool(m.data))),
            ("/tandem_sim/stall", std.Float64, self._on_stall),
        ]
        for side in self.grippers:
            prefix = f"/robot/end_effector/{side}_gripper"
            publish[f"{side}/state"] = rospy.Publisher(
                f"{prefix}/state", baxter.EndEffectorState, queue_size=2
            )
            publish[f"{side}/properties"] = rospy.Publisher(
                f"{prefix}/properties", baxter.EndEffectorProperties, queue_size=2, latch=True
            )
            listen.append(
                (f"{prefix}/command", baxter.EndEffectorCommand, self._on_command_for(side))
            )
        self._subscribers = [
            rospy.Subscriber(topic, kind, callback, queue_size=10)
            for topic, kind, callback in listen
        ]

    def _reset(self) -> None:
        if not self.state.reset():
            self._ros["rospy"].logwarn("reset refused: the e-stop button is pressed")

    def _on_stall(self, message: Any) -> None:
        with self._lock:
            self._stall = abs(float(message.data))

    def _on_command_for(self, side: Side) -> Any:
        def on_command(message: Any) -> None:
            gripper = self.grippers[side]
            did = gripper.handle(
                int(message.id),
                str(message.command),
                str(message.args),
                str(message.sender),
                int(message.sequence),
            )
            if did.startswith(("ignored", "refused")):
                self._ros["rospy"].logwarn("%s gripper: %s", side, did)

        return on_command

    def publish_state(self) -> None:
        """The robot's and the grippers' state, now."""
        rospy, baxter = self._ros["rospy"], self._ros["baxter"]
        self._publishers["state"].publish(baxter.AssemblyState(**asdict(self.state.fields())))
        now = rospy.Time.now()
        for side, gripper in self.grippers.items():
            self._publishers[f"{side}/state"].publish(
                baxter.EndEffectorState(timestamp=now, **gripper.state())
            )

    def publish_properties(self) -> None:
        baxter = self._ros["baxter"]
        for side, gripper in self.grippers.items():
            fields = asdict(properties(gripper.kind))
            self._publishers[f"{side}/properties"].publish(baxter.EndEffectorProperties(**fields))

    def close(self) -> None:
        for subscriber in self._subscribers:
            subscriber.unregister()
