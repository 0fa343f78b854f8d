"""The dashboard's pure parts, without a browser: tree layout, world at a node, edits."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from app.dashboard import scenario_edit
from app.dashboard.scenario_folders import RefusedName, ScenarioFolders
from app.dashboard.tree_layout import SpanningTree, layout
from app.execution.world import hands_x, place_parts, world_at
from planner.feasibility.robot import HOME
from planner.feasibility.scene import part_boxes, region_extents
from planner.plan.model import Plan
from planner.planning import plan_scenario
from planner.scenario.loading import load_scenario

ROOT = Path(__file__).resolve().parent.parent
DEFAULT = ROOT / "static" / "scenarios" / "default.toml"


@pytest.fixture(scope="module")
def doc(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    cache = tmp_path_factory.mktemp("cache")
    return plan_scenario(load_scenario(DEFAULT), workers=1, cache_dir=cache).plan.to_json()


def test_spanning_tree_covers_every_node_once(doc: dict[str, Any]) -> None:
    tree = SpanningTree.of(Plan.from_json(doc))
    assert set(tree.depth) == set(doc["nodes"])
    edges = sum(len(n["children"]) for n in doc["nodes"].values())
    assert len(tree.parent) + len(tree.shared) == edges
    leaf = next(n for n in doc["nodes"] if not doc["nodes"][n]["children"])
    lineage = tree.lineage(leaf)
    assert lineage[0] == doc["root"] and lineage[-1] == leaf


def test_layout_puts_parents_over_children_and_collapses(doc: dict[str, Any]) -> None:
    tree = SpanningTree.of(Plan.from_json(doc))
    full = layout(tree, set())
    assert set(full.positions) == set(doc["nodes"])
    for edge in (e for e in full.edges if not e.shared):
        assert full.positions[edge.child][1] > full.positions[edge.parent][1]
    # No two nodes on one spot.
    assert len(set(full.positions.values())) == len(full.positions)
    root = doc["root"]
    first = tree.children[root][0][1]
    folded = layout(tree, {first})
    assert folded.hidden_below[first] == tree.subtree_size(first) - 1
    assert len(folded.positions) == len(full.positions) - folded.hidden_below[first]
    # The default view keeps the expected branch open.
    collapsed = tree.default_collapsed(Plan.from_json(doc), budget=10)
    shown = layout(tree, collapsed).positions
    node = root
    while doc["nodes"][node]["children"]:
        assert node in shown
        kids = doc["nodes"][node]["children"]
        expected = doc["nodes"][node].get("expected")
        node = next((k["node"] for k in kids if k["outcome"] == expected), kids[0]["node"])


def test_world_at_a_node_shows_its_action_done(doc: dict[str, Any]) -> None:
    scenario = load_scenario(DEFAULT)
    boxes = part_boxes(scenario)
    edge = max(hi for _, hi in region_extents(scenario).values())
    tree = SpanningTree.of(Plan.from_json(doc))
    nodes = doc["nodes"]
    hold = next(i for i, n in nodes.items() if str(n["action"]).startswith("hold(left,"))
    part = nodes[hold]["action"][len("hold(left,") : -1]
    view = world_at(Plan.from_json(doc).nodes, tree.lineage(hold), boxes, human_edge_x=edge)
    assert view.parts[part].holder == "left"
    assert view.parts[part].z > boxes[part].top_z  # lifted off the bench
    assert view.arms["left"] == nodes[hold]["motion"]["path"][-1]
    assert view.arms["right"] == HOME["right"] or any(
        nodes[n].get("motion", {}).get("arm") == "right" for n in tree.lineage(hold)
    )
    placed = place_parts(
        boxes, ["attached(leg1,top,c1)", "attached(foot1,leg1,foot)"], human_edge_x=edge
    )
    top_c1 = boxes["top"].sites()["c1"]
    assert (placed["leg1"].x, placed["leg1"].y) == pytest.approx(top_c1)
    assert placed["foot1"].z > placed["leg1"].z > placed["top"].z
    assert placed["foot1"].attached_to == "leg1"
    human = place_parts(boxes, ["humanHoldingPart(leg2)"], human_edge_x=edge)
    assert human["leg2"].holder == "human" and human["leg2"].x == hands_x(edge) > edge
    # A longer bench moves the hands with its edge.
    further = place_parts(boxes, ["humanHoldingPart(leg2)"], human_edge_x=edge + 0.5)
    assert further["leg2"].x == pytest.approx(human["leg2"].x + 0.5)


def test_scenario_edits_validate_and_save(tmp_path: Path) -> None:
    loaded = scenario_edit.load_file("default.toml")
    assert loaded.scenario is not None
    changed = scenario_edit.edit(
        loaded.text, loaded.source, safety="strict", dangerous={"foot2": True},
        region={"leg1": "shared"},
    )  # fmt: skip
    assert changed.scenario is not None
    assert changed.scenario.preferences.safety == "strict"
    assert changed.scenario.part("foot2").dangerous
    assert changed.scenario.part("leg1").region == "shared"
    pose = changed.scenario.part("leg1").pose  # a free spot of its new region
    assert pose is not None and 0.65 <= pose[0] <= 1.00
    bad = scenario_edit.edit(loaded.text, loaded.source, region={"leg1": "moon"})
    assert bad.scenario is None and "moon" in bad.error and "\n" not in bad.error
    folders = ScenarioFolders(tmp_path / "scenarios")
    out = folders.save(changed.text, "mine.toml")
    assert out.parent == tmp_path / "scenarios"
    assert load_scenario(out).preferences.safety == "strict"
    with pytest.raises(RefusedName, match="exists"):
        folders.save(changed.text, "mine.toml")
    assert scenario_edit.load_named(folders, "mine.toml").scenario is not None
    assert scenario_edit.load_file(tmp_path / "missing.toml").error
    assert folders.names()[0] == "default.toml" and "mine.toml" in folders.names()


def test_the_scenario_choice_names_what_is_loaded(tmp_path: Path) -> None:
    from app.dashboard.scenario_panel import OTHER_FILE
    from app.dashboard.server import Dashboard, DashboardSettings
    from app.dashboard.stage import ScenarioChanged
    from tests.plan_fixtures import free_port

    mine = tmp_path / "scenarios"
    mine.mkdir()
    # A file of the user's folder shadows the shipped file of the same name.
    (mine / "declared.toml").write_text((ROOT / "static/scenarios/declared.toml").read_text())
    outside = tmp_path / "elsewhere" / "bench.toml"
    outside.parent.mkdir()
    outside.write_text(DEFAULT.read_text())
    shipped_declared = ROOT / "static" / "scenarios" / "declared.toml"
    dashboard = Dashboard(
        "127.0.0.1",
        free_port(),
        str(shipped_declared),
        DashboardSettings(data_dir=str(tmp_path), load_models=False),
    )
    panel = dashboard.scenario_panel
    try:
        # The command line's shipped file is shadowed: no choice names it.
        assert panel.pick.value == OTHER_FILE
        assert panel.pick.options[0] == OTHER_FILE
        dashboard.open_named("paper/paper-03.toml")
        assert panel.pick.value == "paper/paper-03.toml"
        assert OTHER_FILE not in panel.pick.options
        assert dashboard.loaded is not None and dashboard.loaded.source == "paper/paper-03.toml"
        # A choice in the page opens that scenario once.
        loads: list[str] = []
        dashboard.events.subscribe(ScenarioChanged, lambda e: loads.append(e.scenario.name))
        panel.pick.value = "declared.toml"
        assert loads == ["paper-base-declared"]
        assert dashboard.loaded.source == "declared.toml"
        # A file that does not load leaves the choice on the scenario that stays.
        (mine / "broken.toml").write_text('name = "broken"\n')
        panel.pick.options = dashboard.folders.names()
        panel.pick.value = "broken.toml"
        assert panel.error.content.startswith("**Error:** broken.toml")
        assert panel.pick.value == "declared.toml" and loads == ["paper-base-declared"]
        assert dashboard.folders.name_of(mine / "declared.toml") == "declared.toml"
        assert dashboard.folders.name_of(shipped_declared) is None
        assert dashboard.folders.name_of(outside) is None
        dashboard.open_scenario(ROOT / "static" / "scenarios" / "paper" / "paper-05.toml")
        assert panel.pick.value == "paper/paper-05.toml"
        dashboard.open_scenario(outside)  # in no scenario folder
        assert panel.pick.value == OTHER_FILE
        assert dashboard.loaded.source == str(outside)
        # Saving it offers it by its new name, and still shows it as the other file.
        panel.save_name.value = "saved.toml"
        panel.save()
        assert "saved.toml" in panel.pick.options and panel.pick.value == OTHER_FILE
        assert dashboard.loaded.source == str(outside)
    finally:
        dashboard.close()


def test_opening_a_scenario_is_no_edit_of_it(tmp_path: Path) -> None:
    from app.dashboard.server import Dashboard, DashboardSettings
    from app.dashboard.stage import ScenarioChanged
    from tests.plan_fixtures import free_port

    dashboard = Dashboard(
        "127.0.0.1",
        free_port(),
        "default.toml",
        DashboardSettings(data_dir=str(tmp_path), load_models=False),
    )
    panel = dashboard.scenario_panel
    try:
        # The fields show what was loaded; setting them is not an edit, so the
        # scenario stays the file as written (what "Save as" writes).
        assert dashboard.loaded is not None and dashboard.loaded.text == DEFAULT.read_text()
        heard: list[tuple[str, bool]] = []
        dashboard.events.subscribe(
            ScenarioChanged, lambda e: heard.append((e.scenario.name, e.edited))
        )
        panel.safety.value = "strict"  # as a page does
        assert heard == [("paper-base", True)]
        changed = "Scenario changed: not planned yet, press **Plan**."
        assert dashboard.plan_panel.status.content == changed
        # Opening another scenario sets "Safety" back to "normal": one change, the
        # opening, with the new scenario's parts as its file says.
        dashboard.open_named("declared.toml")
        declared = ROOT / "static" / "scenarios" / "declared.toml"
        assert heard == [("paper-base", True), ("paper-base-declared", False)]
        assert dashboard.loaded.text == declared.read_text()
        assert dashboard.plan_panel.status.content.startswith("Scenario **paper-base-declared**")
    finally:
        dashboard.close()


def test_one_label_per_assembly() -> None:
    from app.dashboard.bench_scene import label_words
    from app.execution.world import Placement

    parts = {
        "top": Placement(1.0, 0.0, 0.0),
        "leg1": Placement(0.9, 0.1, 0.1, attached_to="top"),
        "foot1": Placement(0.9, 0.1, 0.3, holder="left", attached_to="leg1"),
        "leg2": Placement(1.6, 0.2, 0.2, holder="human"),
        "foot2": Placement(0.5, -0.3, 0.0),
    }
    assert label_words(parts) == {
        "top": "top + foot1, leg1", "leg2": "leg2 (held by human)", "foot2": "foot2"
    }
    # With the scenario: each loose part's marker code, and its danger, stay said.
    from planner.scenario.loading import load_scenario
    from tests.plan_fixtures import SCENARIOS

    world = load_scenario(SCENARIOS / "real-world.toml")
    nail = next(p for p in world.parts if p.dangerous)
    words = label_words({"top": Placement(0.8, 0.0, 0.0),
                         nail.id: Placement(0.5, 0.0, 0.2, holder="left")}, world)  # fmt: skip
    assert words["top"] == "top #1"
    assert words[nail.id] == f"{nail.id} #{nail.marker} (dangerous, held by left)"
