"""The dashboard in a real browser: Debian's chromium driven by playwright.

Screenshots of the key views go to tests/artifacts/ for people to look at.
"""

from __future__ import annotations

import io
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

pytest.importorskip("playwright.sync_api")
from playwright.sync_api import Browser, Page, expect  # noqa: E402
from playwright.sync_api import TimeoutError as PlaywrightTimeoutError  # noqa: E402

from app.dashboard.server import Dashboard, DashboardSettings  # noqa: E402
from app.dashboard.tree_svg import CURRENT, PATH  # noqa: E402
from app.execution.events import is_step  # noqa: E402
from app.execution.walker import Executor  # noqa: E402
from tests.plan_fixtures import free_port  # noqa: E402

ARTIFACTS = Path(__file__).resolve().parent / "artifacts"


def wait_for(condition: Callable[[], object], timeout: float = 60.0) -> None:
    end = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > end:
            raise AssertionError("condition not met in time")
        time.sleep(0.05)


@pytest.fixture(scope="module")
def dashboard(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Dashboard]:
    cache = str(tmp_path_factory.mktemp("cache"))
    mine = tmp_path_factory.mktemp("lab-scenarios")
    (mine / "bad.toml").write_text('name = "bad"\n[[parts]]\nid = "top"\n')
    d = Dashboard(
        "127.0.0.1",
        free_port(),
        "default.toml",
        DashboardSettings(workers=1, cache_dir=cache, scenario_dirs=[mine]),
    )
    yield d
    d.close()


def open_page(
    browser: Browser, dashboard: Dashboard, ready: str = "Tandem", height: int = 900
) -> Page:
    """A page of `dashboard` once the server knows it and `ready` shows."""
    page = browser.new_page(viewport={"width": 1400, "height": height})
    page.goto(f"http://127.0.0.1:{dashboard.server.get_port()}")
    # "Connected" can show before the server knows the client (field notes).
    wait_for(lambda: dashboard.server.get_clients())
    page.get_by_text(ready, exact=ready != "Tandem").first.wait_for()
    return page


@pytest.fixture(scope="module")
def page(browser: Browser, dashboard: Dashboard) -> Iterator[Page]:
    page = open_page(browser, dashboard)
    yield page
    page.close()


@contextmanager
def served(data: Path, *, workers: int = 1, load_models: bool = False) -> Iterator[Dashboard]:
    """A dashboard of default.toml on a free port, its store in `data`; closed after."""
    settings = DashboardSettings(workers=workers, data_dir=str(data), load_models=load_models)
    d = Dashboard("127.0.0.1", free_port(), "default.toml", settings)
    try:
        yield d
    finally:
        d.close()


@contextmanager
def opened(browser: Browser, dashboard: Dashboard, height: int = 1000) -> Iterator[Page]:
    """A page of `dashboard` (`open_page`), closed after."""
    page = open_page(browser, dashboard, height=height)
    try:
        yield page
    finally:
        page.close()


def choose(page: Page, label: str, option: str) -> None:
    """Picks `option` in the dropdown labelled `label`, opening it again if it closed
    before the click (the panel redraws its fields as a scenario loads), as a person
    would; the last try fails with playwright's account of what it waited for."""
    wanted = page.get_by_role("option", name=option, exact=True)
    for _ in range(3):
        field(page, label).click()  # type: ignore[attr-defined]
        try:
            wanted.click(timeout=5000)
            return
        except PlaywrightTimeoutError:
            page.keyboard.press("Escape")  # a dropdown still open closes: the next click opens it
    field(page, label).click()  # type: ignore[attr-defined]
    wanted.click()


def plan_shown(dashboard: Dashboard) -> Callable[[], bool]:
    def shown() -> bool:
        plan = dashboard.plan
        return plan is not None and not plan.partial and dashboard.selected == plan.root

    return shown


def execute_clicked(page: Page, dashboard: Dashboard, timeout: float = 30) -> Executor:
    """Clicks "Execute plan" and returns the new execution's executor (not the last one's,
    which stays on the panel until the click reaches the server)."""
    before = dashboard.execution.executor
    page.get_by_role("button", name="Execute plan", exact=True).click()
    wait_for(lambda: dashboard.execution.executor not in (None, before), timeout)
    executor = dashboard.execution.executor
    assert executor is not None
    return executor


def plan_clicked(page: Page, dashboard: Dashboard, timeout: float = 120) -> None:
    """Clicks Plan and waits for the new plan on screen. The click reaches the server a
    moment after it returns, so the plan shown before (if any) must not count."""
    before = dashboard.plan
    page.get_by_role("button", name="Plan", exact=True).click()
    shown = plan_shown(dashboard)
    wait_for(lambda: dashboard.plan is not before and shown(), timeout)


def run_by_clicks(page: Page, dashboard: Dashboard, seconds_per_step: float) -> int:
    """Plans, then runs the plan at `seconds_per_step`, answering every question with its
    last button as a user would; the session's id once it is stored as at the goal."""
    plan_clicked(page, dashboard)
    dashboard.execution.speed.value = seconds_per_step
    executor = execute_clicked(page, dashboard)
    clicks = dashboard.execution.clicks
    assert clicks is not None
    last, tries = None, 0
    while not executor.done:
        offer = clicks.pending()
        if offer is None:
            time.sleep(0.05)
            continue
        # A click can miss on a loaded machine (the buttons still being drawn, or
        # redrawn): the same question is then clicked again, a few times at most.
        tries = tries + 1 if offer is last else 1
        last = offer
        assert tries <= 5, f"{offer.node_id}: five clicks went unanswered"
        try:
            page.get_by_role("button", name=offer.words[-1], exact=True).click(timeout=10000)
        except Exception:
            pass  # answered meanwhile (its buttons went), or missed: the loop looks again

        def answered(asked: object = offer) -> bool:
            return clicks.pending() is not asked or executor.done

        deadline = time.monotonic() + 15
        while not answered() and time.monotonic() < deadline:
            time.sleep(0.05)
    assert executor.result == "goal", executor.events
    session_id = dashboard.execution.session_id
    assert session_id is not None
    wait_for(lambda: dashboard.store.get(session_id).result == "goal")
    return session_id


def colour_counts(page: Page) -> tuple[int, int]:
    """Red and strongly blue pixels of the 3D view (its canvas, wherever the panels
    put it). Baxter's red covers are lit from the side: most of their pixels are a
    shaded red (R 100 to 150, G and B under 50), which the wooden parts are not."""
    image = Image.open(io.BytesIO(page.locator("canvas").first.screenshot())).convert("RGB")
    pixels = np.asarray(image, dtype=int)
    r, g, b = pixels[..., 0], pixels[..., 1], pixels[..., 2]
    return int(((r > 100) & (g < 50) & (b < 50)).sum()), int(
        ((b > 150) & (r < 60) & (g < 60)).sum()
    )


def shot(page: Page, name: str) -> None:
    ARTIFACTS.mkdir(exist_ok=True)
    page.screenshot(path=str(ARTIFACTS / f"{name}.png"))


def field(page: Page, label: str) -> object:
    # viser's labels are not linked to their inputs: find the row by its label text.
    text = page.get_by_text(label, exact=True).first
    return text.locator("xpath=ancestor::*[.//input][1]").locator("input").first


def test_page_shows_bench_robot_and_human(page: Page, dashboard: Dashboard) -> None:
    page.get_by_role("button", name="Plan", exact=True).wait_for()
    # The planning panel's status names the loaded scenario, in bold.
    status = page.locator("p", has_text="not planned yet")
    expect(status.locator("strong")).to_have_text("paper-base")
    expect(status).to_have_text("Scenario paper-base (5 parts): not planned yet.")
    assert dashboard.bench.robot is not None
    assert set(dashboard.bench.boxes) == {"top", "leg1", "leg2", "foot1", "foot2"}
    # The page really draws them: Baxter's red covers and the human's blue body
    # fill thousands of pixels of the 3D view once software WebGL has the meshes
    # and has rendered them.
    counts: list[tuple[int, int]] = []

    def drawn() -> bool:
        counts.append(colour_counts(page))
        return min(counts[-1]) > 1000

    try:
        wait_for(drawn, 60)
    finally:
        shot(page, "bench")
    assert min(counts[-1]) > 1000, counts[-5:]


def test_plan_fills_the_tree_and_a_click_shows_a_node(page: Page, dashboard: Dashboard) -> None:
    from tests.test_dashboard_tree import settled

    page.get_by_role("button", name="Plan", exact=True).click()
    wait_for(lambda: dashboard.job is not None and dashboard.job.status.state == "done", 120)
    # The job reports "done" just before the page shows the plan and selects its root.
    wait_for(plan_shown(dashboard))
    assert dashboard.tree.current is not None and len(dashboard.tree.current.positions) >= 10
    assert dashboard.plan is not None and dashboard.selected == dashboard.plan.root
    page.get_by_text("Statistics", exact=True).first.click()  # a folder, closed at first
    page.get_by_text("meaning").wait_for()  # the statistics, with their legend
    page.locator(f'svg.tandem-tree [data-node="{dashboard.plan.root}"]').wait_for()
    settled(page, dashboard)
    shot(page, "plan-tree")
    # Go to the root's child with the selected node's buttons (under the tree), back
    # to the root...
    root = dashboard.plan.root
    child = dashboard.plan.nodes[root].children[0].node
    page.get_by_role("button", name="next", exact=True).click()
    wait_for(lambda: dashboard.selected == child)
    page.get_by_role("button", name="Parent", exact=True).click()
    wait_for(lambda: dashboard.selected == root)
    # ...then click the child's box in the tree picture where a person does, on its
    # words, once the picture stands still: the selection follows.
    settled(page, dashboard)
    words = page.locator(f'svg.tandem-tree [data-node="{child}"] text.label').bounding_box()
    assert words is not None
    page.mouse.click(words["x"] + words["width"] / 2, words["y"] + words["height"] / 2)
    wait_for(lambda: dashboard.selected == child, 20)
    selected = page.locator(f'svg.tandem-tree [data-node="{child}"] rect[stroke="#d0209c"]')
    selected.wait_for()  # the picture marks it selected
    action = str(dashboard.plan.nodes[child].action)
    # The node's details, in the tree's own tab under the picture.
    page.locator("strong").get_by_text(action, exact=True).first.wait_for()
    shot(page, "node-selected")
    page.get_by_role("button", name="Bench", exact=True).click()
    wait_for(lambda: dashboard.screen.bench_at == child, 20)
    shot(page, "bench-at-node")


def test_malformed_scenario_shows_an_error_and_the_page_keeps_working(
    page: Page, dashboard: Dashboard, tmp_path: Path
) -> None:
    outside = tmp_path / "outside.toml"
    outside.write_text('name = "s3cr3t-token-ABC123"\n')
    box = field(page, "File")
    box.fill(str(outside))  # type: ignore[attr-defined]
    page.get_by_role("button", name="Open file", exact=True).click()
    page.get_by_text("not a path", exact=False).first.wait_for()
    assert "s3cr3t" not in page.content()  # a path outside the folders is never read
    box.fill("bad.toml")  # type: ignore[attr-defined]
    page.get_by_role("button", name="Open file", exact=True).click()
    page.get_by_text("bad.toml: ", exact=False).first.wait_for()
    shot(page, "scenario-error")
    # The previous scenario is still loaded and plans.
    assert dashboard.loaded is not None and dashboard.loaded.scenario is not None
    before = dashboard.job
    page.get_by_role("button", name="Plan", exact=True).click()
    wait_for(lambda: dashboard.job is not before and dashboard.job is not None, 20)
    wait_for(lambda: dashboard.job is not None and dashboard.job.status.state == "done", 120)


def test_click_through_an_execution_then_review_it(page: Page, dashboard: Dashboard) -> None:
    from tests.plan_paths import is_plan_path

    if not plan_shown(dashboard)():
        plan_clicked(page, dashboard, 120)
    speed = dashboard.execution.speed
    speed.value = 0.0  # no pauses between steps: the test clicks as fast as it can
    execute = page.get_by_role("button", name="Execute plan", exact=True)
    wait_for(lambda: not dashboard.execution.start_button.disabled)
    expect(execute).to_be_enabled()  # the page, too, knows the plan is ready
    execute.click()
    wait_for(lambda: dashboard.execution.executor is not None)
    executor = dashboard.execution.executor
    assert executor is not None
    answered = 0
    while not executor.done:
        offer = dashboard.execution.clicks.pending() if dashboard.execution.clicks else None
        if offer is None:
            time.sleep(0.05)
            continue
        # The human's answers, as the simulated-human panel words them; take the last.
        button = page.get_by_role("button", name=offer.words[-1], exact=True)
        if answered == 0:
            button.wait_for()
            shot(page, "simulated-human")
        try:
            button.click(timeout=5000)
        except Exception:
            # The answered question's buttons vanish at once, sometimes while
            # playwright still looks at the one it clicked; the loop looks again.
            pass
        answered += 1
        wait_for(lambda o=offer: dashboard.execution.clicks.pending() != o or executor.done)
        if answered == 1:
            # Live on the tree: the answered node on the path taken (blue), marked
            # with who answered; the branches not taken faded.
            taken = page.locator(f'svg.tandem-tree [data-node="{offer.node_id}"]')
            taken.locator(f'rect[stroke="{PATH}"]').wait_for()
            expect(taken).to_contain_text("click")
            assert page.locator('svg.tandem-tree g.node[opacity="0.4"]').count() > 0
    assert executor.result == "goal", executor.events
    clicked = [e for e in executor.events if e.outcome is not None]
    assert clicked and all(e.source == "click" for e in clicked)
    session_id = dashboard.execution.session_id
    assert session_id is not None
    wait_for(lambda: dashboard.store.get(session_id).result == "goal")
    path = dashboard.store.path(session_id)
    assert dashboard.plan is not None and is_plan_path(dashboard.plan, path)
    # The session is in the review list and replays the same path.
    page.get_by_role("tab", name="Review").click()
    page.get_by_role("button", name="Refresh list", exact=True).click()
    label = dashboard.review.label_of(session_id)
    page.get_by_role("button", name="Open session", exact=True).click()
    wait_for(lambda: dashboard.review.opened == session_id)
    assert dashboard.review.pick.value == label
    replayed = []
    reviewed = dashboard.review.events
    for k in range(len(reviewed)):
        # What moving the timeline to step k does (setting the slider from here
        # races with the page echoing earlier values back).
        dashboard.review.show_step(k)
        if is_step(reviewed[k]):  # not the human's own action its click reported
            replayed.append((dashboard.selected, reviewed[k].outcome))
        assert dashboard.tree.marks.current == dashboard.selected
        assert len(dashboard.tree.marks.path) == k + 1
    assert replayed == path
    # The review's tree marks the step shown, as the execution did.
    middle = len(path) // 2
    dashboard.review.show_step(middle)
    node = dashboard.review.events[middle].node
    page.locator(f'svg.tandem-tree [data-node="{node}"] rect[stroke="{CURRENT}"]').wait_for()
    shot(page, "review")
