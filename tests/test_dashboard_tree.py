"""The plan tree panel in real chromium: labels that never overlap (measured on the
page's own geometry), zoom and pan, folded branches, finding an action."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

pytest.importorskip("playwright.sync_api")
from playwright.sync_api import Browser, Page  # noqa: E402

from app.dashboard.server import Dashboard  # noqa: E402
from tests.test_dashboard import (  # noqa: E402
    browser,  # noqa: F401  (the module's fixture)
    opened,
    plan_clicked,
    served,
    shot,
    wait_for,
)

# Every label's box on the screen, as the page lays it out.
LABEL_BOXES = """() => [...document.querySelectorAll('svg.tandem-tree text.label')].map(t => {
    const r = t.getBoundingClientRect(); return [r.left, r.top, r.right, r.bottom]; })"""


@pytest.fixture(scope="module")
def dashboard(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Dashboard]:
    with served(tmp_path_factory.mktemp("data"), workers=2) as d:
        yield d


@pytest.fixture(scope="module")
def page(browser: Browser, dashboard: Dashboard) -> Iterator[Page]:  # noqa: F811
    with opened(browser, dashboard) as page:
        yield page


# The first folded branch's badge inside the picture's frame.
FIRST_BADGE_IN_VIEW = """() => { const s = document.querySelector('svg.tandem-tree')
    .getBoundingClientRect();
  const g = [...document.querySelectorAll('svg.tandem-tree g.fold')].find(g => {
    const r = g.getBoundingClientRect();
    return r.left >= s.left && r.right <= s.right && r.top >= s.top && r.bottom <= s.bottom; });
  return g ? g.dataset.toggle : null; }"""


def overlaps(page: Page) -> tuple[int, list[tuple[int, int]]]:
    """How many labels the page draws, and which pairs overlap."""
    boxes: list[list[float]] = page.evaluate(LABEL_BOXES)
    clashes = []
    for i, (l1, t1, r1, b1) in enumerate(boxes):
        for j in range(i + 1, len(boxes)):
            l2, t2, r2, b2 = boxes[j]
            if l1 < r2 and l2 < r1 and t1 < b2 and t2 < b1:
                clashes.append((i, j))
    return len(boxes), clashes


def view_box(page: Page) -> str:
    return str(page.locator("svg.tandem-tree").get_attribute("viewBox"))


def plan_in_page(page: Page, dashboard: Dashboard, scenario: str) -> None:
    if dashboard.loaded is None or dashboard.loaded.source != scenario:
        dashboard.open_named(scenario)
    plan_clicked(page, dashboard, 300)
    settled(page, dashboard)


def settled(page: Page, dashboard: Dashboard, quiet_s: float = 0.5) -> dict[str, float]:
    """Waits until the page shows the server's newest tree picture and no other has
    been drawn for `quiet_s` (the page reports its size once a picture is shown,
    which can redraw it: a picture measured or scrolled then may be replaced under
    the pointer); the picture's box on the page."""
    svg = page.locator("svg.tandem-tree")
    for _ in range(20):
        draws = dashboard.tree.draws
        wait_for(lambda: svg.get_attribute("data-draw") == str(dashboard.tree.draws), 20)
        page.wait_for_timeout(quiet_s * 1000)
        box = svg.bounding_box()
        if dashboard.tree.draws == draws and box is not None:
            return box
    raise AssertionError("the tree picture kept being redrawn")


def zoom(page: Page, how: str) -> None:
    before = view_box(page)
    page.get_by_role("button", name=how, exact=True).click()
    wait_for(lambda: view_box(page) != before, 20)


@pytest.mark.parametrize("scenario", ["default.toml", "paper/U10.toml"])
def test_no_two_labels_overlap_at_the_first_zoom_or_closer(
    page: Page, dashboard: Dashboard, scenario: str
) -> None:
    plan_in_page(page, dashboard, scenario)
    page.get_by_text("Find, zoom, legend", exact=True).first.click()  # the zoom buttons
    for level in ("first", "in", "fit"):
        if level != "first":
            zoom(page, "In" if level == "in" else "Fit")
        drawn, clashes = overlaps(page)
        assert drawn >= 10 and clashes == [], (scenario, level, clashes[:5])
    name = scenario.removeprefix("paper/").removesuffix(".toml")
    zoom(page, "Root")
    page.get_by_text("Find, zoom, legend", exact=True).first.click()
    page.wait_for_timeout(500)
    shot(page, f"tree-{name}")


def test_wheel_zoom_reaches_the_server_and_a_badge_opens_its_branch(
    page: Page, dashboard: Dashboard
) -> None:
    plan_in_page(page, dashboard, "paper/U10.toml")
    tree = dashboard.tree
    before = tree.view
    picture = settled(page, dashboard)
    page.mouse.move(picture["x"] + picture["width"] / 2, picture["y"] + picture["height"] / 2)
    page.mouse.wheel(0, 400)  # out: the view widens about the pointer
    wait_for(lambda: tree.view[2] > before[2] * 1.3, 20)
    node = str(page.evaluate(FIRST_BADGE_IN_VIEW))
    assert node in tree.collapsed, node
    folded = page.locator(f'svg.tandem-tree g.fold[data-toggle="{node}"]')
    drawn = page.locator("svg.tandem-tree g.node").count()
    folded.click()
    wait_for(lambda: node not in tree.collapsed, 20)
    wait_for(lambda: page.locator("svg.tandem-tree g.node").count() > drawn, 20)
    assert overlaps(page)[1] == []


def test_find_goes_to_the_next_node_with_that_action(page: Page, dashboard: Dashboard) -> None:
    plan_in_page(page, dashboard, "default.toml")
    plan = dashboard.plan
    assert plan is not None
    page.get_by_text("Find, zoom, legend", exact=True).first.click()
    box = page.get_by_text("Find action or node", exact=True).first.locator(
        "xpath=ancestor::*[.//input][1]").locator("input").first  # fmt: skip
    box.fill("unhold")
    page.get_by_role("button", name="Find next", exact=True).click()
    wait_for(lambda: dashboard.selected is not None
             and "unhold" in str(plan.nodes[dashboard.selected].action), 20)  # fmt: skip
    first = dashboard.selected
    page.get_by_text("1 of", exact=False).first.wait_for()
    page.get_by_role("button", name="Find next", exact=True).click()
    wait_for(lambda: dashboard.selected != first, 20)
    assert "unhold" in str(plan.nodes[str(dashboard.selected)].action)
    page.locator(f'svg.tandem-tree [data-node="{dashboard.selected}"]').wait_for()
    page.get_by_text("Find, zoom, legend", exact=True).first.click()
