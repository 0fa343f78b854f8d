"""The bench's part labels on the default camera's picture (app/dashboard/label_layout.py)."""

from __future__ import annotations

from app.dashboard.label_layout import label_box, laid_out
from app.dashboard.view_panel import CAMERAS

BENCH = CAMERAS["Bench"]


def _meets(a: tuple[float, float, float, float], b: tuple[float, float, float, float]) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def test_labels_at_one_spot_are_spread_until_none_covers_another() -> None:
    crowded = {f"p{i}": (1.0 + 0.02 * i, 0.0, 0.0) for i in range(6)}
    texts = {pid: f"{pid} (held by human)" for pid in crowded}
    placed = laid_out(BENCH, crowded, texts)
    boxes = [label_box(BENCH, placed[p], texts[p]) for p in crowded]
    for i, a in enumerate(boxes):
        for b in boxes[i + 1:]:
            assert not _meets(a, b), (a, b)


def test_a_held_parts_label_goes_above_the_assembly_it_covered() -> None:
    # A foot held up by the right arm, in front of the top's assembly, covered its
    # label: the lower label stays, the held one goes up.
    texts = {"top": "top + foot1, leg1", "foot2": "foot2 (held by right)"}
    anchors = {"top": (0.85, 0.0, 0.10), "foot2": (0.72, -0.25, 0.22)}
    assert _meets(*(label_box(BENCH, anchors[p], texts[p]) for p in ("top", "foot2")))
    spread = laid_out(BENCH, anchors, texts)
    assert spread["top"] == anchors["top"] and spread["foot2"][2] > anchors["foot2"][2]
    assert not _meets(*(label_box(BENCH, spread[p], texts[p]) for p in ("top", "foot2")))


def test_a_regions_label_stays_and_a_parts_label_on_it_goes_up() -> None:
    region = ((0.475, -0.25, 0.0), "robotOnly (robot only)")
    lifted = laid_out(BENCH, {"foot10": (0.45, -0.25, 0.0)}, {}, [region])
    assert lifted["foot10"][2] > 0.0
    assert not _meets(label_box(BENCH, lifted["foot10"], "foot10"), label_box(BENCH, *region))


def test_labels_far_apart_stay_where_their_parts_are() -> None:
    anchors = {"leg1": (0.4, 0.2, 0.05), "leg2": (1.3, -0.2, 0.05)}
    assert laid_out(BENCH, anchors, {}) == anchors


def test_the_21_labels_of_u10_are_all_clear() -> None:
    """The paper's U10 bench as the dashboard first draws it: long labels (marker
    codes, "dangerous") in a crowd; none may cover another."""
    from app.dashboard.bench_scene import label_words
    from app.execution.world import Placement
    from planner.feasibility.scene import BENCH_TOP_Z, part_boxes
    from planner.scenario.loading import load_scenario
    from tests.plan_fixtures import SCENARIOS

    scenario = load_scenario(SCENARIOS / "paper" / "U10.toml")
    anchors = {pid: (box.x, box.y, BENCH_TOP_Z + box.size[2] + 0.03)
               for pid, box in part_boxes(scenario).items()}  # fmt: skip
    texts = label_words({p: Placement(*anchors[p]) for p in anchors}, scenario)
    assert len(anchors) == 21 and any("dangerous" in t for t in texts.values())
    placed = laid_out(BENCH, anchors, texts)
    boxes = [label_box(BENCH, placed[p], texts[p]) for p in anchors]
    for i, a in enumerate(boxes):
        for b in boxes[i + 1:]:
            assert not _meets(a, b), (a, b)
