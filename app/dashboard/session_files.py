"""A stored session as the files the review offers for download: the whole session
as JSON, its events as CSV, or MCAP for Foxglove (`app.sessions.mcap_export`)
with what only the world's geometry knows: the parts' poses, Baxter's URDF and
base, and how long each segment of a motion takes.

The file names are whole (`tandem-session-12.mcap`): a browser saves the download
under the name it is given.
"""

from __future__ import annotations

import hashlib
import io
import json
from collections.abc import Mapping
from typing import Literal, get_args

from app.execution.timing import segment_seconds
from app.execution.world import world_at
from app.sessions.export import events_csv
from app.sessions.mcap_export import PartsAt, RobotModel, SessionRun, write_session
from app.sessions.store import SessionStore
from planner.feasibility.robot import RobotModelMissing, baxter_description
from planner.feasibility.scene import part_boxes, region_extents
from planner.plan.model import Plan
from planner.resources import scenario_dir
from planner.scenario.loading import load_scenario
from planner.scenario.model import Scenario

FileFormat = Literal["json", "csv", "mcap"]
FILE_FORMATS: tuple[FileFormat, ...] = get_args(FileFormat)


def file_name(session_id: int, kind: FileFormat) -> str:
    return f"tandem-session-{session_id}.{kind}"


def session_file(
    store: SessionStore, session_id: int, kind: FileFormat, scenario: Scenario | None
) -> bytes:
    """The session's file of format `kind`; `scenario` places the parts and the robot
    in an MCAP file (None: neither is known, the file has no `/tf` and no robot base)."""
    if kind == "json":
        return json.dumps(store.export(session_id), indent=1).encode()
    if kind == "csv":
        return events_csv(store.events(session_id)).encode()
    out = io.BytesIO()
    run = SessionRun.load(store, session_id)
    parts = None if scenario is None else parts_at(scenario)
    write_session(out, run, parts_at=parts, robot=baxter_model(scenario))
    return out.getvalue()


def parts_at(scenario: Scenario) -> PartsAt:
    """The parts' poses as a node of a plan of `scenario` leaves them, placed as the
    dashboard's bench draws them."""
    boxes = part_boxes(scenario)
    human_edge_x = max(hi for _, hi in region_extents(scenario).values())

    def at(plan: Plan, node_id: str) -> Mapping[str, tuple[float, float, float]]:
        world = world_at(plan.nodes, [node_id], boxes, human_edge_x=human_edge_x)
        return {part: (p.x, p.y, p.z) for part, p in world.parts.items()}

    return at


def baxter_model(scenario: Scenario | None) -> RobotModel | None:
    """Baxter as the execution times it, standing where `scenario` puts its base (the
    bench's origin without one); None when the robot model is not installed."""
    try:
        description = baxter_description()
    except (RobotModelMissing, OSError):
        return None
    x, y, yaw = scenario.robot.base_pose if scenario is not None else (0.0, 0.0, 0.0)
    return RobotModel(description, (x, y, yaw), segment_seconds)


def scenario_of(sha256: str | None, loaded: Scenario | None) -> Scenario | None:
    """The scenario a session ran: the one loaded when its file's hash is the
    session's, else the shipped one with that hash; None if neither."""
    if sha256 is None:
        return None
    if loaded is not None and loaded.sha256 == sha256:
        return loaded
    for path in sorted(scenario_dir().rglob("*.toml")):
        if hashlib.sha256(path.read_bytes()).hexdigest() == sha256:
            return load_scenario(path)
    return None
