"""`tandem sessions export --format mcap|csv`: real executions, read back independently.

Two sessions of the default scenario are run headless by `tandem execute` (the
simulated camera, whose frames are stored, and the simulated voice, which speaks
with espeak-ng and hears with the real recogniser) into a temporary store. The
MCAP files are read with the `mcap` package's reader and `mcap_ros2`'s decoder
(not the writer's code) and checked, topic by topic, against the stored events,
the plan's motions and the scenario's parts; the CSV with Python's csv reader.
"""

from __future__ import annotations

import csv
import io
import json
import os
import shutil
from collections import defaultdict
from pathlib import Path
from typing import Any

import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from app.execution.events import ExecutionEvent, is_step
from app.execution.timing import segment_seconds
from app.sessions.mcap_export import SessionRun, write_session
from app.sessions.store import SessionStore
from planner.feasibility.arms import joint_names
from planner.feasibility.scene import part_boxes
from planner.plan.model import Motion, Plan
from planner.resources import scenario_path
from planner.scenario.loading import load_scenario
from planner.vocabulary import Hands
from tests.plan_fixtures import tandem

SCENARIO = scenario_path("default.toml")
OLD_STORE = Path(__file__).parent / "fixtures" / "sessions-0.1.db"
TOPIC_SCHEMAS = {
    "/joint_states": "sensor_msgs/msg/JointState",
    "/tf": "tf2_msgs/msg/TFMessage",
    "/camera/image/compressed": "sensor_msgs/msg/CompressedImage",
    "/rosout": "rcl_interfaces/msg/Log",
    "/speech": "rcl_interfaces/msg/Log",
    "/robot_description": "std_msgs/msg/String",
    "/tf_static": "tf2_msgs/msg/TFMessage",
}


class Decoded:
    """An MCAP file as read back: the decoded messages per topic (with their log
    times in ns), the schema of each topic, the metadata and the attachments."""

    def __init__(self, path: Path) -> None:
        self.messages: dict[str, list[tuple[int, Any]]] = defaultdict(list)
        self.schemas: dict[str, str] = {}
        with path.open("rb") as f:
            reader = make_reader(f, decoder_factories=[DecoderFactory()])
            self.profile = reader.get_header().profile
            for schema, channel, message, decoded in reader.iter_decoded_messages():
                assert schema is not None and channel.message_encoding == "cdr"
                self.schemas[channel.topic] = schema.name
                self.messages[channel.topic].append((message.log_time, decoded))
            self.metadata = {m.name: m.metadata for m in reader.iter_metadata()}
            self.attachments = {a.name: a.data for a in reader.iter_attachments()}


def ns(t: float) -> int:
    return round(t * 1e9)


def stamp_ns(stamp: Any) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


@pytest.fixture(scope="module")
def data_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A store with a simulated-camera session (1) and a simulated-voice one (2)."""
    folder = tmp_path_factory.mktemp("data")
    env = {**os.environ, "TANDEM_DATA_DIR": str(folder)}
    for responses in ("camera:sim", "voice:sim"):
        args = ("execute", str(SCENARIO), "--responses", responses, "--seed", "4")
        done = tandem(*args, env=env)
        assert done.returncode == 0, done.stderr
    return folder


def export(data_dir: Path, session: int, *args: str) -> Any:
    done = tandem("sessions", "export", str(session), "--data-dir", str(data_dir), *args)
    assert done.returncode == 0, done.stderr
    return done


@pytest.fixture(scope="module")
def exported(data_dir: Path) -> dict[int, Decoded]:
    out = {}
    for session in (1, 2):
        path = data_dir / f"session-{session}.mcap"
        export(data_dir, session, "--format", "mcap", "-o", str(path))
        out[session] = Decoded(path)
    return out


def stored(data_dir: Path, session: int) -> tuple[list[ExecutionEvent], SessionRun]:
    with SessionStore(data_dir, read_only=True) as store:
        return store.events(session, with_jpeg=True), SessionRun.load(store, session)


def motions(run: SessionRun) -> list[tuple[int, Motion]]:
    """Each actuation event's index and the motion its plan node holds."""
    out = []
    for k, event in enumerate(run.events):
        node = run.plans[k].nodes.get(event.node)
        if event.kind == "actuation" and node is not None and node.motion is not None:
            out.append((k, node.motion))
    return out


@pytest.mark.parametrize("session", [1, 2])
def test_topics_and_their_ros2_schemas(
    exported: dict[int, Decoded], data_dir: Path, session: int
) -> None:
    decoded = exported[session]
    assert decoded.profile == "ros2"
    expected = {"/joint_states", "/tf", "/rosout", "/robot_description", "/tf_static"}
    expected |= {"/camera/image/compressed"} if session == 1 else {"/speech"}
    assert set(decoded.schemas) == expected
    assert all(decoded.schemas[topic] == TOPIC_SCHEMAS[topic] for topic in expected)
    assert decoded.metadata["tandem-session"]["id"] == str(session)
    with SessionStore(data_dir, read_only=True) as store:
        doc = store.plan_doc(store.get(session).plan_hash)
    assert [json.loads(data) for data in decoded.attachments.values()] == [doc]


@pytest.mark.parametrize("session", [1, 2])
def test_log_lines_when_each_event_starts_waits_and_ends(
    exported: dict[int, Decoded], data_dir: Path, session: int
) -> None:
    """A line when the event is recorded (its end); before it, in these timed
    sessions, one when it started and one when the robot began waiting."""
    events, _ = stored(data_dir, session)
    logs = exported[session].messages["/rosout"]
    by_seq: dict[int, list[tuple[int, Any]]] = defaultdict(list)
    for log_time, log in logs:
        assert log_time == stamp_ns(log.stamp)
        by_seq[log.line].append((log_time, log))
    assert sorted(by_seq) == sorted(e.seq for e in events) and len(events) > 10
    started = waited = 0
    for event in events:
        lines = sorted(by_seq[event.seq], key=lambda line: line[0])
        assert all((m.file, m.function) == (event.node, event.kind) for _, m in lines)
        end_time, end = lines[-1]
        assert end_time == ns(event.time) and event.node in end.msg
        if event.outcome is not None:
            assert f"({event.source})" in end.msg
        expected = [end_time]
        assert event.start is not None  # a timed session
        if event.start < event.time:
            expected.insert(0, ns(event.start))
            assert lines[0][1].msg.endswith(" starts")
            started += 1
            wait = event.wait_start
            if wait is not None and event.start <= wait < event.time:
                expected.insert(1, ns(wait))
                assert lines[1][1].msg.endswith("the robot waits for the human")
                waited += 1
        assert [t for t, _ in lines] == expected
    assert started > 0 and len(logs) == len(events) + started + waited


@pytest.mark.parametrize("session", [1, 2])
def test_joint_states_follow_each_motion_over_its_stored_time(
    exported: dict[int, Decoded], data_dir: Path, session: int
) -> None:
    _, run = stored(data_dir, session)
    states = iter(exported[session].messages["/joint_states"])
    moved = motions(run)
    assert moved
    for k, motion in moved:
        event = run.events[k]
        # On the simulated clock every motion takes time: it runs over its event's
        # own start and end.
        start, end = event.start, event.end
        assert start is not None and end is not None and end > start
        along = [next(states) for _ in motion.path]
        assert [list(m.name) for _, m in along] == [joint_names(motion.arm)] * len(along)
        assert [list(m.position) for _, m in along] == motion.path
        times = [t for t, _ in along]
        assert times[0] == ns(start) and abs(times[-1] - ns(end)) <= 1
        assert times == sorted(times)
        # Each segment takes its share of the stored time as the execution's timing
        # model times it (on the simulated clock exactly its duration); to within
        # what epoch seconds in a float resolve (a quarter of a microsecond today).
        segments = segment_seconds(motion.joints, motion.path)
        share = (end - start) / sum(segments)
        gaps = [b - a for a, b in zip(times, times[1:], strict=False)]
        assert all(abs(g - ns(s * share)) <= 1000 for g, s in zip(gaps, segments, strict=True))
        assert all(t == stamp_ns(m.header.stamp) for t, m in along)
    assert next(states, None) is None


def test_the_parts_poses_per_step(exported: dict[int, Decoded], data_dir: Path) -> None:
    events, run = stored(data_dir, 1)
    steps = [e for e in events if is_step(e)]
    frames = exported[1].messages["/tf"]
    assert len(frames) == len(steps)
    boxes = part_boxes(load_scenario(SCENARIO))
    for event, (t, message) in zip(steps, frames, strict=True):
        assert t >= ns(event.time)
        assert {tf.child_frame_id for tf in message.transforms} == set(boxes)
        assert {tf.header.frame_id for tf in message.transforms} == {"bench"}
        assert all(stamp_ns(tf.header.stamp) == t for tf in message.transforms)
    # Before anything is done the loose parts lie where the scenario puts them.
    first = {tf.child_frame_id: tf.transform.translation for tf in frames[0][1].transforms}
    root = run.plans[0].nodes[run.plans[0].root]
    attached = Hands.of(root.state).attached
    loose = [part for part in boxes if part not in attached]
    assert loose
    for part in loose:
        assert (first[part].x, first[part].y) == pytest.approx((boxes[part].x, boxes[part].y))


def test_the_camera_frames_as_compressed_images(
    exported: dict[int, Decoded], data_dir: Path
) -> None:
    events, _ = stored(data_dir, 1)
    pictured = [e for e in events if e.evidence is not None and e.evidence.jpeg is not None]
    images = exported[1].messages["/camera/image/compressed"]
    assert len(images) == len(pictured) > 0
    for event, (t, image) in zip(pictured, images, strict=True):
        assert event.evidence is not None
        assert t == ns(event.time) and image.format == "jpeg"
        assert bytes(image.data) == event.evidence.jpeg
        assert bytes(image.data[:2]) == b"\xff\xd8"  # a JPEG's start-of-image marker


def test_the_spoken_and_heard_lines(exported: dict[int, Decoded], data_dir: Path) -> None:
    events, _ = stored(data_dir, 2)
    lines = exported[2].messages["/speech"]
    heard = [
        (ns(e.time), e.evidence.voice.heard)
        for e in events
        if e.evidence is not None and e.evidence.voice is not None
    ]
    # The robot speaks when its step begins: its recorded line, or a question the
    # voice asked aloud whose audio the event does not keep (its text).
    said = []
    for e in events:
        evidence = e.evidence
        began = ns(e.start if e.start is not None else e.time)
        if evidence is not None and evidence.spoken is not None:
            said.append((began, evidence.spoken.said))
        elif evidence is not None and evidence.voice is not None and e.text:
            if evidence.voice.engine != "none":  # asked aloud, not only on screen
                said.append((began, e.text))
    assert heard and said
    assert [(t, m.msg) for t, m in lines if m.name == "human"] == heard
    assert [(t, m.msg) for t, m in lines if m.name == "robot"] == said


def test_a_timing_model_gives_the_waypoints_times(data_dir: Path, tmp_path: Path) -> None:
    """A later timing model passes real per-waypoint times; the file carries them."""
    _, run = stored(data_dir, 1)
    path = tmp_path / "timed.mcap"

    def every_tenth_second(
        event: ExecutionEvent, motion: Motion, next_time: float | None
    ) -> list[float]:
        return [event.time + 0.1 * i for i in range(len(motion.path))]

    with path.open("wb") as out:
        write_session(out, run, waypoint_times=every_tenth_second)
    states = Decoded(path).messages["/joint_states"]
    expected = [
        ns(run.events[k].time + 0.1 * i) for k, m in motions(run) for i in range(len(m.path))
    ]
    # Read in time order: these motions outlast the headless run's events and overlap.
    assert [t for t, _ in states] == sorted(expected)
    assert "/tf" not in Decoded(path).messages  # no geometry given: no poses


@pytest.mark.parametrize("session", [1, 2])
def test_the_csv_has_one_row_per_event(data_dir: Path, session: int) -> None:
    events, _ = stored(data_dir, session)
    text = export(data_dir, session, "--format", "csv").stdout
    rows = list(csv.DictReader(io.StringIO(text)))
    assert list(rows[0]) == [
        "seq", "time", "start", "end", "wait_start", "node", "kind", "action", "outcome",
        "source", "confidence", "text",
    ]  # fmt: skip
    assert len(rows) == len(events)
    for row, event in zip(rows, events, strict=True):
        assert int(row["seq"]) == event.seq
        assert float(row["time"]) == event.time  # every digit kept
        times = (("start", event.start), ("end", event.end), ("wait_start", event.wait_start))
        for column, value in times:
            assert (None if row[column] == "" else float(row[column])) == value
        assert (row["node"], row["kind"]) == (event.node, event.kind)
        assert row["action"] == ("" if event.action is None else str(event.action))
        assert row["outcome"] == (event.outcome or "")
        assert row["source"] == (event.source or "")
        confidence = None if row["confidence"] == "" else float(row["confidence"])
        assert confidence == event.confidence
        assert row["text"] == (event.text or "")
    to_file = data_dir / f"events-{session}.csv"
    export(data_dir, session, "--format", "csv", "-o", str(to_file))
    assert to_file.read_text(encoding="utf-8") == text


def test_json_stays_the_default_and_mcap_needs_a_file(data_dir: Path) -> None:
    doc = json.loads(export(data_dir, 1).stdout)
    assert doc["format"] == "tandem-session/2" and doc["session"]["id"] == 1
    done = tandem("sessions", "export", "1", "--format", "mcap", "--data-dir", str(data_dir))
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == [done.stderr.strip()]
    assert "-o FILE" in done.stderr


def test_an_old_repaired_session_exports_its_plans_and_retargeted_motions(
    tmp_path: Path,
) -> None:
    """Session 2 of the old store changed plans after a surprise and then played
    motions re-targeted to the world's slots: those are the joint states written."""
    shutil.copy(OLD_STORE, tmp_path / "sessions.db")
    path = tmp_path / "old.mcap"
    export(tmp_path, 2, "--format", "mcap", "-o", str(path))
    decoded = Decoded(path)
    with SessionStore(tmp_path, read_only=True) as store:
        events = store.events(2)
        first = store.plan_doc(store.get(2).plan_hash)
        replanned = [e.evidence.replanned for e in events if e.evidence and e.evidence.replanned]
        assert len(replanned) == 1
        second = store.plan_doc(replanned[0].plan)
    assert [json.loads(data) for data in decoded.attachments.values()] == [first, second]
    assert len(decoded.messages["/rosout"]) == len(events)
    retargeted = [
        (e, e.evidence.retargeted.motion)
        for e in events
        if e.evidence and e.evidence.retargeted and e.evidence.retargeted.motion
    ]
    assert retargeted
    written = {tuple(m.position) for _, m in decoded.messages["/joint_states"]}
    for _, motion in retargeted:
        assert all(tuple(q) in written for q in motion.path)
    # Every other motion is its node's in the plan of the moment: the first plan's
    # before the repair, the new plan's after it.
    plans = [Plan.from_json(first), Plan.from_json(second)]
    repair_at = next(k for k, e in enumerate(events) if e.kind == "repair")
    expected = 0
    for k, event in enumerate(events):
        node = plans[k > repair_at].nodes.get(event.node)
        if event.kind != "actuation" or node is None or node.motion is None:
            continue
        ours = next((m for e, m in retargeted if e is event), node.motion)
        expected += len(ours.path)
    assert len(decoded.messages["/joint_states"]) == expected > 0


# -- a hand-made session, its times worked out by hand ------------------------------------

LEFT = joint_names("left")
# At Baxter's joint position speed ratio 0.3, a shoulder (1.5 rad/s) turns 0.45 rad in
# 1 s and a wrist (4.0 rad/s) 2.4 rad in 2 s: the motion's segments take 1 s and 2 s.
PATH = [[0.0] * 7, [0.45] + [0.0] * 6, [0.45, 0.0, 0.0, 0.0, 2.4, 0.0, 0.0]]
HAND_PLAN = {
    "format": "tandem-plan/1",
    "scenario": {"name": "hand-made", "sha256": "0" * 64},
    "facts": [],
    "root": "m",
    "nodes": {
        "m": {"kind": "actuation", "action": "hold(left,leg1)", "state": [],
              "children": [{"outcome": None, "node": "q"}],
              "motion": {"arm": "left", "joints": LEFT, "path": PATH}},
        "q": {"kind": "communication", "action": "askHelp(leg2,top)", "state": [],
              "say": "Can you attach leg2 to the top?",
              "children": [{"outcome": "yes", "node": "g"}, {"outcome": "no", "node": "g"}]},
        "g": {"kind": "goal", "action": None, "state": [], "children": []},
    },
}  # fmt: skip


def hand_made_session(folder: Path) -> tuple[SessionRun, float]:
    """A wall-clock session: the arm plays its motion over 6 s (from t0 + 1 to t0 + 7),
    then asks for help (its line said by t0 + 8, the click at t0 + 10), which reports
    the human's action from t0 + 8 to t0 + 10; the session's events and t0."""
    plan = Plan.from_json(HAND_PLAN)
    with SessionStore(folder) as store:
        session = store.start(plan, clock="wall")
        t0 = store.get(session).started
        hold, ask = plan.nodes["m"].action, plan.nodes["q"].action
        for event in (
            ExecutionEvent(0, t0 + 7, "m", hold, "actuation", start=t0 + 1, end=t0 + 7),
            ExecutionEvent(1, t0 + 10, "q", ask, "communication", outcome="yes", source="click",
                           start=t0 + 7, end=t0 + 10, wait_start=t0 + 8),
            ExecutionEvent(2, t0 + 10, "q", ask, "human", source="click", text="attached",
                           start=t0 + 8, end=t0 + 10),
            ExecutionEvent(3, t0 + 10, "g", None, "goal", start=t0 + 10, end=t0 + 10),
        ):  # fmt: skip
            store.record(session, event)
        store.finish(session, "goal", t0 + 10)
        return SessionRun.load(store, session), t0


def test_a_hand_made_session_at_its_real_times(tmp_path: Path) -> None:
    from math import pi, sqrt

    from app.sessions.mcap_export import RobotModel
    from planner.feasibility.robot import baxter_description

    run, t0 = hand_made_session(tmp_path)
    description = baxter_description()
    robot = RobotModel(description, (0.1, -0.2, pi / 2), segment_seconds)
    path = tmp_path / "hand.mcap"
    with path.open("wb") as out:
        write_session(out, run, robot=robot)
    decoded = Decoded(path)
    # The waypoints share the stored 6 s as their segments share 3 s: 2 s, then 4 s.
    states = decoded.messages["/joint_states"]
    assert [list(m.position) for _, m in states] == PATH
    assert [t for t, _ in states] == [ns(t0 + 1), ns(t0 + 3), ns(t0 + 7)]
    # The robot, once at the session's start: its URDF and its base turned a quarter.
    ((t, urdf),) = decoded.messages["/robot_description"]
    assert t == ns(t0) and urdf.data == description and '<robot name="baxter"' in urdf.data
    ((t, static),) = decoded.messages["/tf_static"]
    (base,) = static.transforms
    assert t == ns(t0) and (base.header.frame_id, base.child_frame_id) == ("bench", "base")
    moved, turned = base.transform.translation, base.transform.rotation
    assert (moved.x, moved.y, moved.z) == (0.1, -0.2, 0.0)
    assert (turned.z, turned.w) == pytest.approx((sqrt(0.5), sqrt(0.5)))
    assert decoded.schemas["/robot_description"] == "std_msgs/msg/String"
    # Each event's lines: when it started, when the robot began waiting, when it ended.
    lines = [(t, m.line, m.msg) for t, m in decoded.messages["/rosout"]]
    assert [(t, seq) for t, seq, _ in sorted(lines)] == [
        (ns(t0 + 1), 0), (ns(t0 + 7), 0), (ns(t0 + 7), 1), (ns(t0 + 8), 1), (ns(t0 + 8), 2),
        (ns(t0 + 10), 1), (ns(t0 + 10), 2), (ns(t0 + 10), 3),
    ]  # fmt: skip
    assert {msg for _, seq, msg in lines if seq == 1} == {
        "q askHelp(leg2,top) starts",
        "q askHelp(leg2,top): the robot waits for the human",
        "q askHelp(leg2,top) -> Human says yes (click)",
    }


def test_without_a_robot_model_the_waypoints_share_the_time_evenly(tmp_path: Path) -> None:
    run, t0 = hand_made_session(tmp_path)
    path = tmp_path / "even.mcap"
    with path.open("wb") as out:
        write_session(out, run)
    decoded = Decoded(path)
    assert [t for t, _ in decoded.messages["/joint_states"]] == [
        ns(t0 + 1), ns(t0 + 4), ns(t0 + 7)
    ]  # fmt: skip
    assert "/robot_description" not in decoded.messages and "/tf_static" not in decoded.messages
