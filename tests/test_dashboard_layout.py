"""The dashboard's layout is each page's own, in a real browser (Debian's chromium
driven by playwright): the camera's enlarged frame opens on one page only and
leaves the docked panels where they were, for that page, the others and every
page loaded later; a panel dragged out comes back with "Restore the layout"."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

pytest.importorskip("playwright.sync_api")
from playwright.sync_api import Browser, Page  # noqa: E402

from app.dashboard.layout import LEFT_PX, RIGHT_PX  # noqa: E402
from app.dashboard.server import Dashboard  # noqa: E402
from tests.test_dashboard import open_page, served, shot, wait_for  # noqa: E402

SIZES = ((1600, 1000), (1280, 800))
# Each docked or floating panel: its tabs, and its box on the page.
PANELS = """() => [...document.querySelectorAll('[data-dock-group]')].map(g => {
  const r = g.getBoundingClientRect();
  return [[...g.querySelectorAll('[data-dock-tab]')].map(t => t.textContent).join('|'),
          Math.round(r.left), Math.round(r.top), Math.round(r.width), Math.round(r.height)];
}).sort()"""
BENCH = "() => Math.round(document.querySelector('canvas').getBoundingClientRect().width)"
Layout = tuple[int, list[list[object]]]


def settled(read: Callable[[], object]) -> object:
    """What `read` returns once two readings 0.3 s apart agree (the dock animates)."""
    last = read()
    end = time.monotonic() + 20
    while time.monotonic() < end:
        time.sleep(0.3)
        now = read()
        if now == last:
            return now
        last = now
    raise AssertionError(f"the page kept changing: {last}")


def layout_of(page: Page) -> Layout:
    """The bench's width and every panel's box, once they stand still."""
    measured = settled(lambda: (page.evaluate(BENCH), page.evaluate(PANELS)))
    return measured  # type: ignore[return-value]


def sized_page(browser: Browser, dashboard: Dashboard, size: tuple[int, int]) -> Page:
    page = open_page(browser, dashboard, height=size[1])
    page.set_viewport_size({"width": size[0], "height": size[1]})
    page.get_by_role("button", name="Plan", exact=True).wait_for()
    return page


def enlarge_box(page: Page) -> object:
    # The box's own label, whatever its words ("Enlarge ..."); viser's labels are
    # not linked to their inputs.
    label = page.get_by_text("Enlarge", exact=False).first
    return label.locator("xpath=ancestor::*[.//input][1]").locator("input").first


@pytest.fixture(scope="module")
def dashboard(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Dashboard]:
    with served(Path(tmp_path_factory.mktemp("data"))) as d:
        yield d


def start_camera(page: Page, dashboard: Dashboard) -> None:
    if dashboard.camera_panel.live is None:
        page.get_by_role("button", name="Start camera", exact=True).click()
    wait_for(lambda: dashboard.camera_panel.last_annotated is not None, 30)


@pytest.mark.parametrize("size", SIZES, ids=["1600x1000", "1280x800"])
def test_enlarging_the_frame_leaves_every_pages_layout_as_it_was(
    browser: Browser, dashboard: Dashboard, size: tuple[int, int]
) -> None:
    user = sized_page(browser, dashboard, size)
    other = sized_page(browser, dashboard, size)
    try:
        first = layout_of(user)
        assert first[0] >= size[0] - LEFT_PX - RIGHT_PX - 20, first  # the middle is the bench's
        start_camera(user, dashboard)
        enlarge_box(user).click()  # type: ignore[attr-defined]
        wait_for(lambda: enlarge_box(user).is_checked())  # type: ignore[attr-defined]
        # The other page neither shows the enlarged frame nor has its box ticked.
        assert layout_of(other) == first
        assert not enlarge_box(other).is_checked()  # type: ignore[attr-defined]
        enlarge_box(user).click()  # type: ignore[attr-defined]
        assert layout_of(user) == first  # docked back exactly as it was
        user.reload()
        user.get_by_role("button", name="Plan", exact=True).wait_for()
        assert layout_of(user) == first, "reloaded"
        later = sized_page(browser, dashboard, size)
        try:
            assert layout_of(later) == first, "a later visitor"
        finally:
            later.close()
    finally:
        user.close()
        other.close()


@pytest.mark.parametrize("size", SIZES, ids=["1600x1000", "1280x800"])
def test_the_enlarged_frame_shows_whole_at_its_own_size(
    browser: Browser, dashboard: Dashboard, size: tuple[int, int]
) -> None:
    page = sized_page(browser, dashboard, size)
    try:
        start_camera(page, dashboard)
        enlarge_box(page).click()  # type: ignore[attr-defined]
        frame = page.locator("img").filter(visible=True).last
        frame.wait_for()
        wait_for(lambda: frame.evaluate("i => i.naturalWidth") == 640)
        box = settled(frame.bounding_box)
        window = page.locator("[data-dock-group]").last.bounding_box()
        assert isinstance(box, dict) and window is not None
        assert box["width"] >= 639, box  # not shrunk to fit
        bottom = min(window["y"] + window["height"], size[1])
        assert box["y"] + box["height"] <= bottom + 1, (box, window)  # not cut
        shot(page, f"camera-enlarged-{size[0]}x{size[1]}")
        enlarge_box(page).click()  # type: ignore[attr-defined]
        shot(page, f"camera-docked-{size[0]}x{size[1]}")
    finally:
        page.close()


def test_restore_the_layout_brings_a_dragged_panel_back(
    browser: Browser, dashboard: Dashboard
) -> None:
    page = sized_page(browser, dashboard, (1280, 800))
    other = sized_page(browser, dashboard, (1280, 800))
    try:
        first = layout_of(page)
        panel = page.locator("[data-dock-group]").filter(
            has=page.get_by_role("tab", name="Execution")
        )
        grip = panel.locator("[data-dock-griphandle]").first.bounding_box()
        assert grip is not None
        # Drag the Execution panel by its bar out over the bench, as a person does.
        page.mouse.move(grip["x"] + grip["width"] / 2, grip["y"] + grip["height"] / 2)
        page.mouse.down()
        for k in range(1, 21):
            page.mouse.move(
                grip["x"] + (500 - grip["x"]) * k / 20, grip["y"] + (300 - grip["y"]) * k / 20
            )
        page.mouse.up()
        moved = layout_of(page)
        assert moved != first
        assert layout_of(other) == first  # one page's dragging is its own
        page.get_by_role("button", name="Restore the layout", exact=True).click()
        assert layout_of(page) == first
        assert layout_of(other) == first
    finally:
        page.close()
        other.close()


# The button's box and the visible box of the panel that scrolls it (or the page).
IN_ITS_PANEL = """e => { const r = e.getBoundingClientRect(); let p = e.parentElement;
  while (p) { const s = getComputedStyle(p);
    if (/(auto|scroll)/.test(s.overflowY) && p.scrollHeight > p.clientHeight) {
      const q = p.getBoundingClientRect();
      return [r.top, r.bottom, q.top, q.bottom, p.scrollTop]; }
    p = p.parentElement; }
  return [r.top, r.bottom, 0, innerHeight, 0]; }"""


@pytest.mark.parametrize("size", SIZES, ids=["1600x1000", "1280x800"])
def test_plan_shows_on_a_new_page_without_scrolling(
    browser: Browser, dashboard: Dashboard, size: tuple[int, int]
) -> None:
    page = sized_page(browser, dashboard, size)
    try:
        layout_of(page)  # the panels stand still
        top, bottom, shown_top, shown_bottom, scrolled = page.get_by_role(
            "button", name="Plan", exact=True).evaluate(IN_ITS_PANEL)  # fmt: skip
        assert scrolled == 0
        assert shown_top <= top and bottom <= min(shown_bottom, size[1]), (top, shown_bottom)
    finally:
        page.close()
