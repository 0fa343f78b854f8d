"""The review's lanes read at a glance and zoomed, in real chromium (issue: the review
timeline cannot be read at a glance or zoomed).

The sessions are real: the default plan run in the page by clicks on the wall clock
(clicked answers, the human's clicked actions), and `tandem execute` headless on the
simulated clock (random answers twice with one seed: the same path; the simulated
camera: camera answers), all into one store in a temporary folder.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path

import pytest

from app.dashboard.lane_marks import SOURCE_MARKS, legend_html
from app.dashboard.review_compare import divergence
from app.dashboard.review_timeline import bridged, clamped, following, zoomed
from app.dashboard.timeline_svg import LABEL_PX, PLOT_PX, bars, duration, lanes_svg, place, tip
from app.execution.events import ExecutionEvent
from planner.vocabulary import Hold, SenseHumanHolding
from tests.plan_fixtures import tandem

pytest.importorskip("playwright.sync_api")
from playwright.sync_api import Browser, Locator, Page  # noqa: E402

from app.dashboard.server import Dashboard  # noqa: E402
from tests.test_dashboard import (  # noqa: E402
    choose,
    opened,
    run_by_clicks,
    served,
    shot,
    wait_for,
)

# -- the pictures' parts, without a page ----------------------------------------------


def _asked() -> list[ExecutionEvent]:
    return [
        ExecutionEvent(0, 1.0, "n0", Hold("left", "leg1"), "actuation", start=0.0, end=0.05),
        ExecutionEvent(1, 9.0, "n1", SenseHumanHolding(), "sensing", outcome="yes",
                       source="click", start=1.0, end=9.0, wait_start=2.0),  # fmt: skip
        ExecutionEvent(2, 9.0, "n1", None, "human", text="holds leg2", source="click",
                       start=1.0, end=9.0),  # fmt: skip
        ExecutionEvent(3, 10.0, "n2", None, "human", text="yes", source="voice",
                       start=9.5, end=10.0),  # fmt: skip
    ]


def test_marks_waits_and_tooltips_in_the_picture() -> None:
    events = _asked()
    placed, _ = bars(events)
    assert [b.lane for b in placed] == ["robot", "sensing", "human", "talk"]  # speech: talk
    svg = lanes_svg(events, shown=1)
    # One mark per answered bar and per human action, each its source's own shape.
    assert svg.count('data-source="click"') == 2 and svg.count('data-source="voice"') == 1
    assert len({m.shape for m in SOURCE_MARKS.values()}) == len(SOURCE_MARKS)
    assert len({m.colour for m in SOURCE_MARKS.values()}) == len(SOURCE_MARKS)
    # The question is solid while asked, hatched from its wait on (2 s to 9 s).
    waiting = re.findall(r'<rect data-t0="([\d.]+)" data-t1="([\d.]+)"[^>]*class="waiting"', svg)
    assert waiting == [("2.000", "9.000")]
    words = tip(placed[1])
    assert "answered by click" in words and "asking 1.0 s, then waiting 7.0 s" in words
    assert "reported by a click" in tip(placed[2])
    # A 0.05 s action of a 10 s session: drawn thin, clickable 14 units wide.
    _, width = place((0.0, 10.0), 0.0, 0.05)
    assert width < 3 and place((0.0, 10.0), 0.0, 0.05, 14.0)[1] == 14.0
    assert 'data-step="0"' in svg and 'class="target"' in svg
    legend = legend_html({"click", "voice"})
    assert ">click<" in legend and ">voice<" in legend and ">camera<" not in legend


def test_zoom_windows_and_the_bridges_messages() -> None:
    assert zoomed(None, 100.0, "In") == (25.0, 75.0)
    assert zoomed((25.0, 75.0), 100.0, "Out") is None and zoomed((1.0, 2.0), 9.0, "All") is None
    assert clamped((-5.0, 5.0), 100.0) == (0.0, 10.0) and clamped((95.0, 105.0), 100.0) == (
        90.0, 100.0)  # fmt: skip
    assert following((0.0, 10.0), 50.0, 100.0) == pytest.approx((46.6667, 56.6667), abs=1e-3)
    assert following((0.0, 10.0), 5.0, 100.0) == (0.0, 10.0)
    message = bridged("lanes:step:7:second:1.5,9.250:1700000")
    assert message is not None and (message.step, message.picture) == (7, "second")
    assert message.window == (1.5, 9.25)
    view = bridged("lanes:view:-:first:0.000,31.500:1")
    assert view is not None and view.what == "view" and view.step is None
    assert bridged("lanes:step:x:first:0,1:1") is None and bridged("tree:select:n1:1") is None
    # A window half a 10 s session: everything placed in its plot, left to right.
    assert place((5.0, 10.0), 5.0, 10.0) == (LABEL_PX, PLOT_PX)


# -- in the page ----------------------------------------------------------------------


@pytest.fixture(scope="module")
def data(tmp_path_factory: pytest.TempPathFactory) -> Path:
    data = tmp_path_factory.mktemp("data")
    for responses, seed in (("random", "1"), ("random", "1"), ("camera:sim", "3")):
        run = tandem("execute", "default.toml", "--responses", responses, "--seed", seed,
                     "--data-dir", str(data))  # fmt: skip
        assert run.returncode == 0, run.stderr
    return data


@pytest.fixture(scope="module")
def dashboard(data: Path) -> Iterator[Dashboard]:
    with served(data) as d:
        yield d


@pytest.fixture(scope="module")
def clicked(browser: Browser, dashboard: Dashboard) -> int:
    """The default plan run in the page by clicks, on the wall clock (session 4)."""
    with opened(browser, dashboard) as page:
        return run_by_clicks(page, dashboard, 0.3)


def open_session(page: Page, dashboard: Dashboard, session_id: int) -> None:
    review = dashboard.review
    page.get_by_role("tab", name="Review").click()
    page.get_by_role("button", name="Refresh list", exact=True).click()
    wait_for(lambda: review.label_of(session_id) is not None, 20)
    label = review.label_of(session_id)
    choose(page, "Session", label)
    wait_for(lambda: review.pick.value == label, 20)
    review.opened = None  # it may be open already, at another step
    page.get_by_role("button", name="Open session", exact=True).click()
    wait_for(lambda: review.opened == session_id, 20)
    on_page(page, review.lanes.content)


def on_page(page: Page, content: str) -> None:
    """Waits until the page shows the lanes the server drew last (their cursor)."""
    drawn = re.search(r'data-at="([\d.]+)"[^>]*class="cursor"', content)
    assert drawn is not None
    cursor = page.locator('svg.tandem-lanes[data-lanes="first"] line.cursor')
    wait_for(lambda: cursor.count() == 1 and cursor.get_attribute("data-at") == drawn[1], 20)


def lanes(page: Page, name: str = "first") -> Locator:
    return page.locator(f'svg.tandem-lanes[data-lanes="{name}"]')


def window_of(page: Page, name: str = "first") -> tuple[float, float]:
    svg = lanes(page, name)
    return float(svg.get_attribute("data-a") or "nan"), float(svg.get_attribute("data-b") or "nan")


def test_each_source_has_its_mark_and_the_legend_names_them(
    browser: Browser, dashboard: Dashboard, clicked: int
) -> None:
    with opened(browser, dashboard) as page:
        open_session(page, dashboard, clicked)
        events = dashboard.review.events
        humans = [k for k, e in enumerate(events) if e.kind == "human"]
        answered = [k for k, e in enumerate(events) if e.outcome and e.source == "click"]
        assert humans and answered
        for k in (humans[0], answered[0]):
            mark = lanes(page).locator(f'g[data-step="{k}"] g.mark[data-source="click"]')
            assert mark.count() == 1 and (mark.bounding_box() or {}).get("width", 0) > 4
        legend = page.locator(".tandem-lanes-legend")
        assert "click" in legend.inner_text() and "camera" not in legend.inner_text()
        # The camera's session: its answers carry another mark, of another colour.
        open_session(page, dashboard, 3)
        camera = lanes(page).locator('g.mark[data-source="camera"]').first
        camera.wait_for()
        fill = camera.locator("polygon").get_attribute("fill")
        assert fill == SOURCE_MARKS["camera"].colour != SOURCE_MARKS["click"].colour
        assert "camera" in page.locator(".tandem-lanes-legend").inner_text()


def test_wheel_zooms_drag_pans_and_the_next_picture_keeps_the_time_shown(
    browser: Browser, dashboard: Dashboard, clicked: int
) -> None:
    review = dashboard.review
    with opened(browser, dashboard) as page:
        open_session(page, dashboard, clicked)
        a, b = window_of(page)
        assert a == 0 and "of" not in (lanes(page).locator("text.axis").text_content() or "")
        box = lanes(page).bounding_box()
        assert box is not None
        page.mouse.move(box["x"] + box["width"] * 0.6, box["y"] + 30)
        for _ in range(4):
            page.mouse.wheel(0, -200)  # zoom in about the pointer
        zoomed_in = window_of(page)
        assert zoomed_in[1] - zoomed_in[0] < (b - a) / 2
        assert " of " in (lanes(page).locator("text.axis").text_content() or "")
        wait_for(lambda: review.windows["first"] is not None, 20)  # reported to the server
        # Drag left: later times come into view.
        page.mouse.move(box["x"] + box["width"] * 0.7, box["y"] + 30)
        page.mouse.down()
        page.mouse.move(box["x"] + box["width"] * 0.4, box["y"] + 30, steps=5)
        page.mouse.up()
        panned = window_of(page)
        assert panned[0] > zoomed_in[0] + 0.5
        wait_for(lambda: review.windows["first"] == pytest.approx(panned, abs=0.01), 20)
        # A bar clicked in the zoomed picture: the review goes there, the picture
        # drawn again shows the same time.
        target = visible_bar(page, panned)
        lanes(page).locator(f'g[data-step="{target}"]').click()
        wait_for(lambda: review.shown_step == target, 20)
        on_page(page, review.lanes.content)
        assert window_of(page) == pytest.approx(panned, abs=0.01)
        lanes(page).scroll_into_view_if_needed()
        shot(page, "review-lanes-zoomed")
        page.get_by_role("button", name="All", exact=True).click()
        wait_for(lambda: window_of(page)[0] == 0 and review.windows["first"] is None, 20)


def visible_bar(page: Page, window: tuple[float, float]) -> int:
    """A bar whose middle is in `window`."""
    for g in lanes(page).locator("g.bar").all():
        rect = g.locator("rect").first
        t0 = float(rect.get_attribute("data-t0") or 0)
        t1 = float(rect.get_attribute("data-t1") or 0)
        if window[0] < (t0 + t1) / 2 < window[1]:
            return int(g.get_attribute("data-step") or -1)
    raise AssertionError("no bar in the window")


def test_every_robot_action_can_be_hovered_and_clicked(
    browser: Browser, dashboard: Dashboard, clicked: int
) -> None:
    review = dashboard.review
    for size in ((1600, 1000), (1280, 800)):
        with opened(browser, dashboard, height=size[1]) as page:
            page.set_viewport_size({"width": size[0], "height": size[1]})
            open_session(page, dashboard, clicked)
            events = review.events
            robot = [k for k, e in enumerate(events) if e.kind == "actuation"]
            shortest = min(robot, key=lambda k: events[k].end - events[k].start)  # type: ignore[operator]
            target = lanes(page).locator(f'g[data-step="{shortest}"] rect.target')
            target.scroll_into_view_if_needed()
            width = (target.bounding_box() or {}).get("width", 0)
            assert width >= 8, (size, width)  # a finger's tip, at the whole session's zoom
            bar = lanes(page).locator(f'g[data-step="{shortest}"]')
            bar.hover()
            tip_box = page.locator("#tandem-lanes-tip")
            tip_box.wait_for(state="visible")
            words = tip_box.inner_text()
            assert events[shortest].node in words and str(events[shortest].action) in words
            shot(page, f"review-lanes-hover-{size[0]}x{size[1]}")
            bar.click()
            wait_for(lambda k=shortest: review.shown_step == k, 20)
            at = f"{events[shortest].end - min(e.start for e in events if e.start):.3f}"  # type: ignore[operator]
            wait_for(lambda p=page, t=at: lanes(p).locator("line.cursor").get_attribute(
                "data-at") == t, 20)  # fmt: skip


def test_compared_sessions_each_have_their_scale_and_part_only_when_paths_differ(
    browser: Browser, dashboard: Dashboard, clicked: int
) -> None:
    compare = dashboard.review.compare
    with opened(browser, dashboard) as page:
        # Two runs of one seed took the same path: nothing parted, nothing dashed.
        open_session(page, dashboard, 1)
        choose(page, "Compare with", compare.label_of(2))
        lanes(page, "second").wait_for()
        page.get_by_text("took the same path", exact=False).first.wait_for()
        caption = page.get_by_text("#2 (", exact=False).first.inner_text()
        assert "parted" not in caption and "same path" in caption, caption
        assert page.locator("svg.tandem-lanes line.diverged").count() == 0
        # The clicked session (wall clock) against a simulated one: each spans its
        # own picture, whatever their lengths.
        open_session(page, dashboard, clicked)
        choose(page, "Compare with", compare.label_of(1))
        lanes(page, "second").wait_for()
        store = dashboard.store
        parted = divergence(store.events(clicked), store.events(1)) is not None
        page.get_by_text("Diverged at step" if parted else "took the same path",
                         exact=False).first.wait_for()  # fmt: skip
        assert ("parted" in page.get_by_text("#1 (", exact=False).first.inner_text()) == parted
        for name, session in (("first", clicked), ("second", 1)):
            svg = lanes(page, name)
            own = duration(store.events(session))
            assert float(svg.get_attribute("data-total") or "nan") == pytest.approx(own, abs=1e-3)
            assert (svg.locator("text.axis").text_content() or "") == f"0 s … {own:.1f} s"
        assert page.locator("svg.tandem-lanes line.diverged").count() == (2 if parted else 0)
        shot(page, "review-lanes-compare")
