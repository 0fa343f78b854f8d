"""The bench and the parts as pybullet boxes, from a scenario.

Coordinates: x along the bench away from the robot (the regions' extents), y across
it, z up with 0 at the robot's base frame; the bench top is at BENCH_TOP_Z. Missing
geometry gets the defaults of the field notes, so every valid scenario has a scene.

Slots (connection points) follow the assembly: a part attached to nothing has its
points on its own footprint (`PartBox.sites`); a part attached at Q's point C stands
at the site of (Q, C), and all its own points are there too. So a leg attached to
the top at c2 stands at the top's site c2, and a foot attached to that leg goes to
the same place (`site_of`). An arm works at a site from above: top-down, the
gripper endpoint GRASP_CLEARANCE (planner.feasibility.reach) over the top face of
the part whose footprint the site lies on.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from planner.scenario.model import Part, Scenario
from planner.scenario.sections import DEFAULT_REGION_X

BENCH_TOP_Z = -0.05  # Baxter's base frame is ~0.93 m up; the bench top ~0.88 m
BENCH_THICKNESS = 0.04
BENCH_HALF_WIDTH = 0.70  # across the bench (y), metres
# Legs lie across the bench (long along y) so they fit a 0.35 m deep region.
DEFAULT_SIZE = {
    "top": (0.30, 0.50, 0.03),
    "leg": (0.05, 0.35, 0.05),
    "foot": (0.08, 0.08, 0.04),
    "other": (0.10, 0.10, 0.05),
}
_GAP = 0.05  # between default-placed parts


@dataclass(frozen=True)
class PartBox:
    id: str
    x: float
    y: float
    yaw: float
    size: tuple[float, float, float]
    region: str
    movable: bool = True
    connections: tuple[str, ...] = ()

    @property
    def top_z(self) -> float:
        return BENCH_TOP_Z + self.size[2]

    def sites(self) -> dict[str, tuple[float, float]]:
        """Where each connection point lies on the bench (x, y).

        Points sit at the centres of a grid over the footprint, columns along the
        part's longer side: two points on a long top are its two ends.
        """
        n = len(self.connections)
        if n == 0:
            return {}
        long_x = self.size[0] >= self.size[1]
        cols = math.ceil(math.sqrt(n))
        rows = math.ceil(n / cols)
        along, across = (self.size[0], self.size[1]) if long_x else (self.size[1], self.size[0])
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        out: dict[str, tuple[float, float]] = {}
        for i, name in enumerate(self.connections):
            row, col = divmod(i, cols)
            u = along * ((col + 0.5) / cols - 0.5)
            v = across * ((row + 0.5) / rows - 0.5)
            lx, ly = (u, v) if long_x else (v, u)
            out[name] = (self.x + c * lx - s * ly, self.y + s * lx + c * ly)
        return out

    def work_point(self, near: tuple[float, float]) -> tuple[float, float]:
        """Where an arm works on this part: a movable part is grasped at its centre;
        on a fixed one (the top) the arm attaches at the connection point nearest to
        it, since the points are interchangeable (docs/domain.md)."""
        sites = self.sites()
        if self.movable or not sites:
            return (self.x, self.y)
        return min(sites.values(), key=lambda xy: math.dist(xy, near))


@dataclass(frozen=True, order=True)
class Site:
    """Connection point `point` on the footprint of `part`, a part attached to nothing."""

    part: str
    point: str

    def __str__(self) -> str:
        return f"{self.part}@{self.point}"  # "@" is in no part id: cache keys stay apart

    @staticmethod
    def parse(target: str) -> Site | None:
        """The Site a check target names ("top@c2", as `str` writes it); None for a part id."""
        part, at, point = target.partition("@")
        return Site(part, point) if at else None


def site_of(attached: Mapping[str, tuple[str, str]], part: str, point: str) -> Site:
    """Where connection point `point` of `part` lies when `attached` (part -> (onto,
    point), as `Hands.attached` reads it from a state) places the parts: down the
    attachment chain to the part attached to nothing."""
    seen = {part}
    while part in attached:
        part, point = attached[part]
        if part in seen:
            raise ValueError(f"attachment cycle through {part}")
        seen.add(part)
    return Site(part, point)


@dataclass
class Scene:
    client: int
    bench: int
    parts: dict[str, PartBox]
    bodies: dict[str, int]  # part id -> pybullet body


def region_extents(scenario: Scenario) -> dict[str, tuple[float, float]]:
    """Each region's x extent: its own, the field-notes default, or the next free slot."""
    out: dict[str, tuple[float, float]] = {}
    for r in scenario.regions:
        if r.x is not None:
            out[r.id] = (min(r.x), max(r.x))
        elif r.id in DEFAULT_REGION_X:
            out[r.id] = DEFAULT_REGION_X[r.id]
    for r in scenario.regions:
        if r.id not in out:
            start = max((hi for _, hi in out.values()), default=0.30)
            out[r.id] = (start, start + 0.35)
    return out


def part_boxes(scenario: Scenario) -> dict[str, PartBox]:
    """Parts with a pose keep it; the others fill a grid inside their region, in file order."""
    extents = region_extents(scenario)
    boxes: dict[str, PartBox] = {}
    unplaced: dict[str, list[Part]] = {}
    for p in scenario.parts:
        size = _size(p)
        if p.pose is not None:
            boxes[p.id] = PartBox(
                p.id, p.pose[0], p.pose[1], p.pose[2], size, p.region, *_joints(p)
            )
        else:
            unplaced.setdefault(p.region, []).append(p)
    for region, parts in unplaced.items():
        lo, hi = extents[region]
        boxes.update(_grid(parts, lo, hi))
    return boxes


def _joints(p: Part) -> tuple[bool, tuple[str, ...]]:
    return p.movable, tuple(p.connection_points)


def _size(p: Part) -> tuple[float, float, float]:
    if p.size is not None:
        return (p.size[0], p.size[1], p.size[2])
    return DEFAULT_SIZE[p.kind]


def _grid(parts: list[Part], lo: float, hi: float) -> dict[str, PartBox]:
    # Cells as large as the largest footprint; as many rows along x as fit, then
    # columns across the bench centred on y = 0, filled row by row.
    cell_x = max(_size(p)[0] for p in parts) + _GAP
    cell_y = max(_size(p)[1] for p in parts) + _GAP
    rows = max(1, min(len(parts), int((hi - lo) // cell_x)))
    cols = math.ceil(len(parts) / rows)
    out: dict[str, PartBox] = {}
    for i, p in enumerate(parts):
        row, col = divmod(i, cols)
        x = lo + (hi - lo) * (row + 0.5) / rows
        y = (col - (cols - 1) / 2) * cell_y
        out[p.id] = PartBox(p.id, x, y, 0.0, _size(p), p.region, *_joints(p))
    return out


def build_scene(client: int, scenario: Scenario) -> Scene:
    extents = region_extents(scenario)
    x_lo = min(lo for lo, _ in extents.values())
    x_hi = max(hi for _, hi in extents.values())
    bench = _box(
        client,
        ((x_lo + x_hi) / 2, 0.0, BENCH_TOP_Z - BENCH_THICKNESS / 2),
        0.0,
        (x_hi - x_lo, 2 * BENCH_HALF_WIDTH, BENCH_THICKNESS),
    )
    parts = part_boxes(scenario)
    bodies = {
        pid: _box(client, (b.x, b.y, BENCH_TOP_Z + b.size[2] / 2), b.yaw, b.size)
        for pid, b in parts.items()
    }
    return Scene(client=client, bench=bench, parts=parts, bodies=bodies)


def _box(
    client: int,
    center: tuple[float, float, float],
    yaw: float,
    size: tuple[float, float, float],
) -> int:
    from planner.feasibility._bullet import pb

    shape = pb.createCollisionShape(
        pb.GEOM_BOX, halfExtents=[s / 2 for s in size], physicsClientId=client
    )
    # Mass 0: static, so nothing falls while collisions are queried.
    return int(
        pb.createMultiBody(
            baseMass=0.0,
            baseCollisionShapeIndex=shape,
            basePosition=list(center),
            baseOrientation=pb.getQuaternionFromEuler([0.0, 0.0, yaw]),
            physicsClientId=client,
        )
    )
