"""The simulated camera of a scenario's bench: its scene, and its frames.

`sim_scene` draws, from a planner `Scenario`, the bench that
app.sources.bench_layout describes to perception: the parts where the planner
and the dashboard put them, each with its own code, a leg or a foot with the
shape of its face. `open_sim_camera` renders it with `perception.sim` (pybullet,
imported only here) as a frame source that redraws only when the simulated
world moved something (app.sim.camera.StillSimulatedCamera).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING

from app.execution.world import hands_x
from app.sim.camera import StillSimulatedCamera
from app.sources.bench_layout import bench_extent, outlines, part_shapes, payloads
from app.sources.camera_input import CameraInput
from perception.markers import corner_references
from planner.feasibility.scene import BENCH_TOP_Z, part_boxes
from planner.scenario.model import Scenario

if TYPE_CHECKING:  # the simulated camera loads pybullet, which a layout never needs
    from perception.sim import SimScene

SIM_SIZE = (640, 640)  # every code of the default bench decodes in a clean 640 px frame
# Box colours by kind, as the paper bench draws them, so frames look alike.
COLOURS = {
    "top": (0.80, 0.72, 0.55),
    "leg": (0.70, 0.80, 0.85),
    "foot": (0.85, 0.70, 0.70),
    "other": (0.75, 0.75, 0.70),
}


def sim_scene(
    scenario: Scenario,
    marker_size_m: float | None = None,
    truth: Mapping[str, str] | None = None,
) -> SimScene:
    """The parts resting where the scenario puts them, each with its own code, a
    leg or a foot drawn with its shape (`truth` for one the scenario leaves open,
    else its first option; the simulated world may reshape it later), and the
    human's hands past the bench's far edge, where the camera frames them."""
    from perception.sim import SimPart, SimScene

    if marker_size_m is None:
        marker_size_m = scenario.camera.marker_size
    bench_x, bench_y = bench_extent(scenario)
    boxes = part_boxes(scenario)
    shapes = part_shapes(scenario, marker_size_m)
    texts = payloads(scenario)
    kinds = {p.id: p.kind for p in scenario.parts}
    faces = outlines(scenario)
    truth = truth or {}
    parts = tuple(
        SimPart(
            pid,
            box.size,
            (box.x, box.y, BENCH_TOP_Z + box.size[2] / 2),
            texts[pid],
            yaw=box.yaw,
            colour=COLOURS.get(kinds[pid], COLOURS["other"]),
            code_offset=shapes[pid].code_offset,
            profile=truth.get(pid) or (faces.get(pid) or ("square",))[0],
        )
        for pid, box in boxes.items()
    )
    return SimScene(
        parts=parts,
        references=corner_references(bench_x, bench_y, marker_size_m),
        bench_top_z=BENCH_TOP_Z,
        bench_x=bench_x,
        bench_y=bench_y,
        marker_size_m=marker_size_m,
        hands_x=hands_x(bench_x[1]),
    )


def sim_camera(scenario: Scenario) -> StillSimulatedCamera:
    """The simulated camera over `scenario`'s bench, as it rests before anything moved."""
    from perception.sim import SimulatedCamera

    return StillSimulatedCamera(SimulatedCamera(sim_scene(scenario), size=SIM_SIZE))


def open_sim_camera(scenario: Scenario) -> CameraInput:
    """The simulated camera's frames, with its own intrinsics."""
    camera = sim_camera(scenario)
    return CameraInput(camera, camera.camera.intrinsics, "simulated")
