"""The scenario editor's edits, as text and as the planner reads them (no browser:
the page's own tests are in test_dashboard_state.py)."""

from __future__ import annotations

import difflib
import subprocess
import sys
from pathlib import Path

import pytest

from app.dashboard import scenario_edit
from app.dashboard.region_move import GAP_M, footprint
from app.dashboard.scenario_folders import RefusedName, ScenarioFolders
from planner.feasibility.scene import part_boxes, region_extents
from planner.planning import plan_scenario
from planner.resources import scenario_path
from planner.scenario.loading import ScenarioError, load_scenario, parse_scenario

DEFAULT = scenario_path("default.toml").read_text()


def _meet(a: tuple[float, ...], b: tuple[float, ...]) -> bool:
    return a[0] < b[1] and b[0] < a[1] and a[2] < b[3] and b[2] < a[3]


def test_a_part_moved_among_placed_parts_stands_clear_of_them_and_plans(
    tmp_path: Path,
) -> None:
    moved = scenario_edit.edit(DEFAULT, "default.toml", region={"leg2": "shared"})
    scenario = moved.scenario
    assert scenario is not None, moved.error
    leg2 = scenario.part("leg2")
    assert leg2.region == "shared" and leg2.pose is not None  # the saved file has its pose
    boxes = part_boxes(scenario)
    lo, hi = region_extents(scenario)["shared"]
    mine = footprint(boxes["leg2"])
    assert lo <= mine[0] and mine[1] <= hi
    for pid, box in boxes.items():
        if pid != "leg2":
            grown = footprint(box)
            grown = (grown[0] - GAP_M, grown[1] + GAP_M, grown[2] - GAP_M, grown[3] + GAP_M)
            assert not _meet(mine, grown), pid
    # The planner reads the bench the editor meant: leg2 beside the top, not across it.
    result = plan_scenario(scenario, workers=1, cache_dir=tmp_path / "cache")
    assert not result.plan.partial and result.plan.statistics["L"] > 0


def test_a_part_left_without_a_pose_among_placed_parts_is_refused_by_the_check(
    tmp_path: Path,
) -> None:
    # What the editor wrote before: leg2 in "shared" without a pose, laid out over the
    # top; the planner then blamed leg1 and the top's reach, and the check said ok.
    text = DEFAULT.replace('region = "humanOnly"\npose = [1.20, 0.0, 0.0]\n',
                           'region = "shared"\n')  # fmt: skip
    assert text != DEFAULT
    with pytest.raises(ScenarioError) as caught:
        parse_scenario(text, "moved.toml")
    assert caught.value.field == "parts[2].pose" and "leg2" in caught.value.message
    path = tmp_path / "moved.toml"
    path.write_text(text)
    check = subprocess.run(
        [sys.executable, "-m", "app.cli.main", "scenario", "check", str(path)],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert check.returncode == 2, check.stdout
    lines = check.stderr.strip().splitlines()
    assert len(lines) == 1 and "parts[2].pose" in lines[0] and "give leg2 a pose" in lines[0]
    # A region whose parts all go without a pose is laid out as one grid: still fine.
    bare = "\n".join(line for line in DEFAULT.splitlines() if not line.startswith("pose"))
    assert parse_scenario(bare, "bare.toml").part("leg2").pose is None
    moved = scenario_edit.edit(bare, "bare.toml", region={"leg2": "shared"})
    assert moved.scenario is not None and moved.scenario.part("leg2").pose is None


def test_a_part_with_no_room_in_its_new_region_is_refused_naming_it() -> None:
    moved = scenario_edit.edit(DEFAULT, "default.toml", region={"top": "robotOnly"})
    assert moved.scenario is None
    assert moved.error.startswith("default.toml: top: no free place for it in robotOnly")
    assert "leg1" in moved.error and "\n" not in moved.error


def test_edits_keep_the_files_comments_and_layout() -> None:
    edited = scenario_edit.edit(
        DEFAULT, "default.toml", safety="strict", dangerous={"foot2": True},
        region={"leg2": "shared"},
    )  # fmt: skip
    assert edited.scenario is not None
    before, after = DEFAULT.splitlines(), edited.text.splitlines()
    # Every comment and every array as the file writes them stay; only the edited
    # values' lines differ.
    assert [line for line in before if line.startswith("#")] == [
        line for line in after if line.startswith("#")
    ]
    assert 'x = [0.30, 0.65]' in after and 'manipulators = ["left", "right"]' in after
    diff = list(difflib.ndiff(before, after))
    assert [line[2:] for line in diff if line.startswith("- ")] == [
        'safety = "normal"', 'region = "humanOnly"', "pose = [1.20, 0.0, 0.0]",
        "dangerous = false",
    ]  # fmt: skip
    added = [line[2:] for line in diff if line.startswith("+ ")]
    pose = edited.scenario.part("leg2").pose
    assert added == ['safety = "strict"', 'region = "shared"', f"pose = {pose}",
                     "dangerous = true"]  # fmt: skip
    # Undone, the edits give the file back as it was (no "Unsaved edits" left).
    undone = scenario_edit.edit(
        edited.text, "default.toml", safety="normal", dangerous={"foot2": False},
        region={"leg2": "humanOnly"},
    )  # fmt: skip
    assert undone.scenario is not None
    back = undone.scenario.part("leg2").pose  # a free spot of humanOnly, at leg2's y now
    assert back is not None and back[1] == pose[1]
    assert undone.text.replace(f"pose = {back}", "pose = [1.20, 0.0, 0.0]") == DEFAULT
    # A value the file leaves out is not written when the edit gives it its default.
    same = scenario_edit.edit(DEFAULT, "default.toml", safety="normal", verbosity="normal",
                              dangerous={"leg1": False})  # fmt: skip
    assert same.text == DEFAULT


def test_save_as_takes_a_plain_file_name_only(tmp_path: Path) -> None:
    folders = ScenarioFolders(tmp_path / "scenarios")
    with pytest.raises(RefusedName) as caught:
        folders.save(DEFAULT, "a b.toml")
    line = str(caught.value)
    assert line.startswith("a b.toml: a file name may have letters, digits") and "\n" not in line
    assert not (tmp_path / "scenarios" / "a b.toml").exists()
    for name in ("my-bench.toml", "bench_2.toml", "v1.2.toml", "작업대.toml", "plain"):
        assert folders.save(DEFAULT, name).parent == tmp_path / "scenarios"
    assert load_scenario(tmp_path / "scenarios" / "plain.toml").name == "paper-base"
