"""The Live camera panel in a real browser (Debian's chromium driven by playwright):
the annotated frame of the simulated camera, an execution whose sensing nodes the
camera answers after each click has moved the simulated human, the deciding frame
in the review, a surprise the live camera sees planned again from, and a missing
camera said in one line while clicks answer."""

from __future__ import annotations

import time
from collections.abc import Iterator

import cv2
import numpy as np
import pytest

pytest.importorskip("playwright.sync_api")
from playwright.sync_api import Browser, Page, expect  # noqa: E402

from app.dashboard.camera_panel import VIEW_WIDTH  # noqa: E402
from app.dashboard.server import Dashboard, DashboardSettings  # noqa: E402
from app.execution.events import REPAIR  # noqa: E402
from app.execution.walker import Executor  # noqa: E402
from app.responses.camera import LiveAnswers  # noqa: E402
from app.sim.human import SimulatedHuman, SimulatedWorld  # noqa: E402
from perception.annotate import PART_COLOUR, REFERENCE_COLOUR  # noqa: E402
from planner.plan.model import Plan  # noqa: E402
from planner.vocabulary import SenseHumanAttachingWhere  # noqa: E402
from tests.camera_runs import PutsItDownInstead  # noqa: E402
from tests.test_dashboard import (  # noqa: E402
    ARTIFACTS,
    free_port,
    open_page,
    plan_clicked,
    shot,
    wait_for,
)


@pytest.fixture(scope="module")
def dashboard(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Dashboard]:
    # No robot meshes: the camera panel does not need them, and they cost seconds.
    d = Dashboard(
        "127.0.0.1",
        free_port(),
        "default.toml",
        DashboardSettings(
            workers=1,
            cache_dir=str(tmp_path_factory.mktemp("cache")),
            data_dir=str(tmp_path_factory.mktemp("data")),
            load_models=False,
        ),
    )
    yield d
    d.close()


@pytest.fixture(scope="module")
def page(browser: Browser, dashboard: Dashboard) -> Iterator[Page]:
    page = open_page(browser, dashboard, "Tandem", height=1000)
    yield page
    page.close()


def image_widths(page: Page) -> list[int]:
    widths: list[int] = page.evaluate("Array.from(document.images).map(i => i.naturalWidth)")
    return widths


def colour_pixels(image: np.ndarray, bgr: tuple[int, int, int]) -> int:
    return int(np.all(np.abs(image.astype(int) - np.array(bgr)) <= 30, axis=2).sum())


def stop_camera(page: Page, dashboard: Dashboard) -> None:
    """Start is off while a camera runs; Stop leaves no stale frame."""
    panel = dashboard.camera_panel
    if panel.live is None:
        return
    expect(page.get_by_role("button", name="Start camera", exact=True)).to_be_disabled()
    page.get_by_role("button", name="Stop camera", exact=True).click()
    wait_for(lambda: panel.live is None and not panel.view.visible)
    expect(page.get_by_role("button", name="Start camera", exact=True)).to_be_enabled()


def test_the_panel_shows_the_annotated_frame(page: Page, dashboard: Dashboard) -> None:
    page.get_by_role("button", name="Start camera", exact=True).click()  # its own panel
    page.get_by_text("it answers the sensing nodes", exact=False).wait_for()
    panel = dashboard.camera_panel
    wait_for(lambda: panel.last_annotated is not None, 30)
    # The page shows the frame: an image as wide as the panel sends it.
    wait_for(lambda: VIEW_WIDTH in image_widths(page), 30)
    page.get_by_text("on the bench in humanOnly", exact=False).first.wait_for()
    page.get_by_text("codes; camera located", exact=False).wait_for()
    page.locator("img").last.scroll_into_view_if_needed()
    time.sleep(0.5)
    shot(page, "camera-panel")
    live = panel.live
    assert live is not None
    view = live.latest()
    assert view is not None and len(view.perceived.observation.detections) == 9
    # Boxes around the five part codes and the four references are drawn on it.
    annotated = panel.last_annotated
    assert annotated is not None
    cv2.imwrite(str(ARTIFACTS / "camera-annotated.png"), annotated)
    assert colour_pixels(annotated, PART_COLOUR) > 2000
    assert colour_pixels(annotated, REFERENCE_COLOUR) > 1000
    assert colour_pixels(annotated, (0, 0, 230)) > 100  # the bench's x axis
    answers = dashboard.execution.camera
    assert isinstance(answers, LiveAnswers) and answers.live is live


def execute_clicking_first(page: Page, dashboard: Dashboard) -> Executor:
    """Executes the shown plan from the page, clicking each question's first answer."""
    dashboard.execution.speed.value = 0.0
    wait_for(lambda: not dashboard.execution.start_button.disabled)
    page.get_by_role("tab", name="Execution").click()  # a review may stand in front
    page.get_by_role("button", name="Execute plan", exact=True).click()
    wait_for(lambda: dashboard.execution.executor is not None and dashboard.execution.running)
    executor = dashboard.execution.executor
    assert executor is not None
    while not executor.done:
        clicks = dashboard.execution.clicks
        offer = clicks.pending() if clicks else None
        if offer is None:
            time.sleep(0.05)
            continue
        # A click says what the simulated human does; the camera has to see it.
        try:
            page.get_by_role("button", name=offer.words[0], exact=True).click(timeout=5000)
        except Exception:
            pass  # the buttons went while playwright looked at them: the loop looks again
        wait_for(lambda o=offer, c=clicks: c.pending() != o or executor.done, 60)
    return executor


def test_the_camera_answers_an_execution(page: Page, dashboard: Dashboard) -> None:
    plan_clicked(page, dashboard, 120)
    executor = execute_clicking_first(page, dashboard)
    assert executor.result == "goal", executor.events
    session_id = dashboard.execution.session_id
    assert session_id is not None
    wait_for(lambda: dashboard.store.get(session_id).result == "goal")
    events = dashboard.store.events(session_id, with_jpeg=True)
    sensing = [e for e in events if e.kind == "sensing"]
    assert sensing and all(e.source == "camera" for e in sensing), sensing
    for e in sensing:
        assert e.evidence is not None and e.evidence.jpeg is not None
        assert e.evidence.truth is not None and e.evidence.truth.label == e.outcome
        # From the human's act to the answer, with frames at 30 fps.
        assert e.evidence.camera is not None and e.evidence.camera.seconds < 2.0
    questions = [e for e in events if e.kind == "communication" and e.outcome]
    assert all(e.source == "click" for e in questions)
    page.get_by_text("(by the camera,", exact=False).first.wait_for()
    # The review shows the deciding frame beside a camera answer.
    page.get_by_role("tab", name="Review").click()
    page.get_by_role("button", name="Refresh list", exact=True).click()
    page.get_by_role("button", name="Open session", exact=True).click()
    wait_for(lambda: dashboard.review.opened == session_id)
    k = next(i for i, e in enumerate(dashboard.review.events) if e.source == "camera")
    dashboard.review.show_step(k)
    assert dashboard.review.frame.visible
    wait_for(lambda: 320 in image_widths(page), 30)
    page.get_by_text("answered by the camera:", exact=False).first.wait_for()
    shot(page, "camera-review")
    page.get_by_role("tab", name="Execution").click()


def test_a_surprise_the_live_camera_sees_is_repaired(page: Page, dashboard: Dashboard) -> None:
    """The simulated human, at the first question of where a part was attached, puts
    the part down instead: no branch expects that. The live camera (the code path of
    a real webcam: its views, the same camera source) sees it, and the execution
    plans again from what was seen; the store keeps the repair."""
    panel = dashboard.camera_panel
    humans: list[PutsItDownInstead] = []

    def human(plan: Plan, world: SimulatedWorld) -> SimulatedHuman:
        humans.append(PutsItDownInstead(plan, world, seed=0))
        return humans[-1]

    panel.simulated_human = human
    try:
        panel.kind.value = "simulated"
        stop_camera(page, dashboard)
        page.get_by_role("button", name="Start camera", exact=True).click()
        wait_for(lambda: isinstance(dashboard.execution.camera, LiveAnswers)
                 and dashboard.execution.camera.human is human, 30)  # fmt: skip
        if dashboard.plan is None or dashboard.plan.partial:
            plan_clicked(page, dashboard, 120)
        executor = execute_clicking_first(page, dashboard)
    finally:
        panel.simulated_human = SimulatedHuman
    assert executor.result == "goal", executor.events
    (put_down,) = humans
    assert put_down.surprised_at is not None, "the plan never asked where a part went"
    session_id = dashboard.execution.session_id
    assert session_id is not None
    wait_for(lambda: dashboard.store.get(session_id).result == "goal")
    events = dashboard.store.events(session_id, with_jpeg=True)
    (repair,) = [e for e in events if e.kind == REPAIR]
    assert repair.node == put_down.surprised_at and repair.source == "camera"
    asked = repair.action
    assert isinstance(asked, SenseHumanAttachingWhere)
    assert repair.evidence is not None
    assert repair.evidence.replanned is not None
    assert repair.evidence.replanned.surprise == f"putdown {asked.part}"
    assert repair.text is not None and f"I see you put the {asked.part} down" in repair.text
    # The camera answered on after the repair, on the new plan.
    after = events[events.index(repair) + 1 :]
    assert any(e.kind == "sensing" and e.source == "camera" for e in after), after


def test_a_missing_camera_is_one_line_and_clicks_answer(page: Page, dashboard: Dashboard) -> None:
    panel = dashboard.camera_panel
    panel.kind.value = "webcam"
    panel.where.value = "63"
    stop_camera(page, dashboard)
    page.get_by_role("button", name="Start camera", exact=True).click()
    page.get_by_text("Camera missing: no camera at 63; clicks answer.").wait_for()
    assert panel.live is None and dashboard.execution.camera is None
    if dashboard.plan is None or dashboard.plan.partial:
        plan_clicked(page, dashboard, 120)
    wait_for(lambda: not dashboard.execution.running and not dashboard.execution.preparing)
    wait_for(lambda: not dashboard.execution.start_button.disabled)
    page.get_by_role("button", name="Execute plan", exact=True).click()
    wait_for(lambda: dashboard.execution.executor is not None
             and dashboard.execution.clicks is not None
             and dashboard.execution.clicks.pending() is not None, 30)  # fmt: skip
    clicks = dashboard.execution.clicks
    executor = dashboard.execution.executor
    assert clicks is not None and executor is not None
    offer = clicks.pending()
    assert offer is not None
    page.get_by_role("button", name=offer.words[0], exact=True).click()
    wait_for(lambda: any(e.outcome for e in executor.events), 30)
    answered = next(e for e in executor.events if e.outcome)
    assert answered.source == "click"
    executor.abort()
    wait_for(lambda: executor.done, 30)


def test_a_wait_on_the_camera_says_what_it_sees_and_for_how_long(
    page: Page, dashboard: Dashboard
) -> None:
    if dashboard.camera_panel.live is None:
        dashboard.camera_panel.kind.value = "simulated"  # a test before tried a webcam
        page.get_by_role("button", name="Start camera", exact=True).click()
    wait_for(lambda: dashboard.execution.camera is not None, 30)
    if dashboard.plan is None or dashboard.plan.partial:
        plan_clicked(page, dashboard, 120)
    execution = dashboard.execution
    execution.speed.value = 0.0
    page.get_by_role("tab", name="Execution").click()
    page.get_by_role("button", name="Execute plan", exact=True).click()
    wait_for(lambda: execution.running, 30)
    executor = execution.executor
    assert executor is not None and dashboard.plan is not None
    plan = dashboard.plan
    try:
        while True:  # the questions before the first sensing node: answered by clicks
            wait_for(lambda: execution.clicks is not None and execution.clicks.pending(), 60)
            offer = execution.clicks.pending() if execution.clicks else None
            assert offer is not None
            if plan.nodes[offer.node_id].kind == "sensing":
                break
            execution.clicks.click(offer.options[0], offer.node_id)  # type: ignore[union-attr]
            wait_for(lambda o=offer: execution.clicks.pending() is not o, 30)  # type: ignore[union-attr]
        # Nobody has acted yet: the camera looks, and the page says what it sees.
        line = page.get_by_text("the camera is looking: seen", exact=False).first
        line.wait_for()
        assert f"`{offer.node_id}`" in str(execution.waiting.content) or offer.node_id in (
            line.inner_text())  # fmt: skip
        assert "of 5 markers" in line.inner_text(), line.inner_text()
        waited = page.get_by_text("waiting for an answer for 2 s", exact=False).first
        waited.wait_for(timeout=20000)  # the seconds count up on the page
        shot(page, "camera-wait")
    finally:
        # To the end by clicks (an abort while the camera waits for the simulated
        # human is not this test's matter).
        while not executor.done:
            offer = execution.clicks.pending() if execution.clicks else None
            if offer is not None:
                execution.clicks.click(offer.options[0], offer.node_id)  # type: ignore[union-attr]
            time.sleep(0.05)
    wait_for(lambda: execution.waiting.content == "", 10)
