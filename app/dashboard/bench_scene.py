"""The 3D bench: regions, parts, Baxter and the human, drawn with viser.

Coordinates are the motion planner's (planner/feasibility/scene.py): x along the
bench away from the robot, z up, 0 at Baxter's base frame (~0.93 m above the floor).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
import viser
import yourdfpy
from viser.extras import ViserUrdf

from app.dashboard.label_layout import Point3, laid_out
from app.dashboard.mesh_detail import DEFAULT_DETAIL, reduce_detail
from app.dashboard.view_panel import CAMERAS
from app.execution.world import Placement, WorldView
from planner.feasibility.arms import ARMS, HOME, JOINT_SUFFIXES
from planner.feasibility.robot import baxter_urdf, human_urdf
from planner.feasibility.scene import (
    BENCH_HALF_WIDTH,
    BENCH_THICKNESS,
    BENCH_TOP_Z,
    PartBox,
    part_boxes,
    region_extents,
)
from planner.scenario.model import Scenario

FLOOR_Z = -0.93
REGION_COLOURS = {
    "robotOnly": (120, 160, 230),
    "shared": (240, 200, 90),
    "humanOnly": (140, 200, 140),
}
OTHER_REGION = (200, 200, 200)
PART_COLOURS = {"top": (170, 120, 70), "leg": (200, 160, 110), "foot": (110, 110, 120)}
DANGER = (220, 50, 50)
HELD_TINT = (255, 140, 0)
HUMAN_X = 1.85  # the human stands past the far end of the bench, facing the robot
# The drawn human's hands as the model stands (read off its URDF at rest, in
# bench coordinates): a part the human holds is drawn in one, just in front.
HUMAN_HANDS = ((HUMAN_X - 0.06, 0.21, -0.17), (HUMAN_X - 0.06, -0.21, -0.17))
PREFIX = "/bench"
LEADER = (150, 150, 150)  # the line from a lifted label down to its part


def _yaw_quat(yaw: float) -> tuple[float, float, float, float]:
    return (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))


def label_words(
    parts: Mapping[str, Placement], scenario: Scenario | None = None
) -> dict[str, str]:
    """One label per assembly, on the part the others are attached to ("top +
    leg1, foot1"), and one per loose part, with its marker code and saying
    whether it is dangerous and who holds it: labels of parts attached together
    would stand on top of each other."""
    known = {p.id: p for p in scenario.parts} if scenario is not None else {}
    def root(pid: str) -> str:
        seen = {pid}
        while (onto := parts[pid].attached_to) is not None and onto in parts and onto not in seen:
            pid = onto
            seen.add(pid)
        return pid

    members: dict[str, list[str]] = {}
    for pid in parts:
        if parts[pid].attached_to is not None:
            members.setdefault(root(pid), []).append(pid)
    words = {}
    for pid, placement in parts.items():
        if placement.attached_to is not None:
            continue
        part = known.get(pid)
        text = pid + (f" #{part.marker}" if part and part.marker is not None else "")
        text += f" + {', '.join(sorted(members[pid]))}" if pid in members else ""
        notes = ["dangerous"] if part and part.dangerous else []
        notes += [f"held by {placement.holder}"] if placement.holder is not None else []
        words[pid] = text + (f" ({', '.join(notes)})" if notes else "")
    return words


def human_top_z(human: yourdfpy.URDF) -> float:
    """The top of the drawn human's head (bench coordinates): the model is y-up, its
    pelvis stood 1.0 m above the floor (`load_models`)."""
    return FLOOR_Z + 1.0 + float(human.scene.bounds[1][1])


class BenchScene:
    """Everything on and around the bench; `show(world)` moves parts and arms."""

    def __init__(
        self,
        server: viser.ViserServer,
        *,
        load_models: bool = True,
        mesh_detail: float = DEFAULT_DETAIL,
    ) -> None:
        self.server = server
        self.boxes: dict[str, PartBox] = {}
        self.human_edge_x = 0.0  # the bench's far end (x), where the human's hands reach over
        self.scenario: Scenario | None = None
        self._part_handles: dict[str, viser.BoxHandle] = {}
        self._label_handles: dict[str, viser.LabelHandle] = {}
        self._leaders: viser.LineSegmentsHandle | None = None
        self._lifted: list[tuple[Point3, Point3]] = []  # the leaders drawn now
        self._region_labels: list[tuple[Point3, str]] = []  # where, and what they say
        self._static: list[viser.SceneNodeHandle] = []
        self.robot: ViserUrdf | None = None
        self.drawn_arms: dict[str, list[float]] = {}  # each arm's joints as drawn now
        if load_models:
            self.load_models(mesh_detail)

    def load_models(self, mesh_detail: float = DEFAULT_DETAIL) -> None:
        """Baxter and the human (~5 MB of meshes for every page that connects)."""
        scene = self.server.scene
        scene.add_frame("/baxter", show_axes=False)
        baxter = yourdfpy.URDF.load(str(baxter_urdf()))
        reduce_detail(baxter, mesh_detail)
        self.robot = ViserUrdf(self.server, baxter, root_node_name="/baxter")
        # The human model is y-up and faces +x: stand it up, facing the robot, feet
        # on the floor (its feet are ~1.0 m below its pelvis).
        upright = np.array([[-1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]])
        scene.add_frame(
            "/human",
            show_axes=False,
            position=(HUMAN_X, 0.0, FLOOR_Z + 1.0),
            wxyz=tuple(viser.transforms.SO3.from_matrix(upright).wxyz),
        )
        human = yourdfpy.URDF.load(str(human_urdf()))
        reduce_detail(human, mesh_detail)
        model = ViserUrdf(self.server, human, root_node_name="/human")
        # ViserUrdf places its joints' frames only on an update: without one every
        # limb is drawn at the pelvis, a short heap far below the name.
        model.update_cfg(np.zeros(len(model.get_actuated_joint_names())))
        scene.add_label(
            "/human_name", "human", position=(HUMAN_X, 0.0, human_top_z(human) + 0.03),
            anchor="bottom-center",
        )  # fmt: skip
        self.show_arms({arm: list(q) for arm, q in HOME.items()})

    def load(self, scenario: Scenario) -> None:
        """Draw a scenario's bench and parts, replacing what was there."""
        for handle in [*self._static, *self._part_handles.values(), *self._label_handles.values()]:
            handle.remove()
        self._static, self._part_handles, self._label_handles = [], {}, {}
        self._region_labels = []
        self._draw_leaders({}, {})
        self.scenario = scenario
        self.boxes = part_boxes(scenario)
        scene = self.server.scene
        extents = region_extents(scenario)
        x_lo = min(lo for lo, _ in extents.values())
        x_hi = max(hi for _, hi in extents.values())
        self.human_edge_x = x_hi
        self._static.append(
            scene.add_box(
                f"{PREFIX}/table",
                color=(150, 150, 150),
                dimensions=(x_hi - x_lo, 2 * BENCH_HALF_WIDTH, BENCH_THICKNESS),
                position=((x_lo + x_hi) / 2, 0.0, BENCH_TOP_Z - BENCH_THICKNESS / 2 - 0.002),
            )
        )
        for index, region in enumerate(scenario.regions):
            lo, hi = extents[region.id]
            colour = REGION_COLOURS.get(region.id, OTHER_REGION)
            self._static.append(
                scene.add_box(
                    f"{PREFIX}/regions/{region.id}",
                    color=colour,
                    dimensions=(hi - lo - 0.01, 2 * BENCH_HALF_WIDTH - 0.02, 0.002),
                    position=((lo + hi) / 2, 0.0, BENCH_TOP_Z),
                )
            )
            reach = "human reaches" if region.human_reach else "robot only"
            # Staggered across the bench: side by side they would overlap.
            where = ((lo + hi) / 2, -BENCH_HALF_WIDTH + 0.05 + 0.09 * (index % 2),
                     BENCH_TOP_Z + 0.01)  # fmt: skip
            self._region_labels.append((where, f"{region.id} ({reach})"))
            self._static.append(
                scene.add_label(
                    f"{PREFIX}/region_labels/{region.id}", f"{region.id} ({reach})", position=where
                )
            )
        for pid, box in self.boxes.items():
            part = scenario.part(pid)
            colour = DANGER if part.dangerous else PART_COLOURS.get(part.kind, (150, 150, 200))
            self._part_handles[pid] = scene.add_box(
                f"{PREFIX}/parts/{pid}",
                color=colour,
                dimensions=box.size,
                position=(box.x, box.y, BENCH_TOP_Z + box.size[2] / 2),
                wxyz=_yaw_quat(box.yaw),
            )
        anchors = {pid: (box.x, box.y, BENCH_TOP_Z + box.size[2] + 0.03)
                   for pid, box in self.boxes.items()}  # fmt: skip
        texts = label_words({p: Placement(*anchors[p]) for p in anchors}, scenario)
        for pid, where in anchors.items():
            self._label_handles[pid] = scene.add_label(
                f"{PREFIX}/labels/{pid}", texts[pid], position=where
            )
        self._place_labels(anchors, texts)

    def show(self, world: WorldView) -> None:
        anchors: dict[str, Point3] = {}
        hands = iter(HUMAN_HANDS)
        words = label_words(world.parts, self.scenario)
        for pid, placement in world.parts.items():
            handle = self._part_handles.get(pid)
            if handle is None:
                continue
            where = (placement.x, placement.y, placement.z)
            if placement.holder == "human":
                where = next(hands, where)  # in the drawn human's hand
            handle.position = where
            label = self._label_handles[pid]
            label.visible = pid in words
            if pid in words:
                label.text = words[pid]
                anchors[pid] = (where[0], where[1], where[2] + 0.06)
        self._place_labels(anchors, words)
        self.show_arms(world.arms)

    def drawn(self) -> dict[str, tuple[tuple[float, ...], str | None]]:
        """What the bench shows of each part: where its box is (mm) and its label's
        words (None: no label, the part is in an assembly's)."""
        out: dict[str, tuple[tuple[float, ...], str | None]] = {}
        for pid, handle in self._part_handles.items():
            label = self._label_handles[pid]
            where = tuple(round(float(v) * 1000) for v in handle.position)
            out[pid] = (where, label.text if label.visible else None)
        return out

    def _place_labels(self, anchors: dict[str, Point3], texts: dict[str, str]) -> None:
        """Labels where none covers another on the "Bench" camera; one lifted above
        its part hangs from a thin line down to it."""
        placed = laid_out(CAMERAS["Bench"], anchors, texts, self._region_labels)
        for pid, position in placed.items():
            self._label_handles[pid].position = position
        self._draw_leaders(anchors, placed)

    def _draw_leaders(self, anchors: dict[str, Point3], placed: dict[str, Point3]) -> None:
        lifted = [(anchors[p], placed[p]) for p in placed if placed[p][2] > anchors[p][2]]
        if lifted == self._lifted and (self._leaders is not None or not lifted):
            return  # most steps move no labelled part: nothing to send
        self._lifted = lifted
        if not lifted:
            if self._leaders is not None:
                self._leaders.remove()
                self._leaders = None
            return
        # Added under the same name, the node replaces the last one on every page.
        self._leaders = self.server.scene.add_line_segments(
            f"{PREFIX}/label_leaders", np.array(lifted), colors=LEADER,
            thickness=1.5, thickness_units="screen",
        )  # fmt: skip

    def show_arms(self, arms: dict[str, list[float]]) -> None:
        if self.robot is None:
            return
        names = self.robot.get_actuated_joint_names()
        cfg = np.zeros(len(names))
        for arm in ARMS:
            for suffix, value in zip(JOINT_SUFFIXES, arms[arm], strict=True):
                name = f"{arm}_{suffix}"
                if name in names:
                    cfg[names.index(name)] = value
        self.robot.update_cfg(cfg)
        self.drawn_arms = {arm: list(arms[arm]) for arm in ARMS}
