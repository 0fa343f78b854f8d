"""A session as an MCAP file of ROS 2 messages, which Foxglove opens
(`tandem sessions export ID --format mcap`).

Topics, each message stamped with its event's time (seconds since the epoch):

- `/joint_states` (sensor_msgs/msg/JointState): the moving arm's 7 joints along
  each motion: as the robot reported them when a robot made it (the evidence's
  `robot` states, from the event's start), else at each waypoint of the motion
  (the re-targeted motion when the execution made one, else the plan node's),
  the waypoints spread by a `WaypointTimes` (by default evenly over the event's
  own start and end when the motion took time, else from the event's time to
  the next event's);
- `/tf` (tf2_msgs/msg/TFMessage): every part's pose in the `bench` frame as each
  step leaves it (at the end of the step's motion), when the caller can place
  parts (`PartsAt`: the world's geometry lives above the store);
- `/camera/image/compressed` (sensor_msgs/msg/CompressedImage): the stored camera
  frames that decided answers (JPEG);
- `/rosout` (rcl_interfaces/msg/Log): one line per event;
- `/speech` (rcl_interfaces/msg/Log): the robot's spoken lines (`robot`) and the
  words the voice heard (`human`), in that order at an event.

The session's record is the file's metadata and the plan(s) it ran are attached
as JSON, so the file stands alone.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import IO, Any

from mcap_ros2.writer import Writer

from app.execution.events import REPAIR, ExecutionEvent, describe, is_step
from app.execution.evidence import RobotMotion
from app.sessions.ros_messages import (
    COMPRESSED_IMAGE,
    DEFINITIONS,
    INFO,
    JOINT_STATE,
    LOG,
    TF_MESSAGE,
    WARN,
    nanoseconds,
    stamp,
)
from app.sessions.store import SessionRecord, SessionStore, canonical_json
from planner.plan.model import Motion, Plan

JOINT_TOPIC = "/joint_states"
TF_TOPIC = "/tf"
CAMERA_TOPIC = "/camera/image/compressed"
EVENTS_TOPIC = "/rosout"
SPEECH_TOPIC = "/speech"
BENCH_FRAME = "bench"
CAMERA_FRAME = "camera"
# A motion with no event after it (the session stopped during it) is spread over
# this long.
LAST_MOTION_S = 1.0
# Events that say something went other than planned are logged as warnings.
WARNING_KINDS = frozenset(
    {"interrupted", "repair", "too-long", "fell-back", "own-voice", "robot-fault"}
)

# The parts' box centres (x, y, z in metres, bench frame) as node `node` of `plan`
# leaves them.
PartsAt = Callable[[Plan, str], Mapping[str, tuple[float, float, float]]]
# The time (epoch seconds) of each waypoint of `motion`, run at `event`; `next_time`
# is the time of the event after it (None for the last event).
WaypointTimes = Callable[[ExecutionEvent, Motion, float | None], Sequence[float]]


def even_waypoint_times(
    event: ExecutionEvent, motion: Motion, next_time: float | None
) -> list[float]:
    """The waypoints spread evenly from the event's time to the next event's."""
    end = next_time if next_time is not None else event.time + LAST_MOTION_S
    count = len(motion.path)
    if count < 2 or end <= event.time:
        return [event.time] * count
    step = (end - event.time) / (count - 1)
    return [event.time + i * step for i in range(count)]


def session_waypoint_times(
    event: ExecutionEvent, motion: Motion, next_time: float | None
) -> list[float]:
    """Evenly over the event's own start and end when its motion took time (a timed
    session), else `even_waypoint_times`."""
    start, end = event.start, event.end
    count = len(motion.path)
    if start is None or end is None or end <= start or count < 2:
        return even_waypoint_times(event, motion, next_time)
    step = (end - start) / (count - 1)
    return [start + i * step for i in range(count)]


@dataclass(frozen=True)
class SessionRun:
    """A stored session with what the export needs: its events (with their pictures)
    and the plan each event ran on (a repair changes plans)."""

    record: SessionRecord
    events: list[ExecutionEvent]
    plans: list[Plan]

    @classmethod
    def load(cls, store: SessionStore, session_id: int) -> SessionRun:
        record = store.get(session_id)
        events = store.events(session_id, with_jpeg=True)
        current = store.plan(record.plan_hash)
        plans: list[Plan] = []
        for event in events:
            plans.append(current)
            replanned = event.evidence.replanned if event.evidence is not None else None
            if event.kind == REPAIR and replanned is not None:
                current = store.plan(replanned.plan)
        return cls(record, events, plans)

    def motion(self, k: int) -> Motion | None:
        """The arm motion event `k` played, if any."""
        event = self.events[k]
        if event.kind != "actuation":
            return None
        retargeted = event.evidence.retargeted if event.evidence is not None else None
        if retargeted is not None and retargeted.motion is not None:
            return retargeted.motion
        node = self.plans[k].nodes.get(event.node)
        return None if node is None else node.motion


class McapSession:
    """Writes one session's messages; `counts` tells how many went to each topic."""

    def __init__(self, out: IO[bytes]) -> None:
        self.writer = Writer(out)
        self.schemas = {
            name: self.writer.register_msgdef(name, text) for name, text in DEFINITIONS.items()
        }
        self.counts: Counter[str] = Counter()

    def write(self, topic: str, schema: str, message: dict[str, Any], t: float) -> None:
        self.writer.write_message(
            topic,
            self.schemas[schema],
            message,
            log_time=nanoseconds(t),
            sequence=self.counts[topic],
        )
        self.counts[topic] += 1

    def finish(self) -> None:
        self.writer.finish()  # type: ignore[no-untyped-call]  # mcap_ros2 leaves it untyped


def write_session(
    out: IO[bytes],
    run: SessionRun,
    *,
    parts_at: PartsAt | None = None,
    waypoint_times: WaypointTimes = session_waypoint_times,
) -> dict[str, int]:
    """Writes `run` to `out` as MCAP; the number of messages per topic."""
    mcap = McapSession(out)
    _describe_session(mcap, run)
    for k, event in enumerate(run.events):
        next_time = run.events[k + 1].time if k + 1 < len(run.events) else None
        motion = run.motion(k)
        settled = event.time
        robot = event.evidence.robot if event.evidence is not None else None
        if robot is not None and robot.states:
            settled = _write_robot(mcap, robot, event)
        elif motion is not None and motion.path:
            times = waypoint_times(event, motion, next_time)
            _write_motion(mcap, motion, times)
            settled = times[-1]
        if parts_at is not None and is_step(event) and event.node in run.plans[k].nodes:
            _write_parts(mcap, parts_at(run.plans[k], event.node), settled)
        _write_event(mcap, event)
    mcap.finish()
    return dict(mcap.counts)


def _describe_session(mcap: McapSession, run: SessionRun) -> None:
    record = run.record
    mcap.writer.add_metadata(
        "tandem-session",
        {key: "" if value is None else str(value) for key, value in record.to_json().items()},
    )
    seen: set[int] = set()
    for plan in run.plans or []:
        if id(plan) in seen:
            continue
        seen.add(id(plan))
        t = nanoseconds(record.started)
        mcap.writer.add_attachment(
            t, t, f"plan-{len(seen)}.json", "application/json", canonical_json(plan).encode()
        )


def _write_motion(mcap: McapSession, motion: Motion, times: Sequence[float]) -> None:
    for q, t in zip(motion.path, times, strict=True):
        _write_joints(mcap, motion.joints, q, t)


def _write_robot(mcap: McapSession, robot: RobotMotion, event: ExecutionEvent) -> float:
    """The robot's own joint states along the motion; the time of the last."""
    began = event.start if event.start is not None else event.time - robot.states[-1][0]
    for t, q in robot.states:
        _write_joints(mcap, robot.joints, q, began + t)
    return began + robot.states[-1][0]


def _write_joints(mcap: McapSession, names: Sequence[str], q: Sequence[float], t: float) -> None:
    message = {
        "header": {"stamp": stamp(t), "frame_id": ""},
        "name": list(names),
        "position": list(q),
        "velocity": [],
        "effort": [],
    }
    mcap.write(JOINT_TOPIC, JOINT_STATE, message, t)


def _write_parts(
    mcap: McapSession, parts: Mapping[str, tuple[float, float, float]], t: float
) -> None:
    transforms = [
        {
            "header": {"stamp": stamp(t), "frame_id": BENCH_FRAME},
            "child_frame_id": part,
            "transform": {
                "translation": {"x": x, "y": y, "z": z},
                "rotation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0},
            },
        }
        for part, (x, y, z) in sorted(parts.items())
    ]
    mcap.write(TF_TOPIC, TF_MESSAGE, {"transforms": transforms}, t)


def _write_event(mcap: McapSession, event: ExecutionEvent) -> None:
    evidence = event.evidence
    if evidence is not None and evidence.jpeg is not None:
        picture = {
            "header": {"stamp": stamp(event.time), "frame_id": CAMERA_FRAME},
            "format": "jpeg",
            "data": evidence.jpeg,
        }
        mcap.write(CAMERA_TOPIC, COMPRESSED_IMAGE, picture, event.time)
    level = WARN if event.kind in WARNING_KINDS else INFO
    mcap.write(EVENTS_TOPIC, LOG, _log(event, "tandem", level, event_line(event)), event.time)
    for who, words in spoken_lines(event):
        mcap.write(SPEECH_TOPIC, LOG, _log(event, who, INFO, words), event.time)


def spoken_lines(event: ExecutionEvent) -> list[tuple[str, str]]:
    """Who spoke at `event` and the words: the robot's line (a question asked by the
    voice is the event's text), then what the voice heard."""
    evidence = event.evidence
    if evidence is None:
        return []
    lines: list[tuple[str, str]] = []
    if evidence.spoken is not None:
        lines.append(("robot", evidence.spoken.said))
    elif evidence.voice is not None and evidence.voice.engine != "none" and event.text:
        lines.append(("robot", event.text))
    if evidence.voice is not None and evidence.voice.heard:
        lines.append(("human", evidence.voice.heard))
    return lines


def event_line(event: ExecutionEvent) -> str:
    """An event in one line: the node, what ran, how it turned out and who said so."""
    what = str(event.action) if event.action is not None else event.kind
    line = f"{event.node} {what}"
    if event.outcome is not None:
        line += f" -> {describe(event.action, event.outcome)} ({event.source})"
    if event.text:
        line += f": {event.text}"
    return line


def _log(event: ExecutionEvent, name: str, level: int, text: str) -> dict[str, Any]:
    return {
        "stamp": stamp(event.time),
        "level": level,
        "name": name,
        "msg": text,
        "file": event.node,
        "function": event.kind,
        "line": event.seq,
    }
