"""The ROS 2 message definitions a session's MCAP file uses, as ROS ships them.

ROS is not installed where sessions are exported, so each definition is written
out here in the concatenated form MCAP's `ros2msg` schemas take (the message,
then each type it uses after a line of `=`), field for field as in ROS 2's
sensor_msgs, tf2_msgs, geometry_msgs, std_msgs and rcl_interfaces.
`builtin_interfaces/Time` is known to every reader and is not repeated.
"""

from __future__ import annotations

import math

SEPARATOR = "=" * 80

HEADER = """builtin_interfaces/Time stamp
string frame_id"""

VECTOR3 = """float64 x
float64 y
float64 z"""

QUATERNION = """float64 x 0
float64 y 0
float64 z 0
float64 w 1"""

TRANSFORM = """Vector3 translation
Quaternion rotation"""

TRANSFORM_STAMPED = """std_msgs/Header header
string child_frame_id
Transform transform"""


def _definition(own: str, *used: tuple[str, str]) -> str:
    parts = [own]
    for name, text in used:
        parts += [SEPARATOR, f"MSG: {name}", text]
    return "\n".join(parts) + "\n"


JOINT_STATE = "sensor_msgs/msg/JointState"
TF_MESSAGE = "tf2_msgs/msg/TFMessage"
COMPRESSED_IMAGE = "sensor_msgs/msg/CompressedImage"
LOG = "rcl_interfaces/msg/Log"
STRING = "std_msgs/msg/String"

DEFINITIONS: dict[str, str] = {
    JOINT_STATE: _definition(
        """std_msgs/Header header
string[] name
float64[] position
float64[] velocity
float64[] effort""",
        ("std_msgs/Header", HEADER),
    ),
    TF_MESSAGE: _definition(
        "geometry_msgs/TransformStamped[] transforms",
        ("geometry_msgs/TransformStamped", TRANSFORM_STAMPED),
        ("std_msgs/Header", HEADER),
        ("geometry_msgs/Transform", TRANSFORM),
        ("geometry_msgs/Vector3", VECTOR3),
        ("geometry_msgs/Quaternion", QUATERNION),
    ),
    COMPRESSED_IMAGE: _definition(
        """std_msgs/Header header
string format
uint8[] data""",
        ("std_msgs/Header", HEADER),
    ),
    LOG: _definition(
        """byte DEBUG=10
byte INFO=20
byte WARN=30
byte ERROR=40
byte FATAL=50
builtin_interfaces/Time stamp
uint8 level
string name
string msg
string file
string function
uint32 line"""
    ),
    STRING: _definition("string data"),
}

# rcl_interfaces/msg/Log levels
INFO = 20
WARN = 30


def stamp(t: float) -> dict[str, int]:
    """A builtin_interfaces/Time of epoch seconds `t`."""
    ns = round(t * 1e9)
    return {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}


def nanoseconds(t: float) -> int:
    """Epoch seconds as MCAP's log time (nanoseconds)."""
    return round(t * 1e9)


def quaternion_of_yaw(yaw: float) -> dict[str, float]:
    """A geometry_msgs/Quaternion turning by `yaw` radians about z."""
    return {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2), "w": math.cos(yaw / 2)}
