"""A session as an MCAP file of ROS 2 messages, which Foxglove opens
(`tandem sessions export ID --format mcap`, the review's download).

Topics, each message stamped with its time (seconds since the epoch):

- `/robot_description` (std_msgs/msg/String) and `/tf_static`
  (tf2_msgs/msg/TFMessage): the robot's URDF and where its `base` frame stands
  in the `bench` frame, once at the session's start, as a ROS robot publishes
  them (latched), when the caller gives the robot (`RobotModel`). Foxglove's 3D
  panel draws a robot from this topic; it reads no URDF from an attachment;
- `/joint_states` (sensor_msgs/msg/JointState): the moving arm's 7 joints along
  each motion, at the motion's own times: as the robot reported them when a
  robot made it (the evidence's `robot` states, from the event's start), else at
  each waypoint of the motion (the re-targeted motion when the execution made
  one, else the plan node's), the waypoints spread by a `WaypointTimes`: over the
  event's stored start and end, in proportion to how long each segment of the
  path takes (the robot model's timing) or evenly without one; in a session
  stored untimed, from the event's time to the next event's;
- `/tf` (tf2_msgs/msg/TFMessage): every part's pose in the `bench` frame as each
  step leaves it (at the end of the step's motion), when the caller can place
  parts (`PartsAt`: the world's geometry lives above the store);
- `/camera/image/compressed` (sensor_msgs/msg/CompressedImage): the stored camera
  frames that decided answers (JPEG);
- `/rosout` (rcl_interfaces/msg/Log): a line per event when it is recorded (its
  end), and in a timed session one when it started and one when the robot began
  waiting for the human (`wait_start`), each naming the event by its `seq`;
- `/speech` (rcl_interfaces/msg/Log): the robot's spoken lines (`robot`, when its
  step began) and the words the voice heard (`human`, when the answer was taken).

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
    STRING,
    TF_MESSAGE,
    WARN,
    nanoseconds,
    quaternion_of_yaw,
    stamp,
)
from app.sessions.store import SessionRecord, SessionStore, canonical_json
from planner.plan.model import Motion, Plan

JOINT_TOPIC = "/joint_states"
TF_TOPIC = "/tf"
TF_STATIC_TOPIC = "/tf_static"
ROBOT_DESCRIPTION_TOPIC = "/robot_description"
CAMERA_TOPIC = "/camera/image/compressed"
EVENTS_TOPIC = "/rosout"
SPEECH_TOPIC = "/speech"
BENCH_FRAME = "bench"
ROBOT_BASE_FRAME = "base"  # the root link of Baxter's URDF
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
# How long each segment of a joint path takes (seconds), given the joints' names
# (app.execution.timing.segment_seconds: the time the execution gives a motion).
SegmentSeconds = Callable[[Sequence[str], Sequence[Sequence[float]]], Sequence[float]]


@dataclass(frozen=True)
class RobotModel:
    """The robot as the caller can load it: its URDF, where its base frame stands in
    the bench frame (x, y in metres, yaw in radians), and how long each segment of
    a joint path takes."""

    description: str
    base_pose: tuple[float, float, float]
    segment_seconds: SegmentSeconds


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


def timed_waypoint_times(segment_seconds: SegmentSeconds) -> WaypointTimes:
    """Waypoint times over the event's own start and end, each segment taking its
    share of that time in proportion to how long `segment_seconds` says it takes (a
    segment whose joints turn far takes longer); `session_waypoint_times` where
    there is no duration to share."""

    def times(event: ExecutionEvent, motion: Motion, next_time: float | None) -> list[float]:
        start, end = event.start, event.end
        if start is None or end is None or end <= start or len(motion.path) < 2:
            return session_waypoint_times(event, motion, next_time)
        segments = list(segment_seconds(motion.joints, motion.path))
        total = sum(segments)
        if total <= 0.0:
            return session_waypoint_times(event, motion, next_time)
        out, elapsed = [start], 0.0
        for seconds in segments[:-1]:
            elapsed += seconds
            out.append(start + (end - start) * elapsed / total)
        return [*out, end]  # the last at the end itself, not a sum's rounding

    return times


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
    robot: RobotModel | None = None,
    waypoint_times: WaypointTimes | None = None,
) -> dict[str, int]:
    """Writes `run` to `out` as MCAP; the number of messages per topic. The waypoints'
    times are `waypoint_times`' when given, else timed by `robot`'s segments."""
    mcap = McapSession(out)
    _describe_session(mcap, run)
    if robot is not None:
        _describe_robot(mcap, robot, session_start(run))
    if waypoint_times is None:
        timed = None if robot is None else timed_waypoint_times(robot.segment_seconds)
        waypoint_times = timed or session_waypoint_times
    for k, event in enumerate(run.events):
        next_time = run.events[k + 1].time if k + 1 < len(run.events) else None
        motion = run.motion(k)
        settled = event.time
        made = event.evidence.robot if event.evidence is not None else None
        if made is not None and made.states:
            settled = _write_robot(mcap, made, event)
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


def session_start(run: SessionRun) -> float:
    """When the session began: its record's start, or its first event's if earlier."""
    times = [e.start if e.start is not None else e.time for e in run.events]
    return min([run.record.started, *times])


def _describe_robot(mcap: McapSession, robot: RobotModel, t: float) -> None:
    """The robot's URDF and its base in the bench frame, once (a ROS robot latches
    both)."""
    mcap.write(ROBOT_DESCRIPTION_TOPIC, STRING, {"data": robot.description}, t)
    x, y, yaw = robot.base_pose
    base = {
        "header": {"stamp": stamp(t), "frame_id": BENCH_FRAME},
        "child_frame_id": ROBOT_BASE_FRAME,
        "transform": {
            "translation": {"x": x, "y": y, "z": 0.0},
            "rotation": quaternion_of_yaw(yaw),
        },
    }
    mcap.write(TF_STATIC_TOPIC, TF_MESSAGE, {"transforms": [base]}, t)


def _write_motion(mcap: McapSession, motion: Motion, times: Sequence[float]) -> None:
    for q, t in zip(motion.path, times, strict=True):
        _write_joints(mcap, motion.joints, q, t)


def _write_robot(mcap: McapSession, robot: RobotMotion, event: ExecutionEvent) -> float:
    """The robot's own joint states along the motion; the time of the last."""
    began = robot.began if robot.began is not None else event.start
    began = began if began is not None else event.time - robot.states[-1][0]
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
    for t, level, line in log_lines(event):
        mcap.write(EVENTS_TOPIC, LOG, _log(event, "tandem", level, line, t), t)
    for who, words in spoken_lines(event):
        # The robot speaks when its step begins; the voice's words end the step.
        said = event.start if who == "robot" and event.start is not None else event.time
        t = min(said, event.time)
        mcap.write(SPEECH_TOPIC, LOG, _log(event, who, INFO, words, t), t)


def log_lines(event: ExecutionEvent) -> list[tuple[float, int, str]]:
    """The `/rosout` lines of `event` (time, level, words): when it started and when
    the robot began waiting for the human (a timed event that took time), then
    `event_line` when it was recorded."""
    lines: list[tuple[float, int, str]] = []
    what = f"{event.node} {event.action if event.action is not None else event.kind}"
    if event.start is not None and event.start < event.time:
        lines.append((event.start, INFO, f"{what} starts"))
        waited = event.wait_start
        if waited is not None and event.start <= waited < event.time:
            lines.append((waited, INFO, f"{what}: the robot waits for the human"))
    level = WARN if event.kind in WARNING_KINDS else INFO
    return [*lines, (event.time, level, event_line(event))]


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


def _log(event: ExecutionEvent, name: str, level: int, text: str, t: float) -> dict[str, Any]:
    return {
        "stamp": stamp(t),
        "level": level,
        "name": name,
        "msg": text,
        "file": event.node,
        "function": event.kind,
        "line": event.seq,
    }
