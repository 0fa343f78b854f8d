"""The panels' own rules, without a viser server: what the Scenario choice shows,
what a load, an edit and "Save as" do, the Plan panel's lines and button, the
Selected node panel's buttons, and where the View panel puts the camera."""

from __future__ import annotations

import html
from pathlib import Path

import pytest

from app.dashboard import scenario_edit
from app.dashboard.node_details import STAT_WORDS, stats_html
from app.dashboard.node_panel import node_view
from app.dashboard.plan_panel import (
    HERE,
    RAY,
    LiveRedraw,
    cluster_address,
    plan_refused,
    progress_percent,
    scenario_line,
    status_line,
)
from app.dashboard.planning_job import JobStatus
from app.dashboard.scenario_folders import ScenarioFolders
from app.dashboard.scenario_panel import OTHER_FILE, Edits, OpenScenario, offer
from app.dashboard.stage import Events, NodeSelected, PlanChanged, Planned
from app.dashboard.tree_layout import SpanningTree
from planner.plan.model import STAT_KEYS, Plan
from planner.resources import scenario_dir
from tests.plan_fixtures import default_plan

SHIPPED = scenario_dir()


@pytest.fixture
def folders(tmp_path: Path) -> ScenarioFolders:
    """The user's folder, where a copy of declared.toml shadows the shipped one."""
    mine = tmp_path / "scenarios"
    mine.mkdir()
    (mine / "declared.toml").write_text((SHIPPED / "declared.toml").read_text())
    return ScenarioFolders(mine)


# -- the Scenario panel ---------------------------------------------------------


def test_the_choice_names_the_loaded_scenario_or_another_file(
    folders: ScenarioFolders, tmp_path: Path
) -> None:
    names = folders.names()
    assert offer(folders, "paper/paper-03.toml").value == "paper/paper-03.toml"
    assert offer(folders, "paper/paper-03.toml").options == names
    # A path in a folder is offered by the name it has there...
    assert offer(folders, str(SHIPPED / "paper" / "paper-05.toml")).value == "paper/paper-05.toml"
    assert offer(folders, str(folders.user.path / "declared.toml")).value == "declared.toml"
    # ...but not a shipped file behind a user's file of the same name, nor a file
    # outside every folder: "(another file)", offered first.
    outside = tmp_path / "elsewhere.toml"
    outside.write_text((SHIPPED / "default.toml").read_text())
    for source in (str(SHIPPED / "declared.toml"), str(outside), None):
        chosen = offer(folders, source)
        assert chosen.value == OTHER_FILE and chosen.options == [OTHER_FILE, *names]


def test_a_choice_loads_once_and_a_bad_file_keeps_the_last_good_one(
    folders: ScenarioFolders,
) -> None:
    scenario = OpenScenario(folders)
    good = scenario.take(scenario_edit.load_named(folders, "paper/paper-03.toml"))
    assert good.scenario is not None and good.error == ""
    assert scenario.offer().value == "paper/paper-03.toml"
    # Setting the choice to what is loaded reads as no new choice.
    assert not scenario.is_new_choice("paper/paper-03.toml")
    assert scenario.is_new_choice("declared.toml")
    (folders.user.path / "broken.toml").write_text('name = "broken"\n')
    bad = scenario.take(scenario_edit.load_named(folders, "broken.toml"))
    assert bad.scenario is None and bad.error is not None
    assert bad.error.startswith("**Error:** broken.toml") and "\n" not in bad.error
    assert scenario.loaded is not None and scenario.loaded.source == "paper/paper-03.toml"
    assert scenario.offer().value == "paper/paper-03.toml"  # the choice goes back


def test_an_edit_makes_the_plan_stale_only_when_it_changes_the_scenario(
    folders: ScenarioFolders,
) -> None:
    scenario = OpenScenario(folders)
    assert scenario.edit(Edits("strict", "normal")).scenario is None  # nothing loaded
    loaded = scenario.take(scenario_edit.load_file("default.toml")).scenario
    assert loaded is not None
    verbosity = loaded.preferences.verbosity
    strict = scenario.edit(Edits("strict", verbosity, dangerous={"foot2": True}))
    assert strict.scenario is not None and strict.error == ""
    assert strict.scenario.preferences.safety == "strict"
    assert strict.scenario.part("foot2").dangerous
    assert scenario.loaded is not None and scenario.loaded.scenario is strict.scenario
    # The same fields again change nothing: the plan made since stays.
    unchanged = scenario.edit(Edits("strict", verbosity, dangerous={"foot2": True}))
    assert unchanged.scenario is None and unchanged.error is None
    # An edit that does not validate is said, and the last good scenario stays.
    moon = scenario.edit(Edits("strict", verbosity, region={"leg1": "moon"}))
    assert moon.scenario is None and moon.error is not None
    assert moon.error.startswith("**Error:** ") and "moon" in moon.error
    assert scenario.loaded.scenario is strict.scenario


def test_save_as_writes_a_new_file_in_the_users_folder(
    folders: ScenarioFolders, tmp_path: Path
) -> None:
    scenario = OpenScenario(folders)
    assert scenario.save("mine.toml") is None  # nothing loaded, nothing written
    outside = tmp_path / "elsewhere.toml"
    outside.write_text((SHIPPED / "default.toml").read_text())
    scenario.take(scenario_edit.load_file(outside))
    saved = scenario.save("mine")
    assert saved is not None and saved.ok
    assert saved.line == "Saved as `mine.toml` in your scenario folder."
    assert (folders.user.path / "mine.toml").read_text() == outside.read_text()
    # What is loaded stays the file outside; the choice offers the copy too.
    chosen = scenario.offer()
    assert chosen.value == OTHER_FILE and "mine.toml" in chosen.options
    again = scenario.save("mine.toml")
    assert again is not None and not again.ok and "exists" in again.line
    refused = scenario.save("sub/x.toml")
    assert refused is not None and refused.line.startswith("**Error:** sub/x.toml")


def test_save_as_says_when_the_users_folder_cannot_be_written(tmp_path: Path) -> None:
    blocked = tmp_path / "scenarios"
    blocked.write_text("a file where the folder should be")
    scenario = OpenScenario(ScenarioFolders(blocked))
    scenario.take(scenario_edit.load_file("default.toml"))
    saved = scenario.save("mine.toml")
    assert saved is not None and not saved.ok
    assert saved.line.startswith("**Error:** cannot save in your scenario folder: ")


# -- the Plan panel -------------------------------------------------------------


def test_solve_on_gives_the_ray_address_or_this_machine() -> None:
    assert cluster_address(HERE, "ray://head:10001") is None
    assert cluster_address(RAY, "  ray://head:10001 ") == "ray://head:10001"
    assert cluster_address(RAY, "   ") == "auto"


def test_the_plan_panels_lines() -> None:
    planning = JobStatus("planning", done=3, open=1, seconds=1.25, message="planning")
    assert status_line(planning) == "Planning: 3 nodes done, 1 open (1.2 s)"
    assert progress_percent(planning) == 75.0
    assert progress_percent(JobStatus("planning")) == 0.0
    failed = JobStatus("failed", message="no plan: the goal cannot be reached")
    assert status_line(failed) == failed.message and progress_percent(failed) == 100.0
    scenario = scenario_edit.load_file("default.toml").scenario
    assert scenario is not None
    parts = len(scenario.parts)
    assert scenario_line(scenario, edited=False) == (
        f"Scenario **paper-base** ({parts} parts): not planned yet."
    )
    assert scenario_line(scenario, edited=True) == (
        "Scenario changed: not planned yet, press **Plan**."
    )


def test_nobody_plans_during_an_execution_or_twice_at_once() -> None:
    assert not plan_refused(executing=False, planning=False)
    assert plan_refused(executing=True, planning=False)
    assert plan_refused(executing=False, planning=True)


def test_the_growing_tree_is_redrawn_at_most_twice_a_second() -> None:
    live = LiveRedraw(every_s=0.5)
    assert live.due(10.0)
    assert not live.due(10.2) and not live.due(10.5)
    assert live.due(10.6)
    assert not live.due(10.7)
    # A redraw that took 0.1 s waits 2 s (5 % of the time), not 0.5 s.
    live.spent(0.1)
    assert not live.due(12.5) and live.due(12.7)


def test_the_statistics_table_has_every_column_of_the_plan_and_its_meaning() -> None:
    plan = default_plan()
    table = stats_html(plan)
    assert plan.stats is not None
    cell = "<td style='text-align:right;padding:0 6px'>"
    for key in STAT_KEYS:
        words = html.escape(STAT_WORDS[key])
        assert f"<td><b>{key}</b></td>{cell}{plan.stats[key]}</td>" in table
        assert f"<td style='color:#555'>{words}</td>" in table and len(words) > 10
    partial = Plan.from_json({**plan.to_json(), "stats": None})
    assert partial.partial
    assert f"<td><b>N</b></td>{cell}</td>" in stats_html(partial)


# -- the Selected node panel ----------------------------------------------------


def test_a_nodes_buttons_go_to_its_children_and_its_parent() -> None:
    plan = default_plan()
    tree = SpanningTree.of(plan)

    def selected(node_id: str) -> NodeSelected:
        lineage = tree.lineage(node_id)
        return NodeSelected(node_id, plan.nodes[node_id], lineage[-2] if len(lineage) > 1 else None)

    root = node_view(selected(plan.root))
    (child,) = plan.nodes[plan.root].children
    assert root.parent is None and root.foldable
    assert root.children == {"next": child.node}  # a deterministic action's one child
    sensing_id = next(n for n, node in plan.nodes.items() if len(node.children) > 1)
    sensing = node_view(selected(sensing_id))
    kids = plan.nodes[sensing_id].children
    assert sensing.children == {str(k.outcome): k.node for k in kids}
    assert sensing.parent == tree.lineage(sensing_id)[-2]
    assert f"`{sensing_id}`" in sensing.details and "Outcomes:" in sensing.details
    leaf_id = next(n for n, node in plan.nodes.items() if not node.children)
    leaf = node_view(selected(leaf_id))
    assert not leaf.foldable and leaf.children == {} and leaf.parent is not None


# -- the bus between them -------------------------------------------------------


def test_the_bus_delivers_each_message_to_its_own_subscribers_in_order() -> None:
    events = Events()
    heard: list[str] = []
    plan = default_plan()
    events.subscribe(Planned, lambda m: heard.append(f"view {m.plan.root}"))
    events.subscribe(PlanChanged, lambda m: heard.append(f"stats {m.plan is not None}"))
    events.subscribe(Planned, lambda m: heard.append("second"))
    events.publish(Planned(plan))
    events.publish(PlanChanged(None))
    assert heard == [f"view {plan.root}", "second", "stats False"]
