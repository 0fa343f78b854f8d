"""The benchmark of Rizwan, Patoglu and Erdem (TPLP) as scenario files.

The paper's base instance has two unassembled legs (one only the robot
reaches, one only the human reaches), a dangerous foot in the shared region
and a top. Its three tables each grow one quantity from 2 to 6:

- family U (Table 1, instances 1-5): the number of unsafe parts, i.e.
  dangerous feet in the shared region; every extra foot brings an extra leg
  (in the shared region) so that the stable table still has a leg per foot;
- family P (Table 2, instances 6-10): the number of parts only the human
  reaches (legs in humanOnly);
- family R (Table 3, instances 11-15): the number of parts only the robot
  reaches (legs in robotOnly).

The paper does not publish its instance files, so this is our reading of its
"Problem Instances" paragraph; n = 7..10 continues each family past the
paper. `tandem scenario paper DIR` writes every file; tests/test_paper.py
checks that the committed files are exactly what this module produces.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from planner.scenario.sections import DEFAULT_REGION_X

FAMILIES = ("U", "P", "R")
PAPER_N = range(2, 7)  # the paper's tables: n = 2..6
CONTINUED_N = range(7, 11)  # beyond the paper, up to 10
TABLE_OF = {"U": 1, "P": 2, "R": 3}
WHAT = {
    "U": "dangerous (unsafe) feet",
    "P": "parts reachable by the human only",
    "R": "parts reachable by the robot only",
}

# The default bench's regions along x, and whether the human reaches them;
# the same three regions as the shipped default.toml.
HUMAN_REACH = {"robotOnly": False, "shared": True, "humanOnly": True}
EXTENT = DEFAULT_REGION_X
REGIONS = tuple((rid, x0, x1, HUMAN_REACH[rid]) for rid, (x0, x1) in EXTENT.items())

# A small model table: the top lies flat in the middle of the shared region,
# within both arms' top-down reach (x <= ~0.85 m, field notes); legs stand
# upright, feet lie flat. Sizes are x, y, z extents.
TOP_POSE = (0.78, 0.0, 0.0)
TOP_SIZE = (0.20, 0.36, 0.02)
LEG_SIZE = (0.04, 0.04, 0.20)
FOOT_SIZE = (0.04, 0.04, 0.03)
Y_RANGE = (-0.45, 0.45)
# Loose shared parts lie beside the top, alternately on the left arm's side (+y)
# and the right arm's, in columns along x that each arm reaches from above.
SHARED_X = (0.69, 0.76, 0.83)
SHARED_Y0 = 0.28  # clear of the top's edge at 0.18
SHARED_PITCH = 0.07
MIN_PITCH = 0.08  # centre-to-centre spacing of parts placed side by side in x


@dataclass(frozen=True)
class Loose:
    """A leg or foot of an instance, before it gets a pose."""

    id: str
    kind: str  # "leg" | "foot"
    region: str
    dangerous: bool = False


def instance_number(family: str, n: int) -> int | None:
    """The paper's instance number (1-15), or None past the paper's tables."""
    if n not in PAPER_N:
        return None
    return 5 * FAMILIES.index(family) + n - 1


def instance_name(family: str, n: int) -> str:
    """`paper-01`..`paper-15` for the paper's instances, `U07` etc. after them."""
    number = instance_number(family, n)
    return f"paper-{number:02d}" if number is not None else f"{family}{n:02d}"


def all_instances(families: bool = True, to: int = CONTINUED_N[-1]) -> list[tuple[str, int]]:
    """(family, n) in benchmark order: the paper's 15, then the continuations up to n=`to`."""
    out = [(f, n) for f in FAMILIES for n in PAPER_N]
    if families:
        out += [(f, n) for f in FAMILIES for n in range(CONTINUED_N[0], to + 1)]
    return out


def parts_of(family: str, n: int) -> list[Loose]:
    """Legs then feet, in file order (the stable goal pairs feet to legs in this order)."""
    if family not in FAMILIES or n < 2:
        raise ValueError(f"unknown instance {family}{n}: family in U, P, R and n >= 2")
    legs = [Loose("leg1", "leg", "robotOnly"), Loose("leg2", "leg", "humanOnly")]
    feet = [Loose("foot1", "foot", "shared", dangerous=True)]
    if family == "U":
        legs += [Loose(f"leg{i}", "leg", "shared") for i in range(3, n + 1)]
        feet += [Loose(f"foot{i}", "foot", "shared", dangerous=True) for i in range(2, n + 1)]
    else:
        region = "humanOnly" if family == "P" else "robotOnly"
        legs += [Loose(f"leg{i}", "leg", region) for i in range(3, n + 2)]
    return legs + feet


def goal_attachments(family: str, n: int) -> list[tuple[str, str]] | None:
    """Explicit goal pairs, or None where `table = "stable"` says the same thing.

    P and R have more legs than feet; the stable-table rule wants a foot under
    every leg (docs/scenario.md), so those instances list the prototype's goal
    instead: every leg on the top and foot1 under leg1.
    """
    loose = parts_of(family, n)
    legs = [p.id for p in loose if p.kind == "leg"]
    feet = [p.id for p in loose if p.kind == "foot"]
    if len(legs) == len(feet):
        return None
    return [(leg, "top") for leg in legs] + list(zip(feet, legs, strict=False))


def _layout(count: int, region: str) -> list[tuple[float, float]]:
    """`count` (x, y) spots on a grid inside `region`, row by row."""
    if region == "shared":
        return [_beside_top(i) for i in range(count)]
    x0, x1 = EXTENT[region]
    y0, y1 = Y_RANGE
    cols = max(1, min(count, int((x1 - x0) / MIN_PITCH)))
    rows = math.ceil(count / cols)
    spots = []
    for i in range(count):
        row, col = divmod(i, cols)
        x = x0 + (col + 0.5) * (x1 - x0) / cols
        y = y0 + (row + 0.5) * (y1 - y0) / rows
        spots.append((x, y))
    return spots


def _beside_top(i: int) -> tuple[float, float]:
    side = 1.0 if i % 2 == 0 else -1.0
    row, col = divmod(i // 2, len(SHARED_X))
    return (SHARED_X[col], side * (SHARED_Y0 + row * SHARED_PITCH))


def _num(v: float) -> str:
    # Millimetre precision, spelt as a TOML float (strict models reject ints),
    # so the files are byte-stable; `+ 0.0` turns -0.0 into 0.0.
    text = f"{round(v, 3) + 0.0:.3f}".rstrip("0")
    return text + "0" if text.endswith(".") else text


def _vec(values: Sequence[float]) -> str:
    return "[" + ", ".join(_num(v) for v in values) + "]"


def description(family: str, n: int) -> str:
    number = instance_number(family, n)
    where = (
        f"paper instance {number} (Table {TABLE_OF[family]})"
        if number is not None
        else "beyond the paper's tables"
    )
    return f"family {family}, n={n}: {n} {WHAT[family]}; {where}"


def scenario_toml(family: str, n: int, feasibility: str = "geometry") -> str:
    """The scenario file of instance (family, n), as TOML text.

    `feasibility = "declared"` writes the table the bench's layout is built for
    instead of asking the motion planner: each arm reaches the robot-only parts,
    the top and the shared parts on its own side (y > 0 is the left arm's).
    """
    if feasibility not in ("geometry", "declared"):
        raise ValueError(f"feasibility must be geometry or declared, not {feasibility!r}")
    loose = parts_of(family, n)
    placed = _placed(loose)
    out = _heading(family, n)
    out += _feasibility(feasibility, loose, placed)
    out += _parts(loose, placed)
    out += _goal(family, n)
    return "\n".join(out) + "\n"


def _heading(family: str, n: int) -> list[str]:
    """The lines before the feasibility: name, preferences, regions, robot."""
    out = [
        f"# Generated by planner/scenario/paper.py ({family}, n={n}); "
        "edit the generator, not this file.",
        f'name = "{instance_name(family, n)}"',
        f'description = "{description(family, n)}"',
        "",
        "[preferences]",
        'safety = "normal"',
        'verbosity = "normal"',
    ]
    for rid, x0, x1, reach in REGIONS:
        out += ["", "[[regions]]", f'id = "{rid}"', f"x = {_vec((x0, x1))}"]
        out += [f"human_reach = {str(reach).lower()}"]
    return out + ["", "[robot]", 'manipulators = ["left", "right"]']


def _placed(loose: Sequence[Loose]) -> dict[str, tuple[float, float]]:
    """Where each loose part lies: its region's layout, in the parts' order."""
    spots: dict[str, list[tuple[float, float]]] = {}
    for rid, *_ in REGIONS:
        spots[rid] = _layout(sum(p.region == rid for p in loose), rid)[::-1]
    return {part.id: spots[part.region].pop() for part in loose}


def _feasibility(
    feasibility: str, loose: Sequence[Loose], placed: dict[str, tuple[float, float]]
) -> list[str]:
    out = ["", "[feasibility]"]
    if feasibility == "geometry":
        # Which arm reaches which part is decided by the motion planner.
        return out + ['source = "geometry"']
    shared = [p.id for p in loose if p.region == "shared"]
    out += ['source = "declared"', "", "[feasibility.reachable]"]
    out += ['left = ["robotOnly", "shared"]', 'right = ["robotOnly", "shared"]']
    out += ["", "[feasibility.unreachable_parts]"]
    for arm, side in (("left", -1.0), ("right", 1.0)):
        ids = ", ".join(f'"{pid}"' for pid in shared if placed[pid][1] * side > 0)
        out += [f"{arm} = [{ids}]"]
    return out


def _parts(loose: Sequence[Loose], placed: dict[str, tuple[float, float]]) -> list[str]:
    """The top, with a connection per leg, then the loose parts where they lie."""
    legs = [p for p in loose if p.kind == "leg"]
    connections = ", ".join(f'"c{i}"' for i in range(1, len(legs) + 1))
    out = ["", "[[parts]]", 'id = "top"', 'kind = "top"', 'region = "shared"']
    out += [f"connections = [{connections}]", f"pose = {_vec(TOP_POSE)}"]
    out += [f"size = {_vec(TOP_SIZE)}", "marker = 1"]
    for marker, part in enumerate(loose, start=2):
        x, y = placed[part.id]
        out += ["", "[[parts]]", f'id = "{part.id}"', f'kind = "{part.kind}"']
        if part.kind == "leg":
            out += ['length = "tall"']
        out += ['shape = "square"', f'region = "{part.region}"']
        if part.dangerous:
            out += ["dangerous = true"]
        size = LEG_SIZE if part.kind == "leg" else FOOT_SIZE
        out += [f"pose = {_vec((x, y, 0.0))}", f"size = {_vec(size)}", f"marker = {marker}"]
    return out


def _goal(family: str, n: int) -> list[str]:
    out = ["", "[goal]"]
    pairs = goal_attachments(family, n)
    if pairs is None:
        return out + ['table = "stable"']
    return out + ["attachments = [", *(f'  ["{p}", "{q}"],' for p, q in pairs), "]"]


def generated_files(families: bool = True) -> dict[str, str]:
    """File name -> TOML text for every instance."""
    return {f"{instance_name(f, n)}.toml": scenario_toml(f, n) for f, n in all_instances(families)}
