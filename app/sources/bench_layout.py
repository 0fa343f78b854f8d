"""A scenario as perception's inputs: the bench layout.

Perception knows nothing of scenario files; this module computes, from a planner
`Scenario`, what `perception.paper_bench` writes by hand for the paper's bench:
the regions' extents, the bench's size and height, each part's box (from
`planner.feasibility.scene.part_boxes`, so the camera sees the parts where the
planner and the dashboard put them), its connection slots relative to its centre,
where its code sits, the code's payload, and what a leg's or a foot's top face
may look like (its shape options: the camera tells them apart when several).
The simulated camera's scene of the same bench is drawn from these by
app.responses.sim_camera (sources never import the simulators).
"""

from __future__ import annotations

from perception.codes_image import printed_side
from perception.layout import BenchLayout, PartShape, Region
from perception.markers import corner_references, encode_part
from planner.feasibility.scene import (
    BENCH_HALF_WIDTH,
    BENCH_TOP_Z,
    PartBox,
    part_boxes,
    region_extents,
)
from planner.scenario.model import Scenario

_CLEARANCE_M = 0.005  # between a code and the code of a part standing on a slot
_CARD_GAP_M = 0.01  # between a face the camera reads and its code's card


def marker_ids(scenario: Scenario) -> dict[str, int]:
    """Each part's marker id: the scenario's `marker`, else the next unused id in
    file order from 1, so ids stay the same as long as the file's order does."""
    taken = {p.marker for p in scenario.parts if p.marker is not None}
    out: dict[str, int] = {}
    candidate = 1
    for p in scenario.parts:
        if p.marker is not None:
            out[p.id] = p.marker
            continue
        while candidate in taken:
            candidate += 1
        out[p.id] = candidate
        taken.add(candidate)
    return out


def payloads(scenario: Scenario) -> dict[str, str]:
    return {pid: encode_part(pid, marker) for pid, marker in marker_ids(scenario).items()}


def code_side(payload: str, marker_size_m: float) -> float:
    """The printed square of a code, quiet zone included (what may hide another)."""
    return printed_side(payload, marker_size_m)


def slot_offsets(box: PartBox) -> dict[str, tuple[float, float]]:
    """Each connection slot's offset from the part's centre, in the bench's axes."""
    return {name: (x - box.x, y - box.y) for name, (x, y) in box.sites().items()}


def code_offset(
    box: PartBox, own_side: float, largest_side: float, face_in_view: bool = False
) -> tuple[float, float]:
    """Where the part's code sits on its top face, from the centre, in its own axes.

    A code under a part standing on a slot is hidden, and a hidden part becomes
    unknown, so a part with slots carries its code clear of them:
    - slots at the centre (a leg's foot point): along the long side, one code's
      width (its own half and the largest other half) away, so the code of a
      part standing on the slot does not cover it;
    - slots along the long side (a top's ends): beside their line, at the edge of
      the face towards the human, as far from what stands on them as it fits;
    - no slots, and a face the camera must see (`face_in_view`: its shape is open):
      on a card flush with the face, beside it across its long side, towards -y
      (-x for a part longer along y). A foot's face is smaller than a code; and
      legs carry theirs along their long side, so a foot's card on a leg never
      covers the leg's code.
    """
    slots = slot_offsets(box)
    long_x = box.size[0] >= box.size[1]
    if not slots:
        if not face_in_view:
            return (0.0, 0.0)
        beside = (box.size[1] if long_x else box.size[0]) / 2 + _CARD_GAP_M + own_side / 2
        return (0.0, -beside) if long_x else (-beside, 0.0)
    if all(abs(dx) < 1e-9 and abs(dy) < 1e-9 for dx, dy in slots.values()):
        along = own_side / 2 + largest_side / 2 + _CLEARANCE_M
        return (along, 0.0) if long_x else (0.0, along)
    short_half = (box.size[1] if long_x else box.size[0]) / 2
    beside = max(short_half - own_side / 2, 0.0)
    return (0.0, beside) if long_x else (beside, 0.0)


def _sides(scenario: Scenario, marker_size_m: float) -> dict[str, float]:
    return {pid: code_side(text, marker_size_m) for pid, text in payloads(scenario).items()}


def outlines(scenario: Scenario) -> dict[str, tuple[str, ...]]:
    """What each leg's and foot's top face may look like: its shape options."""
    return {p.id: tuple(p.shape_options) for p in scenario.parts if p.kind in ("leg", "foot")}


def part_shapes(scenario: Scenario, marker_size_m: float) -> dict[str, PartShape]:
    boxes = part_boxes(scenario)
    sides = _sides(scenario, marker_size_m)
    largest = max(sides.values())
    faces = outlines(scenario)
    return {
        pid: PartShape(
            box.size,
            slot_offsets(box),
            code_offset(box, sides[pid], largest, len(faces.get(pid, ())) > 1),
            faces.get(pid, ()),
        )
        for pid, box in boxes.items()
    }


def bench_extent(scenario: Scenario) -> tuple[tuple[float, float], tuple[float, float]]:
    """The bench top's (x, y) extents: all regions along x, the scene's width in y."""
    extents = region_extents(scenario).values()
    x = (min(lo for lo, _ in extents), max(hi for _, hi in extents))
    return x, (-BENCH_HALF_WIDTH, BENCH_HALF_WIDTH)


def _lift_split_x(scenario: Scenario) -> float:
    # The region on the human's edge of the bench is the one the arms do not reach
    # in the paper's benches: a part lifted over it is in the human's hands.
    extents = sorted(region_extents(scenario).values())
    return extents[-1][0] if len(extents) > 1 else (extents[0][0] + extents[0][1]) / 2


def bench_layout(scenario: Scenario, marker_size_m: float | None = None) -> BenchLayout:
    """Perception's bench; codes at the scenario's `[camera] marker_size` unless given."""
    if marker_size_m is None:
        marker_size_m = scenario.camera.marker_size
    bench_x, bench_y = bench_extent(scenario)
    regions = tuple(
        Region(rid, lo, hi)
        for rid, (lo, hi) in sorted(region_extents(scenario).items(), key=lambda kv: kv[1])
    )
    return BenchLayout(
        regions=regions,
        bench_top_z=BENCH_TOP_Z,
        bench_x=bench_x,
        bench_y=bench_y,
        human_side_x=bench_x[1],
        parts=part_shapes(scenario, marker_size_m),
        references=corner_references(bench_x, bench_y, marker_size_m),
        marker_size_m=marker_size_m,
        lift_split_x=_lift_split_x(scenario),
    )
