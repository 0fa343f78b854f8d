"""The review of stored sessions in real chromium: a session's lanes under its
timeline, scrubbing that moves the tree, the bench and the transcript together,
two sessions of one plan compared, and a study's table and figure.

The sessions are real: `tandem execute` headless on the simulated clock (random
answers, and the simulated camera for a session with frames), and a tiny
`tandem study`, all into one store in a temporary folder.
"""

from __future__ import annotations

import re
import shutil
from collections import Counter
from collections.abc import Iterator
from pathlib import Path

import pytest

from app.dashboard.review_compare import divergence, divergence_words
from app.dashboard.review_metrics import metrics_markdown
from app.dashboard.review_study import short_names
from app.dashboard.review_timeline import bridged_step, clock_words, transcript
from app.dashboard.timeline_svg import lanes_svg
from app.execution.events import ExecutionEvent, is_step
from app.sessions.store import SessionStore
from app.sessions.studies import finished, study_sessions
from planner.vocabulary import Hold, SenseHumanHolding
from tests.plan_fixtures import free_port, tandem

pytest.importorskip("playwright.sync_api")
from playwright.sync_api import Browser, Page  # noqa: E402

from app.dashboard.server import Dashboard, DashboardSettings  # noqa: E402
from tests.test_dashboard import (  # noqa: E402
    choose,
    opened,
    served,
    shot,
    wait_for,
)

OLD_STORE = Path(__file__).parent / "fixtures" / "sessions-0.1.db"  # untimed sessions
TINY_STUDY = """\
[study]
name = "tiny"
participants = 2
seed = 1

[conditions]
scenario = "default.toml"
behaviour = ["cooperative", "hesitant"]
"""

# -- the review's words and pictures, without a page ------------------------------------


def _timed() -> list[ExecutionEvent]:
    return [
        ExecutionEvent(0, 1.0, "n0", None, "communication", text="Hello", start=100.0, end=101.0),
        ExecutionEvent(1, 3.0, "n1", Hold("left", "leg1"), "actuation", start=101.0, end=103.0),
        ExecutionEvent(2, 2.5, "n1", None, "human", text="holds leg2", start=101.5, end=102.5),
        ExecutionEvent(3, 5.0, "n3", SenseHumanHolding(), "sensing", outcome="yes",
                       source="camera", start=103.0, end=104.0),  # fmt: skip
    ]


def test_the_clock_and_the_transcript_follow_time_not_recording_order() -> None:
    events = _timed()
    assert clock_words(events, 1) == "t = 3.0 s of 4.0 s"
    # At the hold's end (t = 3) the human's action, recorded after it, had ended too:
    # it is in the transcript, before the hold (it ended first).
    lines = transcript(events, 1)
    assert [line.split("`")[1] for line in lines] == ["n0", "n1", "n1"]
    assert "The human: holds leg2" in lines[1] and "holds leg1" in lines[2]
    assert len(transcript(events, 3, lines=2)) == 2
    untimed = [ExecutionEvent(i, 0.0, f"n{i}", None, "communication") for i in range(3)]
    assert clock_words(untimed, 1) == "untimed" and len(transcript(untimed, 1)) == 2


def test_divergence_is_the_first_plan_step_whose_node_or_outcome_differs() -> None:
    first = _timed()
    second = [*first[:3], ExecutionEvent(3, 5.0, "n3", SenseHumanHolding(), "sensing",
                                         outcome="no", source="random")]  # fmt: skip
    found = divergence(first, second)
    assert found is not None and (found.step, found.first, found.second) == (3, 3, 3)
    words = divergence_words(first, second, ("#1", "#2"))
    assert words.startswith("Diverged at step 4: `n3` sense(humanHolding): **yes** (#1)")
    assert "**no** (#2)" in words
    assert divergence(first, list(first)) is None
    ended = divergence(first, first[:2])
    assert ended is not None and ended.second is None and ended.first == 3
    assert "#2 had ended" in divergence_words(first, first[:2], ("#1", "#2"))
    svg = lanes_svg(first, shown=1, marked=3, until=10.0)
    assert 'class="diverged"' in svg and "0 s … 10.0 s" in svg and 'data-step="2"' in svg


def test_metrics_table_and_study_names() -> None:
    table = metrics_markdown(_timed(), "simulated")
    assert "| active | 4.0 s · 100% | 1.0 s · 25% |" in table and "task 4.0 s" in table
    assert "| idle | 0.0 s · 0% | 3.0 s · 75% |" in table
    untimed = [ExecutionEvent(i, 0.0, f"n{i}", None, "communication") for i in range(3)]
    assert "untimed" in metrics_markdown(untimed, "simulated")
    short, common = short_names(["d/normal/cooperative", "d/normal/hesitant"])
    assert short == {"d/normal/cooperative": "cooperative", "d/normal/hesitant": "hesitant"}
    assert common == "d/normal/*"
    assert bridged_step("lanes:step:7:1700000") == 7 and bridged_step("lanes:view:1") is None


# -- in the page --------------------------------------------------------------------------


@pytest.fixture(scope="module")
def data(tmp_path_factory: pytest.TempPathFactory) -> Path:
    data = tmp_path_factory.mktemp("data")
    for responses, seed in (("random", "1"), ("random", "2"), ("camera:sim", "3")):
        run = tandem("execute", "default.toml", "--responses", responses, "--seed", seed,
                     "--data-dir", str(data))  # fmt: skip
        assert run.returncode == 0, run.stderr
    study = data.parent / "tiny.toml"
    study.write_text(TINY_STUDY)
    run = tandem("study", str(study), "--data-dir", str(data), "--out", str(data.parent / "out"),
                 "--workers", "1")  # fmt: skip
    assert run.returncode == 0, run.stderr
    return data


@pytest.fixture(scope="module")
def dashboard(data: Path) -> Iterator[Dashboard]:
    with served(data) as d:
        yield d


@pytest.fixture(scope="module")
def page(browser: Browser, dashboard: Dashboard) -> Iterator[Page]:
    with opened(browser, dashboard) as page:
        page.get_by_role("tab", name="Review").click()
        yield page


def open_session(page: Page, dashboard: Dashboard, session_id: int) -> None:
    review = dashboard.review
    page.get_by_role("button", name="Refresh list", exact=True).click()
    label = review.label_of(session_id)
    choose(page, "Session", label)
    wait_for(lambda: review.pick.value == label, 20)
    page.get_by_role("button", name="Open session", exact=True).click()
    wait_for(lambda: review.opened == session_id, 20)
    page.locator("svg.tandem-lanes").first.wait_for()


def cursor_x(page: Page) -> float:
    return float(page.locator("svg.tandem-lanes line.cursor").first.get_attribute("x1") or "nan")


def test_scrubbing_moves_the_tree_the_bench_the_transcript_and_the_cursor(
    page: Page, dashboard: Dashboard
) -> None:
    review = dashboard.review
    open_session(page, dashboard, 3)  # the simulated camera's session: it has frames
    events = review.events
    assert review.shown_step == 0 and dashboard.selected == events[0].node
    top = dashboard.bench._label_handles["top"]  # the bench's label of the top's assembly
    assert top.text == "top"
    page.get_by_text(f"step 1/{len(events)}, t = ", exact=False).first.wait_for()
    page.get_by_text("task ", exact=False).first.wait_for()  # the metrics beside
    before = cursor_x(page)
    # Press the slider on to the step after the left arm attached leg1 to the top.
    k = next(i for i, e in enumerate(events) if str(e.action) == "attach(left,top,c1)")
    thumb = page.get_by_text("Timeline", exact=True).first.locator(
        "xpath=ancestor::*[.//*[@role='slider']][1]").get_by_role("slider")  # fmt: skip
    thumb.focus()
    for _ in range(k):
        thumb.press("ArrowRight")
    wait_for(lambda: review.shown_step == k, 20)
    node = events[k].node
    assert dashboard.selected == node and dashboard.tree.marks.current == node
    page.locator(f'svg.tandem-tree [data-node="{node}"] rect[stroke="#d0209c"]').wait_for()
    assert top.text == "top + leg1"  # the bench as that step left it
    page.get_by_text("attaches its part to top at c1", exact=False).first.wait_for()
    wait_for(lambda: cursor_x(page) > before, 20)
    # A click on a later bar (a camera answer) goes there, with its frame.
    seen = next(i for i, e in enumerate(events) if e.source == "camera" and i > k)
    page.locator(f'svg.tandem-lanes g[data-step="{seen}"] rect').first.click()
    wait_for(lambda: review.shown_step == seen, 20)
    assert dashboard.selected == events[seen].node and review.frame.visible
    assert int(review.timeline.value) == seen + 1
    page.get_by_text("answered by the camera:", exact=False).first.wait_for()
    page.get_by_text(f"step {seen + 1}/{len(events)}", exact=False).first.wait_for()
    shot(page, "review-timeline")


def test_two_sessions_compared_diverge_at_the_first_differing_step(
    page: Page, dashboard: Dashboard
) -> None:
    open_session(page, dashboard, 1)
    label = dashboard.review.compare.label_of(2)
    choose(page, "Compare with", label)
    words = page.get_by_text("Diverged at step", exact=False).first
    words.wait_for()
    # Where the store's own paths of the two sessions part, counted on #1's timeline.
    store = dashboard.store
    a, b = store.path(1), store.path(2)
    n = next(i for i, (x, y) in enumerate(zip(a, b, strict=False)) if x != y)
    steps = [k for k, e in enumerate(store.events(1)) if is_step(e)]
    node, outcome = a[n]
    text = words.inner_text()
    assert re.match(rf"Diverged at step {steps[n] + 1}\b", text), text
    assert node in text and f"{outcome} (#1)" in text and f"{b[n][1]} (#2)" in text
    assert page.locator("svg.tandem-lanes line.diverged").count() == 2  # on both pictures
    words.scroll_into_view_if_needed()
    shot(page, "review-compare")


def test_a_studys_table_shows_its_conditions_and_sessions(
    page: Page, dashboard: Dashboard, data: Path
) -> None:
    page.get_by_text("Study", exact=True).first.click()  # the folder
    choose(page, "Study", "tiny")
    page.get_by_text("Study tiny", exact=False).first.wait_for()
    with SessionStore(data, read_only=True) as store:
        counted = finished(study_sessions(store.db, "tiny"))
    per_condition = Counter(c.split("/")[-2] for c, _ in counted)  # the behaviour varies
    assert set(per_condition) == {"cooperative", "hesitant"}
    table = page.locator("table").filter(has_text="condition").last
    for condition, n in per_condition.items():
        row = table.locator("tr").filter(has_text=condition)
        assert row.locator("td").nth(1).inner_text().strip() == str(n)
    page.get_by_text(f"{sum(per_condition.values())} sessions in 2 conditions",
                     exact=False).first.wait_for()  # fmt: skip
    wait_for(lambda: dashboard.review.study.figure.visible, 30)
    images = page.locator("img")
    wait_for(lambda: any((images.nth(i).bounding_box() or {}).get("height", 0) > 300
                         for i in range(images.count())), 20)  # fmt: skip
    table.scroll_into_view_if_needed()
    shot(page, "review-study")


def test_reviewing_session_after_session_keeps_the_same_elements(dashboard: Dashboard) -> None:
    from app.benchmark.memory import replayed

    review = dashboard.review

    def review_all() -> int:
        for session in dashboard.store.list_sessions():
            label = next(k for k, v in review._ids.items() if v == session.id)
            review.open(label)
            review.show_step(len(review.events) - 1)
            for other in list(review.compare._ids)[:2]:
                review.compare.compare(other)
        review.study.show("tiny")
        return sum(replayed(dashboard.server).values())

    review.refresh()
    first = review_all()
    # The elements' contents are replaced: a page joining now gets as many messages.
    assert review_all() == first and review_all() == first


def test_an_old_untimed_session_is_reviewed_with_its_counts(tmp_path: Path) -> None:
    shutil.copy(OLD_STORE, tmp_path / "sessions.db")
    d = Dashboard("127.0.0.1", free_port(), "default.toml",
                  DashboardSettings(data_dir=str(tmp_path), load_models=False))  # fmt: skip
    try:
        review = d.review
        review.open(next(iter(review._ids)))
        assert review.events and ", untimed" in str(review.summary.content)
        assert "untimed" in str(review.metrics.content)
        assert "untimed: one step each" in str(review.lanes.content)
        review.show_step(len(review.events) - 1)
        assert d.selected == review.events[-1].node
        assert review.study.pick.value == "(no studies)"
    finally:
        d.close()


def test_a_session_with_camera_frames_downloads_as_mcap_with_them(
    page: Page, dashboard: Dashboard, tmp_path: Path
) -> None:
    from tests.test_dashboard_export import downloaded, joint_states

    open_session(page, dashboard, 3)  # the simulated camera's session
    name = "tandem-session-3.mcap"
    states, others = joint_states(downloaded(page, "Export MCAP", name, tmp_path))
    events = dashboard.store.events(3, with_jpeg=True)
    frames = [e.evidence.jpeg for e in events if e.evidence is not None and e.evidence.jpeg]
    assert frames and [bytes(m.data) for m in others["/camera/image/compressed"]] == frames
    assert states and len(others["/robot_description"]) == 1
