"""The paper's base bench as perception inputs: its layout, its simulated scene, and
where parts go when held or attached. Used by the benchmark and the tests; the app
builds the same values from whatever scenario it loads."""

from __future__ import annotations

from perception.layout import BenchLayout, PartShape, Region
from perception.markers import DEFAULT_MARKER_SIZE_M, corner_references, encode_part
from perception.sim import SimPart, SimScene

BENCH_TOP_Z = -0.05
BENCH_X = (0.30, 1.40)
BENCH_Y = (-0.70, 0.70)
HUMAN_HANDS_X = 1.55
HUMAN_HANDS_Z = 0.10  # centre of a part in the human's hands
ROBOT_LIFT = 0.12  # a robot-held part floats this far above where it was taken

SIZES = {
    "top": (0.30, 0.50, 0.03),
    "leg": (0.05, 0.35, 0.05),
    "foot": (0.08, 0.08, 0.04),
}
# (id, kind, x, y, marker id): the default scenario's parts.
PARTS = (
    ("top", "top", 0.80, 0.0, 1),
    ("leg1", "leg", 0.45, 0.0, 2),
    ("leg2", "leg", 1.20, 0.0, 3),
    ("foot1", "foot", 0.75, 0.40, 4),
    ("foot2", "foot", 0.75, -0.40, 5),
)
# The top's two slots at the ends of its long side (y), as the planner places them.
TOP_SLOTS = {"c1": (0.0, -0.125), "c2": (0.0, 0.125)}
# The top's code sits towards the human, clear of the legs standing on its slots.
TOP_CODE_OFFSET = (0.09, 0.0)
COLOURS = {"top": (0.80, 0.72, 0.55), "leg": (0.70, 0.80, 0.85), "foot": (0.85, 0.70, 0.70)}


def layout(marker_size_m: float = DEFAULT_MARKER_SIZE_M) -> BenchLayout:
    shapes = {
        pid: PartShape(SIZES[kind], dict(TOP_SLOTS), TOP_CODE_OFFSET)
        if kind == "top"
        else PartShape(SIZES[kind])
        for pid, kind, _, _, _ in PARTS
    }
    return BenchLayout(
        regions=(
            Region("robotOnly", 0.30, 0.65),
            Region("shared", 0.65, 1.00),
            Region("humanOnly", 1.00, 1.40),
        ),
        bench_top_z=BENCH_TOP_Z,
        bench_x=BENCH_X,
        bench_y=BENCH_Y,
        human_side_x=BENCH_X[1],
        parts=shapes,
        references=corner_references(BENCH_X, BENCH_Y, marker_size_m),
        marker_size_m=marker_size_m,
    )


def resting(part_id: str) -> tuple[float, float, float]:
    """A part's box centre where the scenario puts it on the bench."""
    for pid, kind, x, y, _ in PARTS:
        if pid == part_id:
            return (x, y, BENCH_TOP_Z + SIZES[kind][2] / 2)
    raise KeyError(part_id)


def kind_of(part_id: str) -> str:
    return next(kind for pid, kind, *_ in PARTS if pid == part_id)


def in_human_hands(part_id: str, y: float = 0.0) -> tuple[float, float, float]:
    return (HUMAN_HANDS_X, y, BENCH_TOP_Z + HUMAN_HANDS_Z + SIZES[kind_of(part_id)][2] / 2)


def in_robot_gripper(part_id: str) -> tuple[float, float, float]:
    x, y, z = resting(part_id)
    return (x, y, z + ROBOT_LIFT)


def attached_at(part_id: str, onto: str, slot: str) -> tuple[float, float, float]:
    """Standing on `onto` (resting on the bench) at `slot`."""
    ox, oy, oz = resting(onto)
    dx, dy = TOP_SLOTS[slot]
    h_onto, h_part = SIZES[kind_of(onto)][2], SIZES[kind_of(part_id)][2]
    return (ox + dx, oy + dy, oz + h_onto / 2 + h_part / 2)


def scene(marker_size_m: float = DEFAULT_MARKER_SIZE_M) -> SimScene:
    parts = tuple(
        SimPart(
            pid,
            SIZES[kind],
            resting(pid),
            encode_part(pid, marker),
            colour=COLOURS[kind],
            code_offset=TOP_CODE_OFFSET if kind == "top" else (0.0, 0.0),
        )
        for pid, kind, _, _, marker in PARTS
    )
    return SimScene(
        parts=parts,
        references=corner_references(BENCH_X, BENCH_Y, marker_size_m),
        bench_top_z=BENCH_TOP_Z,
        bench_x=BENCH_X,
        bench_y=BENCH_Y,
        marker_size_m=marker_size_m,
        hands_x=HUMAN_HANDS_X,
    )
