"""What the page shows is the state it has: loads reset, buttons say what can be
done now, waits say what they wait for (real chromium, through the page)."""

from __future__ import annotations

import re
import threading
from collections.abc import Iterator

import pytest

pytest.importorskip("playwright.sync_api")
from playwright.sync_api import Browser, Page, expect  # noqa: E402

from app.dashboard.server import Dashboard  # noqa: E402
from app.execution.events import OutcomeSource  # noqa: E402
from app.execution.walker import Narrator  # noqa: E402
from app.sources.outcomes import ClickSource  # noqa: E402
from planner.plan.model import Plan  # noqa: E402
from planner.resources import scenario_dir  # noqa: E402
from planner.scenario.loading import load_scenario  # noqa: E402
from tests.test_dashboard import (  # noqa: E402
    choose,
    field,
    opened,
    plan_clicked,
    plan_shown,
    served,
    shot,
    wait_for,
)

SHIPPED = scenario_dir()


@pytest.fixture(scope="module")
def dashboard(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Dashboard]:
    with served(tmp_path_factory.mktemp("data")) as d:
        yield d


@pytest.fixture(scope="module")
def page(browser: Browser, dashboard: Dashboard) -> Iterator[Page]:
    with opened(browser, dashboard) as page:
        yield page


def test_loading_a_scenario_drops_the_edits_of_the_one_before(
    page: Page, dashboard: Dashboard
) -> None:
    page.get_by_text("Parts", exact=True).first.click()  # a folder, closed at first
    page.get_by_text("leg1 dangerous", exact=True).wait_for()
    box = field(page, "leg1 dangerous")
    box.check()  # type: ignore[attr-defined]
    wait_for(lambda: dashboard.loaded is not None and dashboard.loaded.scenario is not None
             and dashboard.loaded.scenario.part("leg1").dangerous, 20)  # fmt: skip
    page.get_by_text("unsaved edits", exact=False).first.wait_for()  # the edit is marked
    choose(page, "Scenario", "default-ko.toml")
    wait_for(lambda: dashboard.loaded is not None and dashboard.loaded.source == "default-ko.toml")
    expect(field(page, "leg1 dangerous")).not_to_be_checked()  # type: ignore[arg-type]
    assert dashboard.loaded.scenario is not None
    assert not dashboard.loaded.scenario.part("leg1").dangerous
    assert page.get_by_text("unsaved edits", exact=False).count() == 0
    field(page, "Save as").fill("copy-of-ko.toml")  # type: ignore[attr-defined]
    page.get_by_role("button", name="Save", exact=True).click()
    page.get_by_text("Saved as", exact=False).first.wait_for()
    saved = dashboard.folders.user.path / "copy-of-ko.toml"
    assert saved.read_text() == (SHIPPED / "default-ko.toml").read_text()
    choose(page, "Scenario", "default.toml")
    wait_for(lambda: dashboard.loaded is not None and dashboard.loaded.source == "default.toml")


def test_loading_a_scenario_resets_plan_statistics_selection_and_log(
    page: Page, dashboard: Dashboard
) -> None:
    plan_clicked(page, dashboard, 120)
    page.get_by_text("Statistics", exact=True).first.click()  # a folder, closed at first
    page.get_by_text("meaning").wait_for()  # the statistics
    dashboard.execution.speed.value = 0.0
    page.get_by_role("button", name="Execute plan", exact=True).click()
    wait_for(lambda: dashboard.execution.clicks is not None
             and dashboard.execution.clicks.pending() is not None, 30)  # fmt: skip
    page.get_by_role("button", name="Abort", exact=True).click()
    execution = dashboard.execution
    wait_for(lambda: not execution.running and not execution.start_button.disabled)
    page.get_by_text("Ended: aborted", exact=False).first.wait_for()
    choose(page, "Scenario", "default-ko.toml")
    wait_for(lambda: dashboard.loaded is not None and dashboard.loaded.source == "default-ko.toml")
    # Nothing of the other scenario's plan stays: no statistics, tree, selection, log.
    page.get_by_text("Not planned yet", exact=False).first.wait_for()
    assert page.get_by_text("meaning").count() == 0
    assert page.locator("svg.tandem-tree").count() == 0
    assert dashboard.selected is None and dashboard.plan is None
    page.get_by_text("No plan yet", exact=False).first.wait_for()
    assert page.get_by_text("The robot holds", exact=False).count() == 0
    expect(page.get_by_role("button", name="Execute plan", exact=True)).to_be_disabled()
    page.get_by_text("Click a node of the plan tree", exact=False).first.wait_for()
    shot(page, "state-after-load")
    choose(page, "Scenario", "default.toml")
    wait_for(lambda: dashboard.loaded is not None and dashboard.loaded.source == "default.toml")


def test_buttons_and_waits_say_what_is_happening(page: Page, dashboard: Dashboard) -> None:
    plan_clicked(page, dashboard, 120)
    execution = dashboard.execution
    execution.speed.value = 0.0
    page.get_by_role("button", name="Execute plan", exact=True).click()
    expect(page.get_by_role("button", name="Execute plan", exact=True)).to_be_disabled()
    wait_for(lambda: execution.clicks is not None and execution.clicks.pending() is not None, 30)
    offer = execution.clicks.pending() if execution.clicks else None
    assert offer is not None
    # The question waits: the tree and the selection show the asking node (they follow
    # the executor's event, which may come a moment after the offer).
    node = offer.node_id
    wait_for(lambda: dashboard.selected == node and dashboard.tree.marks.current == node, 10)
    page.get_by_text("waiting for an answer", exact=False).first.wait_for()
    asking = page.locator(f'svg.tandem-tree [data-node="{offer.node_id}"] rect[stroke="#ff7f0e"]')
    asking.wait_for()
    # Pause shows that it is paused, and Resume goes on.
    page.get_by_role("button", name="Pause", exact=True).click()
    page.get_by_role("button", name="Resume", exact=True).wait_for()
    page.get_by_text("Paused", exact=False).first.wait_for()
    assert execution.executor is not None and execution.executor.paused
    page.get_by_role("button", name="Resume", exact=True).click()
    page.get_by_role("button", name="Pause", exact=True).wait_for()
    assert not execution.executor.paused
    page.get_by_role("button", name="Abort", exact=True).click()
    wait_for(lambda: not execution.running)
    expect(page.get_by_role("button", name="Execute plan", exact=True)).to_be_enabled()
    expect(page.get_by_role("button", name="Pause", exact=True)).to_be_disabled()


def test_the_page_says_preparing_before_the_first_step(page: Page, dashboard: Dashboard) -> None:
    if not plan_shown(dashboard)():
        plan_clicked(page, dashboard, 120)
    execution = dashboard.execution
    # Preparing is held open (as loading a voice holds it) until the line is seen: on a
    # quick machine it is otherwise over before anyone could look.
    held = threading.Event()
    answers = execution.responses

    def slow_voice(plan: Plan, clicks: ClickSource) -> tuple[OutcomeSource, Narrator | None]:
        held.wait(30)
        return clicks, None

    execution.responses = slow_voice
    try:
        execution.start()  # as the button does: the line is set before preparing starts
        assert str(execution.status.content).startswith("**Preparing the execution")
        page.get_by_text("Preparing the execution", exact=False).first.wait_for()
        held.set()
        wait_for(lambda: execution.running, 30)
        page.get_by_text("Running", exact=False).first.wait_for()
    finally:
        held.set()
        execution.responses = answers
        wait_for(lambda: not execution.preparing, 30)
        if execution.executor is not None:
            execution.executor.abort()
        wait_for(lambda: not execution.running)


def _parts_open(page: Page) -> None:
    """Opens the Parts folder (closed at first) unless it is open."""
    # A loaded scenario's fields are made anew, in a closed folder.
    if not page.get_by_text("leg2 region", exact=True).first.is_visible():
        page.get_by_text("Parts", exact=True).first.click()
    page.get_by_text("leg2 region", exact=True).wait_for()


def _back_to_default(page: Page, dashboard: Dashboard) -> None:
    choose(page, "Scenario", "default-ko.toml")
    wait_for(lambda: dashboard.loaded is not None and dashboard.loaded.source == "default-ko.toml")
    choose(page, "Scenario", "default.toml")
    wait_for(lambda: dashboard.loaded is not None and dashboard.loaded.source == "default.toml")


def test_a_part_moved_in_the_editor_plans_where_it_was_put(
    page: Page, dashboard: Dashboard
) -> None:
    # leg2 to "shared": it used to lose its pose and lie across the top, and Plan said
    # "no plan", blaming leg1 and the top's reach.
    _parts_open(page)
    choose(page, "leg2 region", "shared")
    wait_for(lambda: dashboard.loaded is not None and dashboard.loaded.scenario is not None
             and dashboard.loaded.scenario.part("leg2").region == "shared", 20)  # fmt: skip
    assert dashboard.loaded.scenario is not None
    pose = dashboard.loaded.scenario.part("leg2").pose
    assert pose is not None and 0.65 <= pose[0] <= 1.00  # placed inside its new region
    plan_clicked(page, dashboard, 120)
    assert dashboard.plan is not None and dashboard.plan.statistics["L"] > 0
    assert page.get_by_text("no plan", exact=False).count() == 0
    shot(page, "editor-leg2-shared")
    field(page, "Save as").fill("leg2-shared.toml")  # type: ignore[attr-defined]
    wait_for(lambda: dashboard.scenario_panel.save_name.value == "leg2-shared.toml")
    page.get_by_role("button", name="Save", exact=True).click()
    page.get_by_text("Saved as", exact=False).first.wait_for()
    saved = dashboard.folders.user.path / "leg2-shared.toml"
    assert load_scenario(saved).part("leg2").pose == pose  # the file says where it stands
    _back_to_default(page, dashboard)


def test_save_as_refuses_a_name_with_a_space(page: Page, dashboard: Dashboard) -> None:
    _parts_open(page)
    before = sorted(dashboard.folders.user.path.glob("*"))
    field(page, "Save as").fill("a b.toml")  # type: ignore[attr-defined]
    wait_for(lambda: dashboard.scenario_panel.save_name.value == "a b.toml")
    page.get_by_role("button", name="Save", exact=True).click()
    page.get_by_text("a file name may have letters, digits", exact=False).first.wait_for()
    assert sorted(dashboard.folders.user.path.glob("*")) == before  # nothing written
    shot(page, "editor-refused-name")


def test_loading_a_scenario_drops_the_voice_of_the_one_before(
    page: Page, dashboard: Dashboard
) -> None:
    speech = dashboard.speech
    choose(page, "Scenario", "default-ko.toml")
    wait_for(lambda: dashboard.loaded is not None and dashboard.loaded.source == "default-ko.toml")
    plan_clicked(page, dashboard, 120)
    dashboard.execution.speed.value = 0.0
    page.get_by_role("button", name="Execute plan", exact=True).click()
    # The robot greets in Korean at once: the panel names the voice that spoke.
    wait_for(lambda: "(ko)" in str(speech.engine.content), 60)
    # On the page too, once the update reaches it (the server's copy changes first).
    page.get_by_text(re.compile(r"Voice:.*\(ko\)")).first.wait_for(timeout=30_000)
    wait_for(lambda: dashboard.execution.running, 30)
    page.get_by_role("button", name="Abort", exact=True).click()
    wait_for(lambda: not dashboard.execution.running, 30)
    choose(page, "Scenario", "default.toml")
    wait_for(lambda: dashboard.loaded is not None and dashboard.loaded.source == "default.toml")
    page.get_by_text("Voice: not spoken yet.", exact=True).first.wait_for()
    assert "(ko)" not in page.content()
