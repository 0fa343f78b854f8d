"""Where a part the editor moves to another region stands on the bench.

The layout lays out the parts without a pose on a grid of their region and
does not look at the parts placed by pose (planner/feasibility/scene.py), so
a part moved into a region of placed parts would land on them: leg2 moved to
"shared" lay across the top, and the planner then found the top out of reach.
A moved part therefore gets a pose of its own, at the free spot of its new
region nearest to where it would have gone: a gap from every other part's
footprint, inside the region and the bench. Pure.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from planner.feasibility.scene import BENCH_HALF_WIDTH, PartBox

GAP_M = 0.03  # between a moved part and any other, so a gripper fits between them
STEP_M = 0.005  # the spacing of the spots tried
ROUND_M = 0.001  # a pose is written to the millimetre: the gap looked for is that wider
Rect = tuple[float, float, float, float]  # x low, x high, y low, y high


class NoFreeSpot(ValueError):
    """No spot of the region is clear of the other parts; `str()` names the part."""


@dataclass(frozen=True)
class Spot:
    """A pose on the bench: x, y and yaw, as a scenario file writes it."""

    x: float
    y: float
    yaw: float

    def pose(self) -> list[float]:
        return [round(self.x, 3), round(self.y, 3), round(self.yaw, 3)]


def footprint(box: PartBox, x: float | None = None, y: float | None = None) -> Rect:
    """The box's footprint on the bench, as an axis-aligned rectangle around it
    (at `x`, `y` instead of where it stands, when given)."""
    cx = box.x if x is None else x
    cy = box.y if y is None else y
    c, s = abs(math.cos(box.yaw)), abs(math.sin(box.yaw))
    hx = (box.size[0] * c + box.size[1] * s) / 2
    hy = (box.size[0] * s + box.size[1] * c) / 2
    return (cx - hx, cx + hx, cy - hy, cy + hy)


def _meets(a: Rect, b: Rect, gap: float) -> bool:
    return a[0] < b[1] + gap and b[0] < a[1] + gap and a[2] < b[3] + gap and b[2] < a[3] + gap


def free_spot(
    part: PartBox,
    extent: tuple[float, float],
    region: str,
    others: Mapping[str, PartBox],
) -> Spot:
    """The spot of `region` (x in `extent`) nearest to its middle at the part's own y
    where `part`'s footprint keeps `GAP_M` from every one of `others`; `NoFreeSpot`."""
    lo, hi = extent
    half = footprint(part, 0.0, 0.0)
    xs = _steps(lo - half[0], hi - half[1])
    ys = _steps(-BENCH_HALF_WIDTH - half[2], BENCH_HALF_WIDTH - half[3])
    want = ((lo + hi) / 2, part.y)
    rects = [footprint(b) for b in others.values()]
    # Nearest first; of two as near, the one further left (+y), whatever the rounding.
    spots = sorted(
        ((x, y) for x in xs for y in ys), key=lambda p: (round(math.dist(p, want), 9), -p[1])
    )
    for x, y in spots:
        if not any(_meets(footprint(part, x, y), r, GAP_M + ROUND_M) for r in rects):
            return Spot(x, y, part.yaw)
    names = ", ".join(sorted(pid for pid, b in others.items() if b.region == region))
    if not names:
        raise NoFreeSpot(f"{part.id}: too large for {region}; give it a pose in the file")
    raise NoFreeSpot(
        f"{part.id}: no free place for it in {region} beside {names}; move one of "
        f"them elsewhere first, or give {part.id} a pose in the file"
    )


def _steps(lo: float, hi: float) -> Iterable[float]:
    """Spots from `lo` to `hi` every `STEP_M` (none when the part does not fit)."""
    count = int(math.floor((hi - lo) / STEP_M + 1e-9)) + 1
    return [lo + i * STEP_M for i in range(max(count, 0))]
