"""The bench as perception needs it: regions, heights, extents and part shapes.

The app converts a scenario into a `BenchLayout`; perception never reads scenarios.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from perception.markers import DEFAULT_MARKER_SIZE_M, ReferenceMarker


@dataclass(frozen=True)
class Region:
    """A band of the bench along x."""

    id: str
    x_min: float
    x_max: float

    def contains(self, x: float) -> bool:
        return self.x_min <= x < self.x_max


@dataclass(frozen=True)
class PartShape:
    """A part's box size (x, y, z) in metres; for parts others attach to, each
    connection slot's (dx, dy) offset from the part's centre in the bench's axes; and
    where its code sits on its top face, from the face's centre in the part's own
    axes (a top's code sits off-centre, clear of the legs that stand on it).

    `outlines` are what its top face's outline may be ("circle", "square",
    "triangle", as `perception.outline` tells them apart): with more than one,
    perception looks at the face beside the code every frame it sees the code.
    """

    size: tuple[float, float, float]
    slots: dict[str, tuple[float, float]] = field(default_factory=dict)
    code_offset: tuple[float, float] = (0.0, 0.0)
    outlines: tuple[str, ...] = ()

    @property
    def outline_unknown(self) -> bool:
        return len(self.outlines) > 1


@dataclass(frozen=True)
class BenchLayout:
    regions: tuple[Region, ...]
    bench_top_z: float
    bench_x: tuple[float, float]
    bench_y: tuple[float, float]
    human_side_x: float  # past this x the part is off the bench, on the human's side
    parts: dict[str, PartShape]
    references: tuple[ReferenceMarker, ...]
    marker_size_m: float = DEFAULT_MARKER_SIZE_M
    # A part lifted off the bench at x below this is taken to be in the robot's
    # gripper, at or beyond it in the human's hands.
    lift_split_x: float = 1.0

    def region_at(self, x: float) -> str | None:
        for region in self.regions:
            if region.contains(x):
                return region.id
        if self.regions and x >= self.regions[-1].x_max and x <= self.bench_x[1]:
            return self.regions[-1].id  # the far edge belongs to the last region
        return None

    def on_bench(self, x: float, y: float) -> bool:
        return (
            self.bench_x[0] <= x <= self.bench_x[1] and self.bench_y[0] <= y <= self.bench_y[1]
        )
